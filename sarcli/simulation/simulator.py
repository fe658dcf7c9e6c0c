"""The simulator: acquisition + scene -> phase history, far-field or exact spherical.

- Point targets: the closed form ``d[p, j] = Σ_s a_s exp(-i ψ_pjs)`` with ψ from
  :func:`sarcli.core.geometry.signal_phase` (eq. ``eq1`` far-field, or the exact range), chunked over
  pulses so memory stays below ``chunk_elements`` complex numbers.
- Extended scenes (see :mod:`sarcli.simulation.scenes`): far-field data are the pixel model on the fine
  grid, evaluated by one type-2 NUFFT (FINUFFT, ``eps=1e-12``) at the wrapped dimensionless
  frequencies (exact on the fine grid, section ``sec: alias``); spherical data are the exact sum
  over fine cells, in a compiled loop over pulses that never holds P × M × cells.
- Noise: circular complex Gaussian with power ``mean|d|² / 10^(SNR/10)``, seeded.
"""

from __future__ import annotations

import numpy as np

from ..core import geometry
from ..core.acquisition import Acquisition
from ..errors import SarcliInputError
from ..core.types import PhaseHistory, Truth
from .._util.progress import progress
from ..io.scene_spec import point_targets
from .scenes import synthesize_extended

__all__ = ["simulate", "point_phase_history", "add_noise"]

CHUNK_ELEMENTS = 2 ** 22


