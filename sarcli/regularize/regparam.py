"""Choice of the regularisation weight λ (``lam='auto'``).

Criteria
--------
Along a short decreasing path ``SELECT_PATH`` (six values from 0.3 to 0.001, ratio 3.13, in the normalised
units of :mod:`sarcli.regularize.driver`), each solve warm-started from the previous one, the residual
``‖A f_λ − b‖²`` and the degrees of freedom of the fit ``dof(λ) = tr ∂(A f_λ)/∂b`` are measured;
the degrees of freedom by one Monte-Carlo probe (Ramani, Blu & Unser 2008): the same solver,
iteration for iteration, on ``b + δε``, and ``dof ≈ Re εᴴ A (f(b + δε) − f(b)) / δ``.

* **SURE** (the noise power σ² known): ``‖A f_λ − b‖² − n σ_e² + 2 σ_e² dof(λ)``, an unbiased
  estimate of the prediction error ``E‖A f_λ − A f‖²`` when the noise power is σ_e².
* **Modified GCV** (no noise power needed): ``n ‖A f_λ − b‖² / (n − γ dof(λ))²`` with
  γ = 1.4 (Kim & Gu 2004; γ = 1 is Wahba's GCV, which picks too small a λ when the image has
  more unknowns than the data, as SAR grids at half the resolution do). It walks the path; its
  minimum gives Wahba's ``σ̂² = ‖A f_λ − b‖² / (n − dof(λ))``, and λ* minimises SURE with σ̂².

Speckle counts as noise: ``σ_e² = σ² + κ (‖b‖²/n − σ²)`` with ``κ = (1 − π/4) max(0, 1 − n/N)``
(:func:`speckle_fraction`; N pixels, n data). The prediction error is that of the complex data;
an image is read for its magnitude, the local mean reflectivity, about which fully developed
speckle is a zero-mean fluctuation carrying 1 − π/4 of the power (Goodman). The N − n image
dimensions the data do not fix hold that speckle at the pixel scale; an image should average it as
it averages noise. Without the term the prediction error's minimum lies 10-100 × below the
magnitude error's on scenes that fill the default grid (docs/regularize.md).

λ* minimises the criterion: a parabola in log λ through the smallest path value and its two
neighbours. The path stops once the criterion has risen twice in a row past its minimum; when the
minimum is at an end the path extends past it by the same ratio (up to ``lam_max``, down to
``lam_min``) while the criterion still falls. The criterion's curve is returned for the image file.

The discrepancy principle (:func:`discrepancy_lambda`, ``‖A f_λ − b‖² = target · n σ²``) is kept
as a function; it needs σ² and the whole path down to the least-squares end, and its
degrees-of-freedom correction is a calibrated rule.

Noise power σ²
--------------
1. From the file: ``attrs['noise_power']`` (written by the simulator; a CPHD reader can supply
   its NoiseLevel the same way).
2. Else estimated from the data (:func:`estimate_noise_power`): each pulse's samples are
   Blackman-Harris-windowed over frequency and transformed to a range profile; every scatterer
   inside the image lies within ``R = max |x|`` (grid corner) of the reference point, so range
   bins beyond ``R`` (plus the window's main lobe) hold noise only. σ² is their median power
   over ln 2 (the median of an exponential variable), divided by ``Σ w²``. Needs uniformly spaced
   frequencies and a range window wider than the scene; scatterers outside the image (real
   clutter) raise the estimate, hence λ.
3. Else no σ² is assumed: GCV walks the path, and its residual estimate at GCV's minimum
   ``σ̂² = ‖A f_λ − b‖² / (n − dof(λ))`` (Wahba) takes σ²'s place in SURE (with the speckle
   term). It needs no empty range bin; it
   counts everything the image does not explain as noise (clutter outside the image, model
   error), and it is biased low where the image has as many degrees of freedom as the data.
   A scale of the data's fine-scale part (MAD along frequency or pulses) is not used: a
   random-phase scene that fills the range window is itself white along both, so that estimate
   measures the scene.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..core import sampling
from ..core.geometry import C
from ..core.windows import BLACKMAN_HARRIS_MAINLOBE_BINS, blackman_harris
from ..errors import SarcliInputError

__all__ = ["NOISE_CODES", "LAM_PATH", "SELECT_PATH", "GCV_GAMMA", "STOP_AFTER", "DISCREPANCY_TAU", "DISCREPANCY_KAPPA",
           "FLOOR_MARGIN", "UNFITTABLE_RATIO", "LamChoice", "PathChoice", "Noise", "estimate_noise_power",
           "noise_power", "discrepancy_lambda", "select_lambda", "speckle_fraction", "SPECKLE_FRACTION",
           "gcv_score", "sure_score", "mc_dof"]

#: Where σ² came from (``parameters['lam_selection']['noise_code']``): the file's attribute, the
#: range bins outside the scene, or none (GCV's residual estimate took its place).
NOISE_CODES = {"file attribute noise_power": "file", "estimated from range bins outside the scene": "range_bins"}

#: Decreasing λ path (normalised units of :mod:`sarcli.regularize.driver`; ℓ1 zeroes the image at λ ≥ 2).
LAM_PATH = tuple(float(v) for v in np.geomspace(1.0, 1e-3, 13))
#: Classical discrepancy factor τ: ‖Af − b‖² = τ n_b σ² (used when kappa is None).
DISCREPANCY_TAU = 1.0
#: Degrees-of-freedom-corrected target r_min + κ (1 − r_min) of the ratio ‖Af − b‖² / (n_b σ²) of
#: :func:`discrepancy_lambda` (an estimate with dof degrees of freedom has E‖Af − b‖² =
#: σ²(n_b − dof), so the least-squares end already sits below 1; κ is a calibrated fraction).
DISCREPANCY_KAPPA = 0.25
#: ... and at least this far above the floor r_min (σ² estimated to ±15 % can put r_min above 1).
FLOOR_MARGIN = 0.1
#: r_min above this: the data cannot be fitted to the noise level (clutter outside the image,
#: noiseless data, model error); no λ is chosen (status 'above at the smallest λ').
UNFITTABLE_RATIO = 1.5


def estimate_noise_power(data, frequency_hz, scene_radius_m: float, *, margin_bins: int = 2):
    """σ² = E|n|² of white noise in phase-history samples, from the range bins outside the scene.

    Parameters
    ----------
    data : ndarray (P, M) complex
    frequency_hz : ndarray (M,) or (P, M)
        Must be equally spaced along each pulse (:func:`sarcli.core.sampling.equally_spaced`).
    scene_radius_m : float
        Largest |differential range| of any scatterer (e.g. the distance from the data's
        reference point to the farthest grid corner).
    margin_bins : int
        Extra guard bins beyond the window's main lobe.

    Returns
    -------
    float or None
        The estimate, or None when it cannot be made (non-uniform frequencies, fewer than 8
        frequencies, or no range bin outside the scene).
    """
    d = np.asarray(data)
    if d.ndim != 2 or d.shape[1] < 8:
        return None
    try:
        _, dalpha = sampling.equally_spaced(frequency_hz, "the noise estimate")
    except SarcliInputError:
        return None
    step = float(np.median(np.abs(dalpha)))
    m = d.shape[1]
    r_bin = C / (2.0 * step * m)  # range per bin (m); the window is m bins
    guard = int(np.ceil(scene_radius_m / r_bin)) + BLACKMAN_HARRIS_MAINLOBE_BINS + int(margin_bins)
    idx = np.abs(np.fft.fftfreq(m) * m)  # |bin| from the reference range, both signs
    noise_bins = idx > guard
    if not noise_bins.any():
        return None
    w = blackman_harris(m)
    prof = np.fft.fft(d * w, axis=1)[:, noise_bins]
    power = np.abs(prof) ** 2
    return float(np.median(power) / np.log(2.0) / np.sum(w**2))


def noise_power(ph, grid):
    """σ² of a phase history and where it came from: ``(sigma2, source)`` or ``(None, reason)``.

    ``attrs['noise_power']`` when present (and > 0), else :func:`estimate_noise_power` with the
    scene radius of ``grid`` (its farthest corner from the origin, the data's reference point).
    """
    val = (ph.attrs or {}).get("noise_power")
    try:
        val = float(val) if val is not None else None
    except (TypeError, ValueError):
        val = None
    if val is not None and np.isfinite(val) and val > 0:
        return val, "file attribute noise_power"
    x, y = grid.x, grid.y
    radius = float(np.sqrt(max(abs(x[0]), abs(x[-1])) ** 2 + max(abs(y[0]), abs(y[-1])) ** 2))
    radius += 0.5 * float(np.hypot(grid.dx, grid.dy))
    est = estimate_noise_power(ph.data, ph.acquisition.frequency_hz, radius)
    if est is None or not est > 0:
        return None, "no noise estimate (non-uniform frequencies or no range bin outside the scene)"
    return est, "estimated from range bins outside the scene"


@dataclass
class LamChoice:
    """The chosen λ and the discrepancy curve.

    Attributes
    ----------
    lam : float
        λ*.
    lams, ratios : list of float
        The λ path solved (decreasing) and ``‖A f_λ − b‖² / (n_b σ²)`` at each.
    target : float
        The ratio λ* attains (τ, or r_min + κ(1 − r_min)).
    start : ndarray or None
        Solution at the path λ nearest below λ* (a warm start for the final solve).
    status : str
        'bracketed', 'below at the largest λ' (even the largest λ fits below the noise: λ* = it),
        or 'above at the smallest λ' (the data cannot be fitted to the noise level: model error
        or an underestimated σ²; λ* = the smallest λ).
    """

    lam: float
    lams: list = field(default_factory=list)
    ratios: list = field(default_factory=list)
    target: float = DISCREPANCY_TAU
    start: np.ndarray | None = None
    status: str = "bracketed"


def discrepancy_lambda(solve: Callable, residual2: Callable, noise_energy: float, *,
                       lams=LAM_PATH, tau: float = DISCREPANCY_TAU, kappa: float | None = None,
                       callback=None) -> LamChoice:
    """λ with ``‖A f_λ − b‖² = target · noise_energy`` on a decreasing, warm-started path.

    Parameters
    ----------
    solve : callable
        ``solve(lam, x0) -> f`` (x0 None for the first λ).
    residual2 : callable
        ``residual2(f) -> ‖A f − b‖²``.
    noise_energy : float
        ``n_b σ²`` (same units as ``residual2``).
    lams : sequence of float
        Decreasing λ values.
    tau : float
        Discrepancy factor (target = τ) when ``kappa`` is None; the path stops at the first λ
        below it.
    kappa : float, optional
        Degrees-of-freedom-corrected target: the whole path is solved and the target is
        ``max(r_min + κ (1 − r_min), 1.1 r_min)``, ``r_min`` the ratio at the smallest λ; none
        when ``r_min > UNFITTABLE_RATIO`` (the data cannot be fitted to the noise level).
    callback : callable, optional
        ``callback(lam, ratio)`` after each solve.

    Returns
    -------
    LamChoice
    """
    lams = sorted((float(v) for v in lams), reverse=True)
    if not lams or not noise_energy > 0:
        raise ValueError("discrepancy_lambda needs a λ path and a positive noise energy")
    out = LamChoice(lam=lams[-1], target=float(tau))
    x = None
    xs = []
    for lam in lams:
        x = solve(lam, x)
        ratio = float(residual2(x)) / noise_energy
        out.lams.append(lam)
        out.ratios.append(ratio)
        xs.append(x)
        if callback is not None:
            callback(lam, ratio)
        if kappa is None and ratio <= tau:
            break
    if kappa is not None:
        r_min = min(out.ratios)
        out.target = float(max(r_min + kappa * (1.0 - r_min), (1.0 + FLOOR_MARGIN) * r_min))
        if r_min > UNFITTABLE_RATIO:
            out.target = 0.0  # unreachable: no λ is chosen
    target = out.target
    below = [i for i, r in enumerate(out.ratios) if r <= target]
    if not below:
        out.start, out.status = x, "above at the smallest λ"
        return out
    i = below[0]
    out.start = xs[i]
    if i == 0:
        out.lam, out.status = out.lams[0], "below at the largest λ"
        return out
    (l0, r0), (l1, r1) = (out.lams[i - 1], out.ratios[i - 1]), (out.lams[i], out.ratios[i])
    t = (np.log(r0) - np.log(target)) / (np.log(r0) - np.log(r1)) if (r1 > 0 and r0 > r1) else 0.5
    out.lam = float(np.exp(np.log(l0) + np.clip(t, 0.0, 1.0) * (np.log(l1) - np.log(l0))))
    return out


# -- criteria that need no noise level (or use an estimated one), on a short warm-started path ------

#: Path of the generalised cross-validation / SURE selection: 0.3 down to 1e-3, six values, ratio 3.13
#: (normalised units of :mod:`sarcli.regularize.driver`); it stops early once the criterion has risen
#: ``STOP_AFTER`` times in a row past its minimum.
SELECT_PATH = tuple(float(v) for v in np.geomspace(0.3, 1e-3, 6))
#: Modified GCV weight γ of the degrees of freedom (Kim & Gu's γ = 1.4; γ = 1 is Wahba's GCV).
GCV_GAMMA = 1.4
#: Fraction of the scene's power that is speckle to the image's magnitude: fully developed speckle
#: (many scatterers per resolution cell, or random-phase pixels finer than the resolution) has a
#: Rayleigh magnitude whose mean squared is π/4 of its power, so 1 − π/4 of the power is the
#: zero-mean fluctuation around the local mean reflectivity (Goodman 1976), which an image read for
#: its magnitude should average away as it does noise.
SPECKLE_FRACTION = 1.0 - np.pi / 4.0
#: Consecutive rises of the criterion past its minimum that end the path.
STOP_AFTER = 2
#: Smallest λ the path extends down to while its criterion still falls at the bottom (normalised units
#: of :mod:`sarcli.regularize.driver`; two decades below ``SELECT_PATH``'s end: there the prior weighs
#: less than 1e-5 of the data term's scale, and the fit is the least-squares fit of the data).
LAM_MIN = 1e-5
#: Relative change of the criterion between two path points below which it is flat: the path stops
#: extending (smaller λ would change nothing measurable).
FLAT_REL = 1e-3


def speckle_fraction(n_pixels: int, n_data: int) -> float:
    """κ of :func:`select_lambda`: the fraction of the scene's power counted as speckle noise.

    ``SPECKLE_FRACTION · max(0, 1 − n/N)`` for N pixels and n data. The data fix n of the image's
    N dimensions; when N > n the prior fills the other N − n, and at the pixel scale those carry
    the random phases of the pixels within each resolution cell, so that share of the image is
    fully developed speckle to the magnitude (the default grid has 4 pixels per resolution cell:
    N ≈ 4n, κ ≈ 0.75 · 0.21). With N ≤ n every pixel is fixed by the data and λ follows the noise
    alone: whether a pixel's own magnitude is speckled (several scatterers in it) cannot be seen in
    the data, whose second-order statistics are the same either way.
    """
    if n_pixels <= 0 or n_data <= 0:
        return 0.0
    return float(SPECKLE_FRACTION * max(0.0, 1.0 - n_data / n_pixels))


def gcv_score(residual2: float, dof: float, n_data: int, gamma: float = GCV_GAMMA) -> float:
    """Modified generalised cross-validation ``V(λ) = n ‖A f_λ − b‖² / (n − γ dof(λ))²``.

    Needs no noise level. ``dof(λ) = tr ∂(A f_λ)/∂b`` (degrees of freedom of the fit); γ > 1
    penalises them more than Wahba's GCV (γ = 1), which under-regularises when the image has more
    unknowns than the data. ``inf`` when ``γ dof ≥ n`` (the fit has used up the data).
    """
    room = n_data - gamma * dof
    return float(n_data * residual2 / room**2) if room > 0 else float("inf")


def sure_score(residual2: float, dof: float, n_data: int, sigma2: float) -> float:
    """Stein's unbiased risk estimate of the prediction error ``E‖A f_λ − A f‖²``:
    ``‖A f_λ − b‖² − n σ² + 2 σ² dof(λ)`` (complex circular noise of power σ² = E|n_i|²)."""
    return float(residual2 - n_data * sigma2 + 2.0 * sigma2 * dof)


@dataclass
class PathChoice:
    """λ chosen on a path by GCV or SURE.

    Attributes
    ----------
    lam : float
        λ*: the minimiser of the criterion, from a parabola in log λ through the three path
        points around the smallest value (the smallest path point when it lies at an end).
    lams, residuals, dofs, scores : list of float
        Path λ (decreasing), ‖A f_λ − b‖², Monte-Carlo degrees of freedom, criterion.
    index : int
        Path point of the smallest score (its solution warm-starts the final solve).
    start : ndarray or None
        That solution.
    status : str
        'interior' (a minimum between two path points), 'at the largest λ' or 'at the smallest λ'.
    at_limit : bool
        λ* sits at a path end that could not be extended further: the floor ``lam_min`` or the
        ceiling ``lam_max`` was reached (or the criterion went flat there) with the criterion still
        lower than at the path's other points.
    noise_power : float
        ``‖A f_λ − b‖² / (n − dof)`` (Wahba's residual estimate of σ²) at the minimum of GCV.
    walk_scores : list of float
        The criterion that walked the path (GCV, or SURE when σ² is known; equal to ``scores``
        unless GCV walked and speckle was then added).
    speckle : float
        The speckle power counted as noise.
    """

    lam: float
    lams: list = field(default_factory=list)
    residuals: list = field(default_factory=list)
    dofs: list = field(default_factory=list)
    scores: list = field(default_factory=list)
    index: int = 0
    start: np.ndarray | None = None
    status: str = "interior"
    at_limit: bool = False
    noise_power: float = float("nan")
    walk_scores: list = field(default_factory=list)
    speckle: float = 0.0


@dataclass(frozen=True)
class Noise:
    """What the criterion counts as noise: the power σ² per sample (None: unknown, GCV walks the
    path) and the speckle ``κ (‖b‖²/n − σ²)``, κ = ``speckle_fraction`` (:func:`speckle_fraction`),
    ``data_power`` = ``‖b‖²/n``."""

    sigma2: float | None = None
    speckle_fraction: float = 0.0
    data_power: float = 0.0

    def speckle(self, sigma2: float) -> float:
        """The speckle power ``κ max(‖b‖²/n − σ², 0)`` counted as noise beside ``sigma2``."""
        return float(self.speckle_fraction) * max(float(self.data_power) - sigma2, 0.0)


def select_lambda(solve: Callable, n_data: int, *, noise: Noise = Noise(), lams=SELECT_PATH, gamma: float = GCV_GAMMA,
                  stop_after: int = STOP_AFTER, lam_max: float | None = None, lam_min: float | None = None,
                  callback=None) -> PathChoice:
    """λ minimising GCV (``noise.sigma2`` None) or SURE (``noise.sigma2`` given) on a decreasing path.

    Parameters
    ----------
    solve : callable
        ``solve(lam, start) -> (f, residual2, dof)``: the solution at ``lam``, warm-started by
        the caller from the solution of its call number ``start`` (None: the previous call),
        ``‖A f − b‖²`` and the degrees of freedom ``tr ∂(A f)/∂b`` (e.g. Monte-Carlo,
        :func:`mc_dof`).
    n_data : int
        Number of (complex) data samples n.
    lams : sequence of float
        Decreasing λ values.
    noise : Noise
        ``sigma2``: the noise power in the units of ``residual2`` per sample: SURE; None: modified
        GCV (:func:`gcv_score`). ``speckle_fraction``, ``data_power``: κ and ``‖b‖² / n``; the
        speckle the image should average away, ``κ (‖b‖²/n − σ²)`` per sample
        (:data:`SPECKLE_FRACTION`), counts as noise: SURE with ``σ² + κ (‖b‖²/n − σ²)``. With
        ``sigma2`` None the path is walked by GCV, whose minimum gives Wahba's
        ``σ̂² = ‖A f − b‖² / (n − dof)``; λ* then minimises that SURE with σ̂² on the same path.
    stop_after : int
        Stop once the score has risen this many consecutive times after its running minimum.
    lam_max : float, optional
        When the smallest score is at the largest λ, the path is extended upwards by the path's
        ratio, warm-started from the largest λ's solution, until the score rises or λ would
        exceed ``lam_max``.
    lam_min : float, optional
        Likewise downwards: when the smallest score is at the smallest λ, the path goes on by its
        ratio, each point warm-started from the previous one, until the score rises, goes flat
        (relative change below :data:`FLAT_REL`) or λ would fall below ``lam_min``.
    callback : callable, optional
        ``callback(index, lam, score)`` after each path point.

    Returns
    -------
    PathChoice
    """
    lams = sorted((float(v) for v in lams), reverse=True)
    if not lams or n_data < 1:
        raise ValueError("select_lambda needs a λ path and data")
    out = PathChoice(lam=lams[0])
    sols, calls = [], []  # solutions, and the call number of each path point (both in the order of out.lams)
    sigma2 = noise.sigma2
    if sigma2 is not None:
        out.speckle = noise.speckle(sigma2)
    walk = (lambda r2, dof: gcv_score(r2, dof, n_data, gamma)) if sigma2 is None else \
        (lambda r2, dof: sure_score(r2, dof, n_data, sigma2 + out.speckle))
    crit = [walk]  # the criterion λ* minimises (it changes once, from GCV to SURE, when speckle > 0)

    def point(lam, start, at):
        f, r2, dof = solve(lam, start)
        dof = float(np.clip(dof, 0.0, n_data))
        score = crit[0](r2, dof)
        for lst, val in ((out.lams, lam), (out.residuals, float(r2)), (out.dofs, dof), (out.scores, score),
                         (out.walk_scores, walk(r2, dof)), (sols, f), (calls, len(calls))):
            lst.insert(at, val)
        if callback is not None:
            callback(len(calls) - 1, lam, score)
        return score

    rises = 0
    for k, lam in enumerate(lams):
        score = point(lam, None, len(out.lams))
        best = int(np.argmin(out.scores))
        rises = rises + 1 if (k > best and score >= out.scores[k - 1]) else 0
        if rises >= stop_after:
            break
    ratio = lams[0] / lams[1] if len(lams) > 1 else 10.0 ** 0.5
    flat = _extend_down(point, out, ratio, lam_min)
    if sigma2 is None and float(noise.speckle_fraction) > 0:
        _gcv_to_sure(out, crit, n_data, noise)
    while lam_max is not None and int(np.argmin(out.scores)) == 0 and out.lams[0] * ratio <= lam_max * (1 + 1e-9):
        point(out.lams[0] * ratio, calls[0], 0)
    return _vertex(out, sols, n_data, ratio, flat, lam_min, lam_max)


def _gcv_to_sure(out: PathChoice, crit: list, n_data: int, noise: Noise) -> None:
    """At GCV's minimum, Wahba's ``σ̂² = ‖A f − b‖² / (n − dof)``; the criterion (``crit[0]``) and
    the path's scores become SURE with σ̂² plus the speckle power."""
    i = int(np.argmin(out.scores))
    room = n_data - out.dofs[i]
    s2 = float(out.residuals[i] / room) if room > 0 else float("nan")
    if np.isfinite(s2):
        out.noise_power, out.speckle = s2, noise.speckle(s2)
        crit[0] = lambda r2, dof: sure_score(r2, dof, n_data, s2 + out.speckle)  # noqa: E731
        out.scores = [crit[0](r, d) for r, d in zip(out.residuals, out.dofs)]


def _extend_down(point, out, ratio, lam_min) -> bool:
    """Go on down the path while its smallest score is at its smallest λ; True when it went flat."""
    flat = False
    while lam_min is not None and int(np.argmin(out.scores)) == len(out.scores) - 1 and not flat \
            and out.lams[-1] / ratio >= lam_min * (1 - 1e-9):
        prev = out.scores[-1]
        score = point(out.lams[-1] / ratio, None, len(out.lams))
        flat = bool(np.isfinite(prev) and abs(prev - score) <= FLAT_REL * max(abs(prev), abs(score)))
    return flat


def _vertex(out, sols, n_data, ratio, flat, lam_min, lam_max) -> PathChoice:
    """λ* of a walked path: the smallest score, refined by a parabola in log λ when interior."""
    s = np.asarray(out.scores)
    i = int(np.argmin(s))
    out.index, out.start = i, sols[i]
    if not np.isfinite(out.noise_power):
        room = n_data - out.dofs[i]
        out.noise_power = float(out.residuals[i] / room) if room > 0 else float("nan")
    if i == 0 or i == len(s) - 1 or not np.all(np.isfinite(s[i - 1:i + 2])):
        out.lam = out.lams[i]
        out.status = "at the largest λ" if i == 0 else ("at the smallest λ" if i == len(s) - 1 else "interior")
        # an end is a limit when the path could not (or need not) go further that way
        out.at_limit = (i == 0 and (lam_max is None or out.lams[0] * ratio > lam_max * (1 + 1e-9))) or \
            (i == len(s) - 1 and i > 0 and (flat or lam_min is None or out.lams[-1] / ratio < lam_min * (1 - 1e-9)))
        return out
    # parabola through (log λ, score) at i-1, i, i+1; its vertex lies between the outer two
    x = np.log(np.asarray(out.lams[i - 1:i + 2]))
    y = s[i - 1:i + 2]
    c2, c1, _ = np.polyfit(x, y, 2)
    xv = -c1 / (2 * c2) if c2 > 0 else x[1]
    out.lam = float(np.exp(np.clip(xv, min(x[0], x[2]), max(x[0], x[2]))))
    return out


def mc_dof(probe_adjoint: np.ndarray, delta: float, f: np.ndarray, f_perturbed: np.ndarray) -> float:
    """Monte-Carlo degrees of freedom ``Re εᴴ A (f(b + δε) − f(b)) / δ`` (Ramani, Blu & Unser 2008).

    ``probe_adjoint`` is ``Aᴴε`` for a probe ε with ``E εεᴴ = I`` (complex circular), so the
    estimate needs no application of A; its expectation is ``tr ∂(Af)/∂b``, exact for a solver
    that is linear in b (Tikhonov), the local divergence otherwise.
    """
    return float(np.vdot(probe_adjoint, f_perturbed - f).real) / delta
