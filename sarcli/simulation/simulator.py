"""The simulator: acquisition + scene -> phase history, far-field or exact spherical.

- Point targets: the closed form ``d[p, j] = Σ_s a_s exp(-i ψ_pjs)`` with ψ from
  :func:`sarcli.core.geometry.signal_phase` (eq. ``eq1`` far-field, or the exact range), chunked over
  pulses so memory stays below ``chunk_elements`` complex numbers.
- Extended scenes (see :mod:`sarcli.simulation.scenes`): far-field data are the pixel model on the fine
  grid, evaluated by one type-2 NUFFT (FINUFFT, ``eps=1e-12``) at the wrapped dimensionless
  frequencies (exact on the fine grid, section ``sec: alias``); spherical data are the exact sum
  over fine cells, in a compiled loop over pulses that never holds P × M × cells.
- Noise: circular complex Gaussian with power ``mean|d|² / 10^(SNR/10)``, seeded.
- Samples come by blocks of pulses (:class:`Simulation`), stored complex64 unless asked for
  complex128; :func:`simulate_file` writes them to a file block by block.
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

__all__ = ["simulate", "simulate_file", "Simulation", "point_phase_history", "add_noise", "noise_power", "PRECISIONS"]

CHUNK_ELEMENTS = 2 ** 22
#: Samples per block of pulses that :func:`simulate_blocks` computes, adds noise to and hands on:
#: the simulator's working memory beyond the stored samples.
BLOCK_SAMPLES = 2 ** 22
#: Stored precision of the samples: the default complex64 (what CPHD files and radars deliver; its
#: rounding, 6e-8 relative, is far below any former's error) or complex128.
PRECISIONS = {"float32": np.complex64, "float64": np.complex128}


def point_phase_history(acq: Acquisition, positions, amplitudes, *, model=None,
                        chunk_elements=CHUNK_ELEMENTS, desc="points", rows=None) -> np.ndarray:
    """Closed-form phase history of point scatterers (complex128, shape (P, M), or the pulses of
    slice ``rows``).

    Spherical data of points in the plane z = 0 are the compiled exact sum (``_simulate.spherical_sum``,
    float64, the phasor advanced by multiplication along equally spaced frequencies); other points
    and far-field data are :func:`sarcli.core.geometry.signal_phase` in chunks of pulses of at most
    ``chunk_elements`` phases.
    """
    model = model or acq.model
    pos = np.atleast_2d(np.asarray(positions, float))
    amp = np.asarray(amplitudes, complex).reshape(-1)
    rows = slice(0, acq.n_pulses) if rows is None else rows
    P, M = rows.stop - rows.start, acq.n_frequencies
    out = np.zeros((P, M), complex)
    if amp.size == 0:
        return out
    f2 = acq.frequencies_2d[rows]
    if model == "spherical" and np.all(pos[:, 2] == 0):
        return _spherical_points(acq, rows, pos[:, :2], amp, out)
    step = max(1, chunk_elements // max(1, M * amp.size))
    for p0 in progress(range(0, P, step), desc=f"simulate {desc}", unit="chunk"):
        sl = slice(p0, min(P, p0 + step))
        g = slice(rows.start + sl.start, rows.start + sl.stop)
        psi = geometry.signal_phase(
            f2[sl], acq.azimuth_rad[g], acq.elevation_rad[g], pos, model=model,
            antenna_position_m=None if acq.antenna_position_m is None else acq.antenna_position_m[g],
            range_to_center_m=None if acq.range_to_center_m is None else acq.range_to_center_m[g])
        out[sl] = np.exp(-1j * psi) @ amp
    return out


def _spherical_points(acq: Acquisition, rows, xy, amp, out):
    """Exact spherical data of points on the plane z = 0 for pulses ``rows``, added into ``out``."""
    from .._native import load

    a = np.ascontiguousarray(acq.antenna_position_m[rows], dtype=np.float64)
    norm_ld = np.sqrt(np.sum(a.astype(np.longdouble) ** 2, axis=1))
    r0 = (norm_ld - acq.range_to_center_m[rows].astype(np.longdouble)).astype(np.float64)  # |a_p| - r0_p
    f2 = np.ascontiguousarray(acq.frequencies_2d[rows], dtype=np.float64)
    load("simulate").spherical_sum(f2, a, r0, np.ascontiguousarray(xy), np.ascontiguousarray(amp, np.complex128), out)
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
    sigma2 = noise_power(power, snr_db)
    return data + _noise(data.shape, sigma2, rng), sigma2


def noise_power(signal_power, snr_db) -> float:
    """σ² = mean signal power / 10^(SNR/10); 1 for a zero signal."""
    return signal_power / 10 ** (snr_db / 10) if signal_power > 0 else 1.0


def _noise(shape, sigma2, rng):
    """Noise of power σ², real and imaginary parts drawn interleaved sample by sample, so that the
    samples do not depend on how the pulses are split into blocks."""
    z = rng.standard_normal(tuple(shape) + (2,))
    return np.sqrt(sigma2 / 2) * (z[..., 0] + 1j * z[..., 1])


class Simulation:
    """A simulation prepared, whose samples come by blocks of pulses (:meth:`blocks`).

    Point scenes are computed block by block (twice with noise: once for the signal power that
    sets the noise, once to store), so their memory is one block whatever the collection's size;
    extended scenes are synthesised whole (a NUFFT or a sum over the fine grid) and served by
    blocks. ``truth``, ``attrs`` (``noise_power`` once the blocks are through) and ``acquisition``
    describe the result. Arguments as for :func:`simulate`.
    """

    def __init__(self, acq: Acquisition, *, seed=None, snr_db="config", model=None, dtype=np.complex64):
        model = model or acq.model
        if model not in ("farfield", "spherical"):
            raise SarcliInputError(f"model {model!r} unknown; expected 'farfield' or 'spherical'")
        if model == "spherical" and not acq.has_positions:
            raise SarcliInputError("model 'spherical' needs a flight path: set geometry.path to circle, line or "
                                   "positions in the config")
        acq = acq.with_(model=model)
        if seed is None:
            seed = acq.extra.get("seed")
        self.rng = np.random.default_rng(seed)
        self.snr = acq.snr_db if isinstance(snr_db, str) else snr_db
        self.dtype = np.dtype(dtype)
        self.model = model
        grid = acq.grid
        scene = acq.scene or {}
        self.pos, self.amp = point_targets(scene)
        # a dense truth only where the scene needs one (extended components): points keep their
        # positions and amplitudes, and a point scene on a 4096² grid does not carry two dense arrays
        extended = any(kind in scene for kind in ("phantom", "image_file"))
        self.whole = None
        truth_scene = truth_mag = None
        if extended:
            self.whole = point_phase_history(acq, self.pos, self.amp, model=model)
            truth_scene, truth_mag = np.zeros(grid.shape, complex), np.zeros(grid.shape)
            for kind in ("phantom", "image_file"):
                if kind in scene:
                    ext = synthesize_extended(scene[kind], grid, self.rng)
                    if model == "farfield":
                        self.whole += _farfield_extended(acq, ext.fine_values, ext.fine_grid)
                    else:
                        self.whole += _spherical_extended(acq, ext.fine_values, ext.fine_grid)
                    truth_scene += ext.truth
                    truth_mag += ext.truth_magnitude
            # points appear in the rasterised truth at their nearest pixel
            for (x, y, _), a in zip(self.pos, self.amp):
                r, c = grid.index_of(x, y)
                if 0 <= r < grid.ny and 0 <= c < grid.nx:
                    truth_scene[r, c] += a
                    truth_mag[r, c] += abs(a)
        self.attrs = {"seed": -1 if seed is None else int(seed)}
        self.attrs.update({k: v for k, v in acq.extra.items() if k.startswith("scene_center")})
        self.truth = Truth(point_position_m=self.pos, point_amplitude=self.amp, scene=truth_scene,
                           x_m=grid.x if extended else None, y_m=grid.y if extended else None, magnitude=truth_mag)
        self.acquisition = acq.with_(snr_db=self.snr)
        self.shape = (acq.n_pulses, acq.n_frequencies)

    def _signal(self, rows):
        if self.whole is not None:
            return self.whole[rows]
        return point_phase_history(self.acquisition, self.pos, self.amp, model=self.model, rows=rows)

    def row_blocks(self):
        """The slices of pulses :meth:`blocks` yields, each of at most :data:`BLOCK_SAMPLES` samples."""
        P, M = self.shape
        step = max(1, BLOCK_SAMPLES // max(1, M))
        return [slice(p, min(P, p + step)) for p in range(0, P, step)]

    def blocks(self):
        """``(rows, samples)`` for consecutive blocks of pulses, samples in the stored dtype."""
        blocks = self.row_blocks()
        sigma2 = None
        if self.snr is not None:   # the noise power needs the whole signal's mean power first
            total = 0.0
            for rows in progress(blocks, desc="simulate (signal power)", unit="block"):
                total += float(np.sum(np.abs(self._signal(rows)) ** 2))
            sigma2 = noise_power(total / (self.shape[0] * self.shape[1]), self.snr)
            self.attrs["noise_power"] = sigma2
        for rows in progress(blocks, desc="simulate", unit="block"):
            d = self._signal(rows)
            if sigma2 is not None:
                d = d + _noise(d.shape, sigma2, self.rng)
            yield rows, d.astype(self.dtype, copy=False)


def simulate(acq: Acquisition, *, seed=None, snr_db="config", model=None,
             dtype=np.complex64) -> PhaseHistory:
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
        complex64 (default) or complex128 for the stored samples; the sums are float64 either way.

    Returns
    -------
    PhaseHistory
        Data, the acquisition (with ``model`` set) and the truth: the point targets, and for
        extended scenes the scene on the grid (``truth.scene`` is None for a point-only scene).
        :func:`simulate_file` writes the same samples to a file by blocks of pulses.
    """
    sim = Simulation(acq, seed=seed, snr_db=snr_db, model=model, dtype=dtype)
    data = np.empty(sim.shape, dtype=sim.dtype)
    for rows, block in sim.blocks():
        data[rows] = block
    return PhaseHistory(data=data, acquisition=sim.acquisition, truth=sim.truth, attrs=sim.attrs)


def simulate_file(acq: Acquisition, path, *, seed=None, snr_db="config", model=None, dtype=np.complex64):
    """:func:`simulate` straight to a phase-history file, written by blocks of pulses: a point
    scene's memory is one block (:data:`BLOCK_SAMPLES` samples), not the collection.

    Returns
    -------
    PhaseHistory
        The acquisition, truth and attributes written, with ``data`` the file's samples left on
        disk (:class:`sarcli.io.pulses.PulseArray`).
    """
    from ..io.hdf5 import write_phase_history
    from ..io.pulses import PulseArray

    sim = Simulation(acq, seed=seed, snr_db=snr_db, model=model, dtype=dtype)
    samples = PulseArray(path, "phase_history", sim.shape, sim.dtype)
    ph = PhaseHistory(data=samples, acquisition=sim.acquisition, truth=sim.truth, attrs=sim.attrs)
    write_phase_history(path, ph, blocks=sim.blocks())
    return ph
