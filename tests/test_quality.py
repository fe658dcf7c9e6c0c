"""IPR measurement (IRW, PSLR, ISLR, peak position) against the theorem's prediction; `sar quality`."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from scipy.signal import windows as sw

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.cli.main import cli
from sarcli.errors import SarcliInputError
from sarcli.core.grid import Grid
from sarcli.core.types import Image, PhaseHistory, Truth
from sarcli.io.hdf5 import write_image, write_phase_history
from sarcli.analysis.psf import predicted_ipr
from sarcli.analysis.quality import image_quality, measure_ipr
from sarcli.analysis.ipr import profile_metrics

# the three-points demo (configs/three-points.yaml) at a reduced size: 128 frequencies, 64 pulses
F = np.linspace(9.7e9, 10.3e9, 128)
AZ = np.radians(np.linspace(48.5, 51.5, 64))
EL = np.radians(30.0)
GRID = Grid.square(5.0, 100)  # 10 cm pixels, resolution ~0.29 m x 0.33 m
POINTS = np.array([[0.0, 0.0, 0.0], [-3.0, 2.0, 0.0], [1.0, 4.0, 0.0]])
TAYLOR = np.outer(sw.taylor(AZ.size, nbar=4, sll=35), sw.taylor(F.size, nbar=4, sll=35))


def exact_mf_image(points, weights=None, grid=GRID):
    """Far-field data of unit points and its exact matched filter (eq. mf, 1/W), separable sums."""
    d = np.exp(-1j * geometry.signal_phase(F, AZ, EL, points)).sum(axis=-1)  # (P, M)
    w = np.ones(d.shape) if weights is None else weights
    kx, ky = geometry.kspace_coordinates(F, AZ, EL)
    u = np.exp(1j * kx.reshape(-1, 1) * grid.x[None, :])
    v = np.exp(1j * ky.reshape(-1, 1) * grid.y[None, :]) * (w * d).reshape(-1, 1)
    return d, (v.T @ u) / w.sum()


def _acq():
    return Acquisition(frequency_hz=F, azimuth_rad=AZ, elevation_rad=np.full(AZ.size, EL), grid=GRID,
                       model="farfield", name="three-points-small")


def test_profile_metrics_on_a_sinc():
    # 1-D uniform aperture: |sinc| with nulls at integers; IRW 0.886, PSLR -13.26 dB
    s = np.linspace(-10.5, 10.5, 21 * 200 + 1)
    met = profile_metrics(s, np.abs(np.sinc(s)), sidelobe_extent=10.0)
    assert met["irw_m"] == pytest.approx(0.8859, abs=0.002)
    assert abs(met["pslr_db"] - (-13.26)) < 0.3
    assert met["first_nulls_m"] == pytest.approx([-1.0, 1.0], abs=0.01)
    # sidelobe energy of sinc^2 within |s| <= 10 is 1 - 0.9028 - tail(>10) ~ 0.0874 -> about -10.1 dB
    assert -10.5 < met["islr_db"] < -9.7


def test_predicted_pslr_uniform_is_the_sinc_value():
    pred = predicted_ipr(_acq())
    for d in ("range", "cross_range"):
        assert abs(pred[d]["pslr_db"] - (-13.26)) < 0.3


@pytest.mark.parametrize("weights", [None, TAYLOR], ids=["uniform", "taylor"])
def test_three_points_irw_matches_prediction(weights):
    _, img = exact_mf_image(POINTS, weights)
    pred = predicted_ipr(_acq(), window="none" if weights is None else weights)
    rho = geometry.resolutions(F, AZ, EL)
    for p in POINTS:
        m = measure_ipr(img, GRID.x, GRID.y, at=p[:2], range_direction_rad=pred["range_direction_rad"],
                        resolution_m=rho)
        for d in ("range", "cross_range"):
            assert abs(m[d]["irw_m"] / pred[d]["irw_m"] - 1) < 0.05, (p, d)
        assert m["peak_position_error_m"] < GRID.dx  # points on pixel centres
        assert m["peak_magnitude"] == pytest.approx(1.0, abs=0.01)


def test_single_offgrid_point_sidelobes_match_prediction():
    at = (0.037, -0.052)  # between pixel centres
    _, img = exact_mf_image(np.array([[at[0], at[1], 0.0]]))
    pred = predicted_ipr(_acq())
    m = measure_ipr(img, GRID.x, GRID.y, at=at, range_direction_rad=pred["range_direction_rad"],
                    resolution_m=geometry.resolutions(F, AZ, EL))
    assert m["peak_position_error_m"] < 0.1 * GRID.dx
    assert m["peak_magnitude"] == pytest.approx(1.0, abs=0.005)
    for d in ("range", "cross_range"):
        assert abs(m[d]["pslr_db"] - pred[d]["pslr_db"]) < 0.3
        assert abs(m[d]["islr_db"] - pred[d]["islr_db"]) < 0.5


def test_measure_without_resolution_estimates_it():
    _, img = exact_mf_image(POINTS[:1])
    m = measure_ipr(img, GRID.x, GRID.y, range_direction_rad=np.radians(50.0))
    rho = geometry.resolutions(F, AZ, EL)
    assert m["range"]["resolution_m"] == pytest.approx(rho[0], rel=0.05)
    assert m["peak_position_error_m"] is None
    with pytest.raises(SarcliInputError, match="not within"):
        measure_ipr(img, GRID.x, GRID.y, at=(40.0, 0.0), resolution_m=rho)


def _ph_and_image(weights=None):
    d, img = exact_mf_image(POINTS, weights)
    ph = PhaseHistory(data=d, acquisition=_acq(),
                      truth=Truth(point_position_m=POINTS, point_amplitude=np.ones(3, complex)))
    image = Image(image=img, x_m=GRID.x, y_m=GRID.y, method="direct",
                  parameters={"window": "none" if weights is None else "taylor"})
    return ph, image


def test_image_quality_names_every_truth_point_and_is_json():
    ph, image = _ph_and_image()
    res = image_quality(image, ph)
    assert [r["name"] for r in res] == ["T1", "T2", "T3"]
    for r in res:
        assert r["expected_peak_magnitude"] == 1.0
        assert abs(r["irw_ratio"]["range"] - 1) < 0.05 and abs(r["irw_ratio"]["cross_range"] - 1) < 0.05
    assert json.loads(json.dumps(res))[0]["predicted"]["range"]["irw_m"] > 0
    with pytest.raises(SarcliInputError, match="no targets"):
        image_quality(image, ph.acquisition)


def test_cli_quality_json_and_table(tmp_path):
    ph, image = _ph_and_image()
    ph_path, img_path = tmp_path / "ph.h5", tmp_path / "img.h5"
    write_phase_history(ph_path, ph)
    write_image(img_path, image)
    runner = CliRunner()
    res = runner.invoke(cli, ["quality", str(img_path), "--ph", str(ph_path), "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert [r["name"] for r in out] == ["T1", "T2", "T3"]
    assert out[1]["measured"]["peak_position_error_m"] < GRID.dx
    res = runner.invoke(cli, ["quality", str(img_path), "--ph", str(ph_path), "--at", "1,4"])
    assert res.exit_code == 0 and "T1" in res.output and "IRW_r" in res.output
    res = runner.invoke(cli, ["quality", str(img_path)])
    assert res.exit_code == 2 and "--ph" in res.output


def test_quality_table_names_the_targets_at_the_border_and_says_what_irw_is():
    from sarcli.cli.quality import results_table
    from sarcli.core.windows import IRW_FACTOR_UNIFORM

    ph, image = _ph_and_image()
    res = image_quality(image, ph)
    cut = {r["name"] for r in res if r["measured"]["patch_truncated"]}
    assert cut and cut != {"T1", "T2", "T3"}  # T1 at the centre keeps its whole neighbourhood
    text = results_table(res)
    for r in res:
        m = r["measured"]
        note = f"note: {r['name']} at ({m['x_m']:.3f}, {m['y_m']:.3f}) m lies near the image border"
        assert (note in text) == (r["name"] in cut), (r["name"], text)
    assert "IRW: the -3 dB width of the main lobe along each cut, window none" in text
    assert f"about {1 / IRW_FACTOR_UNIFORM:.3f} x the IRW without a window" in text
    # what the footer claims: unwindowed, the predicted IRW is 0.886 of c/(2B cos el)
    rho_r = geometry.resolutions(F, AZ, np.full(AZ.size, EL))[0]
    assert res[0]["predicted"]["range"]["irw_m"] == pytest.approx(IRW_FACTOR_UNIFORM * rho_r, rel=0.01)


def test_cli_quality_with_a_config(tmp_path):
    cfg = {"name": "q", "model": "farfield",
           "frequencies": {"center_frequency_ghz": 10.0, "bandwidth_mhz": 600.0, "count": 128},
           "elevation_deg": 30.0, "azimuths": {"center_deg": 50.0, "extent_deg": 3.0, "count": 64},
           "image": {"half_width_m": 5.0, "pixels": 100},
           "scene": {"points": [{"position_m": [0.0, 0.0], "amplitude": 1.0},
                                {"position_m": [-3.0, 2.0], "amplitude": 1.0}]}}
    path = tmp_path / "acq.yaml"
    path.write_text(yaml.safe_dump(cfg))
    _, image = _ph_and_image()
    img_path = tmp_path / "img.h5"
    write_image(img_path, image)
    res = CliRunner().invoke(cli, ["quality", str(img_path), "--config", str(path), "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert [r["name"] for r in out] == ["T1", "T2"]
    assert abs(out[0]["irw_ratio"]["range"] - 1) < 0.05


@pytest.mark.parametrize("window", ["none", "taylor"])
def test_simulated_three_points_through_form_image(window, write_config):
    """End to end: YAML -> simulate (spherical) -> direct matched filter -> measured vs predicted."""
    from sarcli.io.config import load_acquisition
    from sarcli.formers.formation import form_image
    from sarcli.simulation.simulator import simulate

    from .conftest import CONFIGS

    cfg = yaml.safe_load((CONFIGS / "three-points.yaml").read_text())
    cfg["frequencies"]["count"] = 96
    cfg["azimuths"]["count"] = 48
    cfg["image"] = {"half_width_m": 5.0, "pixels": 80}
    ph = simulate(load_acquisition(write_config(cfg)), seed=1, snr_db=None)
    img = form_image(ph, method="direct", window=window)
    res = image_quality(img, ph)
    assert [r["name"] for r in res] == ["T1", "T2", "T3"]
    pixel = img.x_m[1] - img.x_m[0]
    for r in res:
        assert abs(r["irw_ratio"]["range"] - 1) < 0.05 and abs(r["irw_ratio"]["cross_range"] - 1) < 0.05
        assert r["measured"]["peak_position_error_m"] < pixel
        assert r["measured"]["peak_magnitude"] == pytest.approx(1.0, abs=0.02)
        assert r["predicted"]["window"] == window


def test_undersampled_image_is_flagged():
    from sarcli.errors import AliasingWarning

    coarse = Grid.square(5.0, 24)  # 42 cm pixels > 29 cm resolution
    d, img = exact_mf_image(POINTS[:1], grid=coarse)
    image = Image(image=img, x_m=coarse.x, y_m=coarse.y, method="direct")
    with pytest.warns(AliasingWarning, match="undersamples"):
        res = image_quality(image, _acq(), at=(0.0, 0.0))
    assert res[0]["undersampled"] is True
    ph, fine = _ph_and_image()
    assert image_quality(fine, ph, at=(0.0, 0.0))[0]["undersampled"] is False
