"""form_image: every method against the exact matched filter, through the public API and the CLI."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import sarcli
from sarcli.cli.main import cli
from sarcli.errors import DefocusWarning
from sarcli.formers.formation import image_error

from .conftest import CONFIGS

# documented bounds at default settings (docs/accuracy.md)
#: relative error against the exact matched filter, within 10x of what is measured (nufft 1.5e-10,
#: pfa 8.1e-7, backprojection 6.8e-5)
BOUNDS = {"nufft": 1e-9, "pfa": 8e-6, "backprojection": 5e-4}
#: |peak| - 1 of a lone unit point on a pixel centre (measured: direct 0, nufft 1.2e-11, pfa 5.4e-9,
#: backprojection 3.8e-6)
PEAK = {"direct": 1e-12, "nufft": 1e-10, "pfa": 5e-8, "backprojection": 4e-5}


def _three_points(model, **image):
    cfg = yaml.safe_load((CONFIGS / "three-points.yaml").read_text())
    cfg["frequencies"]["count"] = 128
    cfg["azimuths"]["count"] = 64
    cfg["image"] = {"half_width_m": 5.0, "pixels": 100, **image}
    return sarcli.simulate(sarcli.parse_acquisition(cfg), model=model)


@pytest.fixture(scope="module")
def ff():
    ph = _three_points("farfield")
    return ph, sarcli.form_image(ph, "direct")


@pytest.fixture(scope="module")
def sph():
    ph = _three_points("spherical")
    return ph, sarcli.form_image(ph, "direct")


@pytest.mark.parametrize("method", ["nufft", "pfa", "backprojection"])
def test_farfield_methods_match_direct(ff, method):
    ph, ref = ff
    img = sarcli.form_image(ph, method)
    assert image_error(img.image, ref.image) < BOUNDS[method]
    assert img.method == method and img.parameters["method"] == method and img.runtime_s > 0


def test_backprojection_matches_direct_on_spherical(sph):
    ph, ref = sph
    img = sarcli.form_image(ph, "backprojection")
    assert image_error(img.image, ref.image) < BOUNDS["backprojection"]


def test_farfield_method_on_spherical_data_warns_with_phase_error(sph):
    ph, ref = sph
    with pytest.warns(DefocusWarning, match=r"predicted phase error \d"):
        img = sarcli.form_image(ph, "nufft")
    assert image_error(img.image, ref.image) > 1e-2  # and it really is defocused


@pytest.mark.parametrize("method", ["direct", "nufft", "pfa", "backprojection"])
def test_unit_points_on_pixel_centres_peak_at_one(ff, sph, method):
    """Each target alone (another target's sidelobes would shift the peak by ~1e-3)."""
    from sarcli.simulation.simulator import point_phase_history

    ph0 = sph[0] if method in ("direct", "backprojection") else ff[0]
    acq = ph0.acquisition
    for pos in ph0.truth.point_position_m:
        ph = sarcli.PhaseHistory(point_phase_history(acq, [pos], [1.0]), acq)
        img = sarcli.form_image(ph, method)
        r, c = img.grid.index_of(pos[0], pos[1])
        win = np.abs(img.image[r - 2:r + 3, c - 2:c + 3])
        assert np.unravel_index(np.argmax(win), win.shape) == (2, 2)
        assert abs(np.abs(img.image[r, c]) - 1) < PEAK[method]


@pytest.mark.parametrize("window", ["hann", "hamming", "taylor"])
def test_windows_keep_unit_peak(ff, window):
    ph, _ = ff
    img = sarcli.form_image(ph, "nufft", window=window)
    r, c = img.grid.index_of(0.0, 0.0)
    assert abs(abs(img.image[r, c]) - 1) < 1e-3
    assert img.parameters["window"] == window


def test_error_falls_with_knobs(ff, sph):
    ph, ref = ff
    errs = [image_error(sarcli.form_image(ph, "nufft", eps=e).image, ref.image) for e in (1e-3, 1e-6, 1e-9)]
    assert errs[0] > errs[1] > errs[2]
    ph, ref = sph
    errs = [image_error(sarcli.form_image(ph, "backprojection", upsample=u, interp="linear").image, ref.image)
            for u in (2, 8)]
    assert errs[0] > errs[1]


def test_random_extended_scene(ff):
    """A random complex scene on a 2x finer grid (not the image grid): same bounds."""
    ph0, _ = ff
    acq = ph0.acquisition
    rng = np.random.default_rng(4)
    pts = np.column_stack([rng.uniform(-4, 4, 300), rng.uniform(-4, 4, 300), np.zeros(300)])
    amp = rng.standard_normal(300) + 1j * rng.standard_normal(300)
    from sarcli.simulation.simulator import point_phase_history

    for model in ("farfield", "spherical"):
        ph = sarcli.PhaseHistory(point_phase_history(acq, pts, amp, model=model), acq.with_(model=model))
        ref = sarcli.form_image(ph, "direct")
        methods = ["nufft", "pfa", "backprojection"] if model == "farfield" else ["backprojection"]
        for m in methods:
            assert image_error(sarcli.form_image(ph, m).image, ref.image) < BOUNDS[m], (model, m)


def test_grid_overrides(ff):
    ph, _ = ff
    img = sarcli.form_image(ph, "nufft", center=(1.0, 4.0), extent=(2.0, 1.0), pixel_size=0.05)
    assert img.image.shape == (20, 40)
    assert img.x_m[20] == pytest.approx(1.0) and img.y_m[10] == pytest.approx(4.0)
    r, c = np.unravel_index(np.argmax(np.abs(img.image)), img.image.shape)
    assert (img.x_m[c], img.y_m[r]) == (pytest.approx(1.0), pytest.approx(4.0))
    ref = sarcli.form_image(ph, "direct", center=(1.0, 4.0), extent=(2.0, 1.0), pixel_size=0.05)
    assert image_error(img.image, ref.image) < BOUNDS["nufft"]


def test_cli_form_image_and_regrid(tmp_path, ff):
    ph, ref = ff
    phf = tmp_path / "ph.h5"
    sarcli.write_phase_history(phf, ph)
    run = CliRunner().invoke
    res = run(cli, ["form-image", str(phf), "-o", str(tmp_path / "nufft.h5"), "--method", "nufft"])
    assert res.exit_code == 0, res.output
    img = sarcli.read_image(tmp_path / "nufft.h5")
    assert image_error(img.image, ref.image) < BOUNDS["nufft"] and img.parameters["eps"] == 1e-9
    res = run(cli, ["regrid", str(phf), "-o", str(tmp_path / "kg.h5")])
    assert res.exit_code == 0, res.output
    res = run(cli, ["form-image", str(tmp_path / "kg.h5"), "-o", str(tmp_path / "pfa.h5"), "--method", "pfa"])
    assert res.exit_code == 0, res.output
    via_kgrid = sarcli.read_image(tmp_path / "pfa.h5")
    direct_pfa = sarcli.form_image(ph, "pfa")
    assert np.allclose(via_kgrid.image, direct_pfa.image, rtol=0, atol=1e-10)
    res = run(cli, ["form-image", str(tmp_path / "kg.h5"), "-o", str(tmp_path / "x.h5"), "--method", "nufft"])
    assert res.exit_code == 2 and "k-grid" in res.output and not (tmp_path / "x.h5").exists()
    res = run(cli, ["form-image", str(phf), "-o", str(tmp_path / "y.h5"), "--extent", "a,b"])
    assert res.exit_code == 2 and "--extent" in res.output


@pytest.mark.parametrize("args,needle", [
    (["--pixel-size", "-1"], "--pixel-size"),
    (["--extent", "0"], "--extent"),
    (["--extent", "1e5", "--pixel-size", "0.001"], "pixels (more than"),
    (["--eps", "5"], "--eps"),
])
def test_cli_bad_grid_and_knobs_one_line(tmp_path, ff, args, needle):
    ph, _ = ff
    phf = tmp_path / "ph.h5"
    sarcli.write_phase_history(phf, ph)
    out = tmp_path / "img.h5"
    res = CliRunner().invoke(cli, ["form-image", str(phf), "-o", str(out), *args])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and needle in res.output
    assert len(res.output.strip().splitlines()) == 1 and not out.exists()