def point_phase_history(acq: Acquisition, positions, amplitudes, *, model=None,
                        chunk_elements=CHUNK_ELEMENTS, desc="points") -> np.ndarray:
    """Closed-form phase history of point scatterers (complex128, shape (P, M))."""
    model = model or acq.model
    pos = np.atleast_2d(np.asarray(positions, float))
    amp = np.asarray(amplitudes, complex).reshape(-1)
    P, M = acq.n_pulses, acq.n_frequencies
    out = np.zeros((P, M), complex)
    if amp.size == 0:
        return out
    step = max(1, chunk_elements // max(1, M * amp.size))
    f2 = acq.frequencies_2d
    for p0 in progress(range(0, P, step), desc=f"simulate {desc}", unit="chunk"):
        sl = slice(p0, min(P, p0 + step))
        psi = geometry.signal_phase(
            f2[sl], acq.azimuth_rad[sl], acq.elevation_rad[sl], pos, model=model,
            antenna_position_m=None if acq.antenna_position_m is None else acq.antenna_position_m[sl],
            range_to_center_m=None if acq.range_to_center_m is None else acq.range_to_center_m[sl])
        out[sl] = np.exp(-1j * psi) @ amp
    return out


def _farfield_extended(acq: Acquisition, values, grid) -> np.ndarray:
    """Pixel-model data of a fine grid by a type-2 NUFFT: Σ v[r, c] exp(-i (kx x_c + ky y_r))."""
    import finufft

    kx, ky = acq.kspace()
    t1 = geometry.wrap_phase(kx * grid.dx)
    t2 = geometry.wrap_phase(ky * grid.dy)
    # modes m = index - n//2 run over -n/2 .. n/2-1 for even n: finufft's modeord=0 ordering.
    v = np.ascontiguousarray(values, dtype=np.complex128)
    if grid.nx % 2 or grid.ny % 2:
        raise ValueError("the synthesis grid must have even sizes")
    c = finufft.nufft2d2(t2.ravel(), t1.ravel(), v, isign=-1, eps=1e-12)
    phase0 = np.exp(-1j * (kx * grid.cx + ky * grid.cy))
    return c.reshape(kx.shape) * phase0


def _spherical_extended(acq: Acquisition, values, grid) -> np.ndarray:
    """Exact spherical-model data of a fine grid (compiled loop, bounded memory)."""
    from .._native import load

    spherical_sum = load("simulate").spherical_sum

    mask = values != 0
    pts = grid.points()[mask]
    amp = values[mask].astype(np.complex128)
    f2 = np.ascontiguousarray(acq.frequencies_2d, dtype=np.float64)
    out = np.zeros((acq.n_pulses, acq.n_frequencies), np.complex128)
    a = np.ascontiguousarray(acq.antenna_position_m, dtype=np.float64)
    norm_ld = np.sqrt(np.sum(acq.antenna_position_m.astype(np.longdouble) ** 2, axis=1))
    r0 = (norm_ld - acq.range_to_center_m.astype(np.longdouble)).astype(np.float64)  # |a_p| - r0_p
    # blocks of pulses and points, one compiled call each, so the progress bar moves
    work = 1 << 23
    per_pulse = max(1, acq.n_frequencies * len(amp))
    step = max(1, min(acq.n_pulses // 32, work // per_pulse))
    npts = max(1, work // (step * acq.n_frequencies))
    xy = np.ascontiguousarray(pts[:, :2])
    for p0 in progress(range(0, acq.n_pulses, step), desc="simulate scene", unit="chunk"):
        sl = slice(p0, min(acq.n_pulses, p0 + step))
        for q in range(0, len(amp), npts):
            spherical_sum(f2[sl], a[sl], r0[sl], xy[q:q + npts], amp[q:q + npts], out[sl])
    return out


def add_noise(data, snr_db, rng) -> tuple[np.ndarray, float]:
    """Add circular complex Gaussian noise at ``snr_db`` (mean signal power over noise power).

    Returns the noisy data and the noise power σ² (E|n|²). A zero signal gets σ² = 1.
    """
    power = float(np.mean(np.abs(data) ** 2))
    sigma2 = power / 10 ** (snr_db / 10) if power > 0 else 1.0
    noise = np.sqrt(sigma2 / 2) * (rng.standard_normal(data.shape) + 1j * rng.standard_normal(data.shape))
    return data + noise, sigma2


def simulate(acq: Acquisition, *, seed=None, snr_db="config", model=None,
             dtype=np.complex128) -> PhaseHistory:
    """Simulate the phase history of the acquisition's scene.

    Parameters
    ----------
    acq : Acquisition
        Geometry, grid and scene (``acq.scene``).
    seed : int, optional
        Seeds the random phases and the noise (default: the config's ``seed``, else fresh entropy).
    snr_db : float or None, optional
        Signal-to-noise ratio in dB; default: the config's ``noise.snr_db``; None: noiseless.
    model : {'farfield', 'spherical'}, optional
        Data model (default: the acquisition's). Spherical needs antenna positions.
    dtype : numpy dtype
        complex128 (default) or complex64 for the stored samples.

    Returns
    -------
    PhaseHistory
        Data, the acquisition (with ``model`` set) and the truth: the point targets, and for
        extended scenes the scene on the grid (``truth.scene`` is None for a point-only scene).
    """
    model = model or acq.model
    if model not in ("farfield", "spherical"):
        raise SarcliInputError(f"model {model!r} unknown; expected 'farfield' or 'spherical'")
    if model == "spherical" and not acq.has_positions:
        raise SarcliInputError("model 'spherical' needs a flight path: set geometry.path to circle, line or "
                               "positions in the config")
    acq = acq.with_(model=model)
    if seed is None:
        seed = acq.extra.get("seed")
    rng = np.random.default_rng(seed)
    snr = acq.snr_db if isinstance(snr_db, str) else snr_db
    grid = acq.grid
    scene = acq.scene or {}
    pos, amp = point_targets(scene)
    data = point_phase_history(acq, pos, amp, model=model)
    # a dense truth only where the scene needs one (extended components): points keep their
    # positions and amplitudes, and a point scene on a 4096² grid does not carry two dense arrays
    extended = any(kind in scene for kind in ("phantom", "image_file"))
    truth_scene = np.zeros(grid.shape, complex) if extended else None
    truth_mag = np.zeros(grid.shape) if extended else None
    for kind in ("phantom", "image_file"):
        if kind in scene:
            ext = synthesize_extended(scene[kind], grid, rng)
            if model == "farfield":
                data += _farfield_extended(acq, ext.fine_values, ext.fine_grid)
            else:
                data += _spherical_extended(acq, ext.fine_values, ext.fine_grid)
            truth_scene += ext.truth
            truth_mag += ext.truth_magnitude
    # points appear in the rasterised truth (when there is one) at their nearest pixel
    for (x, y, _), a in zip(pos, amp) if extended else ():
        r, c = grid.index_of(x, y)
        if 0 <= r < grid.ny and 0 <= c < grid.nx:
            truth_scene[r, c] += a
            truth_mag[r, c] += abs(a)
    attrs = {"seed": -1 if seed is None else int(seed)}
    if snr is not None:
        data, sigma2 = add_noise(data, snr, rng)
        attrs["noise_power"] = sigma2
    attrs.update({k: v for k, v in acq.extra.items() if k.startswith("scene_center")})
    truth = Truth(point_position_m=pos, point_amplitude=amp, scene=truth_scene,
                  x_m=grid.x if extended else None, y_m=grid.y if extended else None, magnitude=truth_mag)
    return PhaseHistory(data=data.astype(dtype), acquisition=acq.with_(snr_db=snr), truth=truth, attrs=attrs)
