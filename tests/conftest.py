"""Shared fixtures: small acquisitions written to tmp_path, the repository's paths."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml

from sarcli.io.gotcha import gotcha_dir, gotcha_files

REPO = Path(__file__).resolve().parents[1]
CONFIGS = REPO / "configs"
#: A local copy of the AFRL GOTCHA pass files (sarcli.io.gotcha.gotcha_dir: $SARCLI_GOTCHA_DIR, else
#: ../shared/data/gotcha beside the repository); tests that need it skip with a reason when it is absent.
GOTCHA_DIR = gotcha_dir()
#: The four pass-1 HH files the GOTCHA tests read (fewer than four: every test marked ``gotcha`` skips).
GOTCHA_FILES = gotcha_files(GOTCHA_DIR)[:4]


def pytest_collection_modifyitems(config, items):
    """Tests marked ``gotcha`` need the four AFRL GOTCHA files: without them they skip as a group,
    with one reason, and nothing else in the suite depends on them (a clone of the repository has
    none; ``.ci/run`` runs the suite a second time that way)."""
    if len(GOTCHA_FILES) == 4:
        return
    skip = pytest.mark.skip(reason=f"the four AFRL GOTCHA pass-1 HH files are not in {GOTCHA_DIR} "
                                   "(set SARCLI_GOTCHA_DIR to a copy)")
    for item in items:
        if item.get_closest_marker("gotcha") is not None:
            item.add_marker(skip)


@pytest.fixture(autouse=True, scope="session")
def _no_user_calibration(tmp_path_factory):
    """Tests plan with the shipped reference cost model, never a calibration left in the user's
    cache by `sar plan` on this machine (sarcli.formers.planning.calibration): this machine's calibration
    file is that model, so `sar plan` does not measure the machine in every test."""
    import json

    from sarcli.formers.planning import calibration

    old = os.environ.get("SARCLI_CACHE_DIR")
    os.environ["SARCLI_CACHE_DIR"] = str(tmp_path_factory.mktemp("sarcli-cache"))
    shipped = json.loads(calibration.COST_MODEL_PATH.read_text())
    calibration.user_cost_model_path().write_text(json.dumps({**shipped, "machine": calibration.machine()}))
    yield
    if old is None:
        os.environ.pop("SARCLI_CACHE_DIR", None)
    else:
        os.environ["SARCLI_CACHE_DIR"] = old


@pytest.fixture(autouse=True)
def _bars_as_a_library_call_finds_them():
    """Each test starts with bars allowed, as a library call does: ``sar -q`` through click's
    CliRunner sets the process-wide quiet flag and nothing in-process resets it."""
    from sarcli._util.progress import set_quiet

    set_quiet(False)
    yield


def spy_rows(monkeypatch) -> list:
    """Record the number of pulses of every block read from samples left on disk (HDF5 or CPHD:
    both go through ``PulseSource.__getitem__`` or ``PulseSource.read_into``); returns the list it
    appends to."""
    from sarcli.io.pulses import PulseSource

    asked = []
    real, real_into = PulseSource.__getitem__, PulseSource.read_into

    def spy(self, key):
        out = real(self, key)
        asked.append(out.shape[0])
        return out

    def spy_into(self, rows, out):
        got = real_into(self, rows, out)
        asked.append(got.shape[0])
        return got

    monkeypatch.setattr(PulseSource, "__getitem__", spy)
    monkeypatch.setattr(PulseSource, "read_into", spy_into)
    return asked


def small_config(**overrides) -> dict:
    """A small three-points-like acquisition (fast to simulate and image)."""
    cfg = {
        "name": "small",
        "model": "spherical",
        "frequencies": {"center_frequency_ghz": 10.0, "bandwidth_mhz": 600.0, "count": 64},
        "elevation_deg": 30.0,
        "azimuths": {"center_deg": 50.0, "extent_deg": 3.0, "count": 32},
        "geometry": {"path": "circle", "standoff_range_m": 10000.0},
        "image": {"half_width_m": 4.0, "pixels": 64},
        "scene": {"points": [{"position_m": [0.0, 0.0], "amplitude": 1.0},
                             {"position_m": [-1.5, 1.0], "amplitude": [0.0, 1.0]}]},
    }
    for key, value in overrides.items():
        if value is None:
            cfg.pop(key, None)
        else:
            cfg[key] = value
    return cfg


@pytest.fixture
def write_config(tmp_path):
    """Write a config dict (or raw text) to a YAML file and return its path."""

    def _write(cfg, name="acq.yaml"):
        path = tmp_path / name
        path.write_text(cfg if isinstance(cfg, str) else yaml.safe_dump(cfg, sort_keys=False))
        return path

    return _write
