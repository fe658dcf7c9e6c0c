"""Shared pieces of the autofocus methods: per-pulse signals, images, sharpness guard, records."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..core import geometry, sampling
from ..core.grid import Grid
from ..core.types import PhaseHistory
from ..errors import SarcliInputError, SarcliWarning

__all__ = ["AutofocusResult", "DECISION_CODES", "apply_phase_correction", "remove_linear_phase", "estimation_grid",
           "pulse_signals", "pulse_images", "correlation", "agreement_threshold", "form", "sharpness",
           "keep_if_sharper", "guarded_grid", "MAX_ESTIMATION_PIXELS"]

#: Largest estimation grid (pixels) of PGA and minimum entropy; bigger grids are cut to a central
#: square of this size.
MAX_ESTIMATION_PIXELS = 400 * 400
#: Largest guarded grid of minimum entropy (pixels; its single-pulse image stack is P times this).
MAX_GUARDED_PIXELS = 192 * 192


#: What an autofocus run decided (:attr:`AutofocusResult.code`): ``applied`` (a correction is
#: applied); ``no_common_error`` (the halves of the scene show no error common to both, so there is
#: nothing to apply); ``untrusted`` (an error common to the scene, but the halves predict the estimate
#: leaves no less than it removes, or more than the method's bound); ``less_sharp`` (the estimate
#: would leave the image less sharp); ``not_cross_validated`` (the grid is too narrow for two
#: halves, so the estimate cannot be checked).
DECISION_CODES = ("applied", "no_common_error", "untrusted", "less_sharp", "not_cross_validated")


@dataclass
class AutofocusResult:
    """An autofocus estimate and how it was reached.

    Attributes
    ----------
    phase_rad : ndarray, shape (P,)
        ``ε̂_p`` with its constant and linear part removed; the data are corrected by ``exp(-i ε̂)``.
    method : str
    iterations : int
    entropy_before, entropy_after, peak_to_mean_before, peak_to_mean_after : float
        Sharpness of the image on the estimation grid before and after the correction.
    history : dict
        Per-iteration diagnostics (e.g. rms phase increment, window width, entropy).
    accepted : bool
        False when an estimate was made but replaced by zero (its code says why).
    code : str
        The decision, one of :data:`DECISION_CODES`.
    """

    phase_rad: np.ndarray
    method: str
    iterations: int = 0
    entropy_before: float = float("nan")
    entropy_after: float = float("nan")
    peak_to_mean_before: float = float("nan")
    peak_to_mean_after: float = float("nan")
    history: dict = field(default_factory=dict)
    accepted: bool = True
    code: str = "applied"

    def reject(self, why: str | None = None, code: str = "less_sharp") -> None:
        """No correction after all: the estimate replaced by zero and the image left as it was
        (``why`` appended to the decision, where given; ``code`` one of :data:`DECISION_CODES`)."""
        if code not in DECISION_CODES:
            raise ValueError(f"unknown autofocus decision code {code!r}")
        self.phase_rad = np.zeros_like(self.phase_rad)
        self.accepted = False
        self.code = code
        self.entropy_after, self.peak_to_mean_after = self.entropy_before, self.peak_to_mean_before
        if why:
            self.history["decision"] = self.history.get("decision", "") + why

    def describe(self) -> str:
        """One line: what was applied and why (the method's own decision when it records one)."""
        rms = float(np.sqrt(np.mean(self.phase_rad ** 2)))
        what = (f"{self.method}: {rms:.3g} rad rms applied" if self.accepted and np.any(self.phase_rad)
                else f"{self.method}: no correction applied [{self.code}]")
        why = self.history.get("decision") or (
            "it lowers the entropy and does not lower the peak-to-mean ratio" if self.accepted and np.any(self.phase_rad)
            else "no estimate made the image sharper")
        return (f"{what} ({why}); entropy {self.entropy_before:.4f} -> {self.entropy_after:.4f}, "
                f"peak-to-mean {self.peak_to_mean_before:.4g} -> {self.peak_to_mean_after:.4g}")

    def summary(self) -> dict:
        return {"method": self.method, "iterations": self.iterations, "accepted": self.accepted, "code": self.code,
                "entropy_before": self.entropy_before, "entropy_after": self.entropy_after,
                "peak_to_mean_before": self.peak_to_mean_before, "peak_to_mean_after": self.peak_to_mean_after,
                "rms_phase_rad": float(np.sqrt(np.mean(self.phase_rad ** 2)))}


def remove_linear_phase(phase_rad, azimuth_rad) -> np.ndarray:
    """``phase`` minus its least-squares fit ``a + b·θ`` over look azimuth (the unobservable part)."""
    phi = np.asarray(phase_rad, dtype=np.float64)
    th = np.unwrap(np.asarray(azimuth_rad, dtype=np.float64))
    if phi.size < 2:
        return phi - phi.mean()
    A = np.column_stack([np.ones_like(th), th - th.mean()])
    coef, *_ = np.linalg.lstsq(A, phi, rcond=None)
    return phi - A @ coef


def apply_phase_correction(ph: PhaseHistory, phase_rad, method: str, decision: str | None = None) -> PhaseHistory:
    """``data · exp(-i phase_p)``, the estimate accumulated into ``attrs['autofocus_phase_rad']``
    and, when given, what was decided and why into ``attrs['autofocus_decision']`` (joined with
    `` | `` over repeated runs; written as a root attribute of the file)."""
    phi = np.asarray(phase_rad, dtype=np.float64)
    if phi.shape != (ph.data.shape[0],):
        raise SarcliInputError(f"autofocus phase has shape {phi.shape}, expected ({ph.data.shape[0]},)")
    data = np.asarray(ph.data)
    out = (data * np.exp(-1j * phi)[:, None]).astype(data.dtype)
    attrs = dict(ph.attrs)
    prev = attrs.get("autofocus_phase_rad")
    total = phi if prev is None else np.asarray(prev, np.float64) + phi
    prev_method = attrs.get("autofocus_method")
    attrs["autofocus_phase_rad"] = total
    attrs["autofocus_method"] = method if not prev_method else f"{prev_method}+{method}"
    if decision:
        prev_decision = attrs.get("autofocus_decision")
        attrs["autofocus_decision"] = decision if not prev_decision else f"{prev_decision} | {decision}"
    return PhaseHistory(data=out, acquisition=ph.acquisition, truth=ph.truth, attrs=attrs)


#: An axis of the estimation grid whose spacing exceeds this fraction of the image's Nyquist spacing
#: is resampled to :data:`ESTIMATION_OVERSAMPLE` pixels per Nyquist spacing (:func:`estimation_grid`).
ESTIMATION_COARSEST = 0.9
ESTIMATION_OVERSAMPLE = 1.6


def estimation_grid(grid: Grid, max_pixels: int = MAX_ESTIMATION_PIXELS, acq=None) -> Grid:
    """``grid``, or its central square window of at most ``max_pixels`` pixels (same spacing).

    With ``acq``, an axis whose spacing exceeds :data:`ESTIMATION_COARSEST` of the image's
    Nyquist spacing (:func:`sarcli.core.geometry.image_sampling`) is first resampled over the same
    extent at that spacing over :data:`ESTIMATION_OVERSAMPLE`: on a grid near or beyond it a bright
    point's energy depends on where it falls between pixels, and a phase search moves points onto
    pixels (GOTCHA, an injected 1.1 rad rms error, 100 m at 0.33, 0.4 and 0.5 m pixels against a
    Nyquist spacing of 0.31-0.33 m: 0.24, 0.22 and 1.01 rad rms of it left, 0.020 at 0.3 m; so
    resampled, 0.018 at each of 0.3, 0.4 and 0.5 m).
    """
    if acq is not None:
        from ..core.geometry import image_sampling

        sx, sy = image_sampling(acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad)
        dx, dy = grid.dx, grid.dy
        if dx > ESTIMATION_COARSEST * sx:
            dx = sx / ESTIMATION_OVERSAMPLE
        if dy > ESTIMATION_COARSEST * sy:
            dy = sy / ESTIMATION_OVERSAMPLE
        if (dx, dy) != (grid.dx, grid.dy):
            nx = max(2, int(np.ceil(grid.nx * grid.dx / dx / 2.0)) * 2)
            ny = max(2, int(np.ceil(grid.ny * grid.dy / dy / 2.0)) * 2)
            grid = Grid(nx, ny, dx, dy, grid.cx, grid.cy)
    if grid.nx * grid.ny <= max_pixels:
        return grid
    side = int(np.sqrt(max_pixels)) // 2 * 2
    nx, ny = min(grid.nx, side), min(grid.ny, side)
    return Grid(nx, ny, grid.dx, grid.dy, grid.cx, grid.cy)


def guarded_grid(grid: Grid, acq, factor: float = 2.0, max_pixels: int = MAX_GUARDED_PIXELS) -> Grid:
    """``grid`` widened ``factor`` times about its centre (a guard band), at most to the alias-free
    diameter and ``max_pixels`` pixels.

    The entropy of an image measured on a window can fall when a phase error pushes energy out of
    the window, which lets minimum entropy drift from the truth; the wider the band the less
    (``docs/autofocus.md``: on the simulated scenes of ``tests/test_autofocus.py`` 0.45 rad rms
    from the truth without it, 0.05 rad with 1.5×, 0.044 rad with 2×, which there is the whole
    alias-free diameter).
    """
    r_rg, r_cr = acq.alias_free_radii()
    diam = 2.0 * max(min(r_rg, 1e9), min(r_cr, 1e9))
    nx = int(min(round(grid.nx * factor), max(grid.nx, diam / grid.dx))) // 2 * 2
    ny = int(min(round(grid.ny * factor), max(grid.ny, diam / grid.dy))) // 2 * 2
    scale = min(1.0, np.sqrt(max_pixels / (nx * ny)))
    nx, ny = max(2, int(nx * scale) // 2 * 2), max(2, int(ny * scale) // 2 * 2)
    return Grid(nx, ny, grid.dx, grid.dy, grid.cx, grid.cy)


def _phases(acq, pts):
    """ψ[p, j, k] of the data model for points ``pts`` [K, 3] (bistatic aware)."""
    if acq.model == "spherical":
        t, q, r0 = acq.range_geometry()
        dr = geometry.bistatic_differential_range(t, q, r0, pts)
        return sampling.range_wavenumbers(acq.frequencies_2d)[:, :, None] * dr[:, None, :]
    return geometry.signal_phase(acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad, pts)


def pulse_signals(ph: PhaseHistory, points_m, *, chunk: int = 16) -> np.ndarray:
    """Each pulse's matched filter at each point, ``z[p, k] = (1/M) Σ_j d[p, j] exp(+i ψ_pjk)``.

    For an isolated scatterer at ``x_k`` this is ``a_k exp(i ε_p)``: the scatterer's phase
    history across pulses, compensated to its own exact range history (any flight path). Spherical
    data: the compiled ``sarcli._native._autofocus.point_signals`` (exact to about 1e-9 of the
    sum: Horner's scheme about each pulse's frequency line); far-field: the sum itself.
    """
    pts = np.atleast_2d(np.asarray(points_m, dtype=np.float64))
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    d = np.ascontiguousarray(ph.data, dtype=np.complex128)
    out = np.empty((d.shape[0], len(pts)), dtype=np.complex128)
    acq = ph.acquisition
    if acq.model == "spherical":
        # compiled: Horner's scheme in the frequency step's phasor (no exponential per sample)
        from .._native import load

        t, q, r0 = acq.range_geometry()
        dr = np.ascontiguousarray(geometry.bistatic_differential_range(t, q, r0, pts), dtype=np.float64)
        kw = np.ascontiguousarray(np.broadcast_to(sampling.range_wavenumbers(acq.frequencies_2d), d.shape))
        load("autofocus").point_signals(d, kw, dr.reshape(d.shape[0], len(pts)), out)
        return out
    for s in range(0, len(pts), chunk):
        psi = _phases(ph.acquisition, pts[s:s + chunk])
        out[:, s:s + chunk] = np.einsum("pj,pjk->pk", d, np.exp(1j * psi)) / d.shape[1]
    return out


def form(ph: PhaseHistory, grid: Grid, phase_rad=None) -> np.ndarray:
    """The matched-filter image of ``ph · exp(-i phase)`` on ``grid`` (backprojection, else direct)."""
    from ..formers.formation import form_image

    src = ph if phase_rad is None else apply_phase_correction(ph, phase_rad, "trial")
    method = "backprojection" if ph.data.shape[1] >= 2 else "direct"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SarcliWarning)
            return np.asarray(form_image(src, method, grid=grid).image)
    except SarcliInputError:
        return np.asarray(form_image(src, "direct", grid=grid).image)


def pulse_images(ph: PhaseHistory, grid: Grid) -> np.ndarray:
    """The stack ``B[p, s]`` of single-pulse images (complex64, P × pixels): ``f = Σ_p B[p]``
    is the matched filter (up to the factor P), and ``Σ_p exp(-i φ_p) B[p]`` is the image of the
    data corrected by ``φ``."""
    acq = ph.acquisition
    P = ph.data.shape[0]
    out = np.empty((P, grid.nx * grid.ny), dtype=np.complex64)
    d = np.asarray(ph.data)
    if acq.model == "spherical" and ph.data.shape[1] >= 2:
        from ..formers import backprojection as bp

        col = acq.collection().with_(frequency_hz=acq.frequencies_2d)
        with warnings.catch_warnings():  # a guard band may reach the unambiguous window: harmless
            warnings.simplefilter("ignore", SarcliWarning)
            for p in range(P):
                out[p] = bp.backproject(d[p:p + 1], col.pulses(slice(p, p + 1)), grid).ravel()
        return out
    pts = grid.points().reshape(-1, 3)
    for s in range(0, P, 8):
        sub = PhaseHistory(d[s:s + 8], acq.subset(pulses=slice(s, s + 8)))
        psi = _phases(sub.acquisition, pts)  # [p, j, s]
        out[s:s + 8] = np.einsum("pj,pjs->ps", d[s:s + 8], np.exp(1j * psi)) / d.shape[1]
    return out


def correlation(a, b) -> float:
    """``a·b / (|a| |b|)`` of two estimates (0 when either is zero)."""
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    return float(np.dot(a, b) / (na * nb)) if na > 0 and nb > 0 else 0.0


def agreement_threshold(dof: int) -> float:
    """The correlation two independent estimates with ``dof`` free parameters exceed by chance
    with probability about 2 % (two standard deviations, ``2/√dof``).

    Two halves of a scene with no common phase error give estimates whose correlation is
    about normal with variance ``1/dof``; a correlation above this is evidence of an error
    common to the scene.
    """
    return 2.0 / np.sqrt(dof)


def sharpness(image):
    """``(entropy, peak_to_mean)`` of an image (:mod:`sarcli.analysis.speckle`)."""
    from ..analysis.speckle import image_entropy, peak_to_mean

    return image_entropy(image), peak_to_mean(image)


def keep_if_sharper(ph: PhaseHistory, grid: Grid, result: AutofocusResult, candidates,
                    imager=None) -> AutofocusResult:
    """Pick, among zero and the candidate estimates, the one with the lowest entropy whose
    peak-to-mean ratio is not below the uncorrected image's: autofocus never leaves an image
    less sharp than it found it (by either measure). The images are ``imager.image(φ)`` (PGA
    passes :func:`sarcli.autofocus._sharpness.sharpness_imager`'s, which minimum entropy reports
    too), else :func:`form`'s on ``grid``."""
    image = imager.image if imager is not None else (lambda phi: form(ph, grid, phi))
    h0, m0 = sharpness(image(np.zeros(ph.data.shape[0])))
    best, best_h, best_m = np.zeros(ph.data.shape[0]), h0, m0
    for phi in candidates:
        h, m = sharpness(image(phi))
        if h < best_h and m >= m0:
            best, best_h, best_m = phi, h, m
    result.entropy_before, result.peak_to_mean_before = h0, m0
    result.entropy_after, result.peak_to_mean_after = best_h, best_m
    if not np.any(best) and not any(np.any(c) for c in candidates):
        result.code = "no_common_error"   # the method estimated no error at all
    if not np.any(best) and any(np.any(c) for c in candidates):
        result.accepted, result.code = False, "less_sharp"
        warnings.warn(f"autofocus ({result.method}) did not sharpen the image (entropy {h0:.4f}, "
                      f"peak-to-mean {m0:.4g} before): no correction applied", AutofocusWarning, stacklevel=3)
    result.phase_rad = best
    return result


class AutofocusWarning(SarcliWarning):
    """Autofocus found no correction that sharpens the image; the message gives the sharpness."""


def synthetic_phase_error(n_pulses: int, seed: int = 0) -> np.ndarray:
    """A per-pulse phase error (rad) of the kind autofocus must remove, for validation: quadratic
    (4 rad at the ends of the aperture) + smooth random (four sinusoids, ~1 rad) + jitter
    (0.15 rad rms), seeded.

    Examples
    --------
    >>> e = synthetic_phase_error(200)
    >>> e.shape, bool(abs(e).max() > 2)
    ((200,), True)
    """
    rng = np.random.default_rng(100 + seed)
    u = np.linspace(-1, 1, n_pulses)
    err = 4.0 * u ** 2
    for k in range(1, 5):
        err += rng.normal(0, 0.6 / k) * np.sin(np.pi * k * u + rng.uniform(0, 2 * np.pi))
    return err + rng.normal(0, 0.15, n_pulses)
