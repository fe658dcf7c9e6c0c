"""The simulator against closed forms, the far-field limit, the noise level and seeding."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

import sarcli
from sarcli.cli.main import cli
from sarcli.simulation.simulator import point_phase_history

from .conftest import CONFIGS, small_config

C = 299_792_458.0


def _acq(write_config, **kw):
    return sarcli.load_acquisition(write_config(small_config(**kw)))


def test_farfield_points_equal_closed_form(write_config):
    acq = _acq(write_config, model="farfield")
    ph = sarcli.simulate(acq, dtype=np.complex128)
    f = acq.frequency_hz
    ref = np.zeros(ph.data.shape, complex)
    for p, (th, ph_el) in enumerate(zip(acq.azimuth_rad, acq.elevation_rad)):
        k = 4 * np.pi * f * np.cos(ph_el) / C
        for (x, y), a in [((0.0, 0.0), 1.0), ((-1.5, 1.0), 1j)]:
            ref[p] += a * np.exp(-1j * k * (np.cos(th) * x + np.sin(th) * y))
    assert np.max(np.abs(ph.data - ref)) < 1e-12


def test_spherical_points_equal_closed_form(write_config):
    acq = _acq(write_config)
    ph = sarcli.simulate(acq, dtype=np.complex128)
    ld = np.longdouble
    ref = np.zeros(ph.data.shape, complex)
    for p in range(acq.n_pulses):
        a = acq.antenna_position_m[p].astype(ld)
        for (x, y), amp in [((0.0, 0.0), 1.0), ((-1.5, 1.0), 1j)]:
            dr = np.sqrt(np.sum((a - np.array([x, y, 0.0], dtype=ld)) ** 2)) - ld(acq.range_to_center_m[p])
            ref[p] += amp * np.exp(-1j * (4 * np.pi * acq.frequency_hz / C) * float(dr))
    assert np.max(np.abs(ph.data - ref)) < 1e-12 * 50  # phases ~1e3 rad: 1e-12 relative to the phase


def test_spherical_tends_to_farfield_like_one_over_r0(write_config):
    diffs = []
    for r0 in (1e4, 1e5, 1e6):
        acq = _acq(write_config, geometry={"path": "circle", "standoff_range_m": r0})
        sph = sarcli.simulate(acq, dtype=np.complex128).data
        ff = sarcli.simulate(acq, model="farfield", dtype=np.complex128).data
        diffs.append(np.linalg.norm(sph - ff) / np.linalg.norm(ff))
    assert diffs[0] > diffs[1] > diffs[2]
    assert diffs[0] / diffs[1] == pytest.approx(10, rel=0.1)
    assert diffs[1] / diffs[2] == pytest.approx(10, rel=0.1)


def test_noise_power_matches_snr(write_config):
    cfg = small_config(frequencies={"center_frequency_ghz": 10, "bandwidth_mhz": 600, "count": 256},
                       azimuths={"center_deg": 50, "extent_deg": 3, "count": 256})
    acq = sarcli.load_acquisition(write_config(cfg))
    clean = sarcli.simulate(acq, snr_db=None).data
    noisy = sarcli.simulate(acq, snr_db=10.0, seed=3).data
    measured = np.mean(np.abs(clean) ** 2) / np.mean(np.abs(noisy - clean) ** 2)
    assert 10 * np.log10(measured) == pytest.approx(10.0, abs=10 * np.log10(1.05))


def test_same_seed_same_file(tmp_path):
    outs = []
    for i, seed in enumerate((5, 5, 6)):
        out = tmp_path / f"ph{i}.h5"
        res = CliRunner().invoke(cli, ["simulate", str(CONFIGS / "shepp-logan.yaml"), "-o", str(out), "--seed", str(seed)])
        assert res.exit_code == 0, res.output
        outs.append(sarcli.read_phase_history(out).data)
    assert np.array_equal(outs[0], outs[1])
    assert not np.array_equal(outs[0], outs[2])


def test_chunking_does_not_change_points(write_config):
    acq = _acq(write_config)
    pos = np.array([[0.0, 0.0, 0.0], [1.0, -2.0, 0.0], [2.5, 0.5, 0.0]])
    amp = np.array([1.0, 0.5j, -0.25])
    full = point_phase_history(acq, pos, amp)
    chunked = point_phase_history(acq, pos, amp, chunk_elements=64 * 3)  # one pulse at a time
    assert np.max(np.abs(full - chunked)) < 1e-13


def test_extended_scene_no_inverse_crime_and_truth(write_config):
    cfg = small_config(model="farfield", geometry={"path": "farfield"},
                       scene={"phantom": {"name": "disks", "half_width_m": 3.0, "upsample": 2}})
    ph = sarcli.simulate(sarcli.load_acquisition(write_config(cfg)))
    t = ph.truth
    assert t.scene.shape == (64, 64) and np.allclose(t.x_m, ph.acquisition.grid.x)
    # truth is the block mean of the 2x finer synthesis: values between 0 and 1, edges fractional
    assert t.scene.real.max() == pytest.approx(1.0) and np.any((t.scene.real > 0.05) & (t.scene.real < 0.95))
    # the data are NOT those of the truth on the reconstruction grid (no inverse crime)
    from sarcli.simulation.simulator import _farfield_extended

    same_grid = _farfield_extended(ph.acquisition, t.scene, ph.acquisition.grid)
    rel = np.linalg.norm(same_grid - ph.data) / np.linalg.norm(ph.data)
    assert rel > 1e-3


def test_random_phase_extended_spherical_matches_farfield_limit(write_config):
    cfg = small_config(geometry={"path": "circle", "standoff_range_m": 1e7},
                       scene={"phantom": {"name": "shepp-logan", "half_width_m": 3.0, "random_phase": True}})
    acq = sarcli.load_acquisition(write_config(cfg))
    sph = sarcli.simulate(acq, seed=1)
    ff = sarcli.simulate(acq, seed=1, model="farfield")
    assert np.array_equal(sph.truth.scene, ff.truth.scene)
    ph_ = np.angle(sph.truth.scene[sph.truth.magnitude > 0.2])
    assert abs(np.mean(np.exp(1j * ph_))) < 0.1 and ph_.size > 200  # phases really uniform
    assert np.linalg.norm(sph.data - ff.data) / np.linalg.norm(ff.data) < 5e-4   # measured 7.2e-5 at 10,000 km


def test_failing_simulate_leaves_no_file(write_config, tmp_path):
    path = write_config(small_config(model="farfield", geometry={"path": "farfield"}))
    out = tmp_path / "ph.h5"
    res = CliRunner().invoke(cli, ["simulate", str(path), "-o", str(out), "--model", "spherical"])
    assert res.exit_code == 2 and "flight path" in res.output
    assert not out.exists() and not list(tmp_path.glob(".ph.h5*"))


def test_memory_bounded_by_chunking():
    """A 512 x 256 collection of a 256² scene: P·M·pixels complex numbers would be 137 GB."""
    import tracemalloc

    cfg = small_config(model="farfield", geometry={"path": "farfield"},
                       frequencies={"center_frequency_ghz": 10.0, "bandwidth_mhz": 600.0, "count": 256},
                       azimuths={"center_deg": 50.0, "extent_deg": 6.0, "count": 512},
                       image={"half_width_m": 12.0, "pixels": 256},
                       scene={"phantom": {"name": "shepp-logan", "half_width_m": 10.0, "random_phase": True}})
    acq = sarcli.parse_acquisition(cfg)
    tracemalloc.start()
    ph = sarcli.simulate(acq, seed=0)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    full = 512 * 256 * 256 ** 2 * 16
    assert ph.data.shape == (512, 256) and np.all(np.isfinite(ph.data))
    assert peak < 300e6 and peak < full / 400


def test_complex64_by_default_and_the_same_samples_as_complex128(write_config, tmp_path):
    """Stored complex64 unless asked: the same sums rounded once (relative 6e-8 of the peak), also
    when written to a file by blocks of pulses; noise included, seed for seed."""
    from sarcli.simulation import simulate_file
    from sarcli.simulation import simulator

    acq = _acq(write_config)
    single = sarcli.simulate(acq, seed=4, snr_db=20.0)
    double = sarcli.simulate(acq, seed=4, snr_db=20.0, dtype=np.complex128)
    assert single.data.dtype == np.complex64 and double.data.dtype == np.complex128
    assert np.max(np.abs(single.data - double.data)) < 1e-7 * np.max(np.abs(double.data))
    assert single.attrs["noise_power"] == double.attrs["noise_power"]
    # by blocks of one pulse into a file: the same samples as in memory
    old = simulator.BLOCK_SAMPLES
    simulator.BLOCK_SAMPLES = acq.n_frequencies
    try:
        simulate_file(acq, tmp_path / "ph.h5", seed=4, snr_db=20.0)
        blocks = simulator.Simulation(acq, seed=4, snr_db=20.0).row_blocks()
    finally:
        simulator.BLOCK_SAMPLES = old
    assert len(blocks) == acq.n_pulses
    back = sarcli.read_phase_history(tmp_path / "ph.h5")
    assert back.data.dtype == np.complex64
    assert np.max(np.abs(back.data - double.data)) < 1e-7 * np.max(np.abs(double.data))
    assert back.attrs["noise_power"] == pytest.approx(double.attrs["noise_power"], rel=1e-12)
