"""`make demo` produces every file it promises (run on a reduced three-points config)."""

from __future__ import annotations

import json
import shutil
import subprocess

import pytest
import yaml

import sarcli

from .conftest import CONFIGS, REPO

PROMISED = ["three-points.h5", "three-points-ff.h5",
            "three-points-bp.h5", "three-points-bp.png", "three-points-bp.tif",
            "three-points-nufft.h5", "three-points-nufft.png", "three-points-nufft.tif",
            "three-points-quality.json",
            "three-points-ptv.h5", "three-points-ptv.png", "three-points-ptv.tif", "three-points-ptv-history.png"]


def test_make_demo_produces_every_file(tmp_path):
    installed = REPO / ".venv" / ".installed"
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    if not installed.exists() or installed.stat().st_mtime < (REPO / "pyproject.toml").stat().st_mtime:
        pytest.skip("the project's .venv is not set up by make (run `make test`), so make demo would reinstall")
    cfg = yaml.safe_load((CONFIGS / "three-points.yaml").read_text())
    cfg["frequencies"]["count"] = 64
    cfg["azimuths"]["count"] = 32
    cfg["image"] = {"half_width_m": 5.0, "pixels": 100}
    config = tmp_path / "small.yaml"
    config.write_text(yaml.safe_dump(cfg))
    out = tmp_path / "out"
    res = subprocess.run(["make", "-C", str(REPO), "demo", f"OUT={out}", f"DEMO_CONFIG={config}"],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    for name in PROMISED:
        assert (out / name).exists() and (out / name).stat().st_size > 0, name
    quality = json.loads((out / "three-points-quality.json").read_text())
    assert len(quality) == 3
    img = sarcli.read_image(out / "three-points-ptv.h5")
    assert img.method.startswith("regularize") and "objective" in img.history
    # a second run has nothing to redo: every target is a file and up to date
    again = subprocess.run(["make", "-C", str(REPO), "-q", f"OUT={out}", f"DEMO_CONFIG={config}",
                            *[str(out / n) for n in PROMISED if n.endswith(".h5") or n.endswith(".json")]],
                           capture_output=True, text=True)
    assert again.returncode == 0, again.stdout + again.stderr
