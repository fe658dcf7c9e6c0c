"""Choice of the regularisation weight λ: the discrepancy principle (``lam='auto'``).

Criterion (Morozov's discrepancy principle, corrected for the degrees of freedom)
----------------------------------------------------------------------------------
With data ``b = A f + n``, ``n`` white complex noise of power ``σ² = E|n_i|²`` over ``n_b``
samples, a good reconstruction explains the data down to the noise and no further. The ratio

    r(λ) = ‖A f_λ − b‖² / (n_b σ²)

grows monotonically with λ. The classical principle picks r(λ*) = τ = 1; but an estimate with
``dof`` degrees of freedom has E‖r‖² = σ²(n_b − dof), and here the image has a sizeable fraction
of the data's degrees of freedom (e.g. 1600 pixels for 3072 samples), so r = 1 over-smooths:
the least-squares end of the path already sits at ``r_min ≈ 0.6``. The target used by default is

    r(λ*) = max(r_min + κ (1 − r_min), 1.1 r_min),     κ = DISCREPANCY_KAPPA = 0.25,

``r_min`` the ratio at the smallest λ of the path: a quarter of the way from the over-fitted floor
to the full noise level, and at least 10 % above the floor (``FLOOR_MARGIN``: a σ² estimated to
±15 % can put r_min slightly above 1). When r_min > ``UNFITTABLE_RATIO`` = 1.5 the data cannot be
fitted to the noise level at all (noiseless data, clutter outside the image, model error) and no λ
is chosen. κ was set on the scenes of ``bench/bench_lam.py`` (where the λ of
smallest magnitude error sits at r = r_min + 0.1 .. 0.35 (1 − r_min) for ptv and TV), so it is a
calibrated rule, not a theorem; ``tau`` (κ None) gives the classical principle.

The whole decreasing path ``LAM_PATH`` (log-spaced over the normalised units of
:mod:`sarcli.regularize`) is solved, each solve warm-started from the previous one; λ* is
interpolated in log λ between the two path values that bracket the target. The curve
(λ, r(λ)) is returned so that the image file can record it.

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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

__all__ = ["LAM_PATH", "DISCREPANCY_TAU", "DISCREPANCY_KAPPA", "FLOOR_MARGIN", "UNFITTABLE_RATIO", "LamChoice", "estimate_noise_power", "noise_power",
           "discrepancy_lambda", "blackman_harris"]

#: Decreasing λ path (normalised units of :mod:`sarcli.regularize`; ℓ1 zeroes the image at λ ≥ 2).
LAM_PATH = tuple(float(v) for v in np.geomspace(1.0, 1e-3, 13))
#: Classical discrepancy factor τ: ‖Af − b‖² = τ n_b σ² (used when kappa is None).
DISCREPANCY_TAU = 1.0
#: Default target r_min + κ (1 − r_min) of the ratio ‖Af − b‖² / (n_b σ²) (module docstring).
DISCREPANCY_KAPPA = 0.25
#: ... and at least this far above the floor r_min (σ² estimated to ±15 % can put r_min above 1).
FLOOR_MARGIN = 0.1
#: r_min above this: the data cannot be fitted to the noise level (clutter outside the image,
#: noiseless data, model error); no λ is chosen (status 'above at the smallest λ').
UNFITTABLE_RATIO = 1.5
_BH = (0.35875, 0.48829, 0.14128, 0.01168)
_BH_MAINLOBE_BINS = 4  # half-width of the Blackman-Harris main lobe, in bins of the unpadded DFT


def blackman_harris(m: int) -> np.ndarray:
    """The 4-term Blackman-Harris window (-92 dB sidelobes), symmetric, length ``m``."""
    if m < 2:
        return np.ones(m)
    t = 2 * np.pi * np.arange(m) / (m - 1)
    return _BH[0] - _BH[1] * np.cos(t) + _BH[2] * np.cos(2 * t) - _BH[3] * np.cos(3 * t)


def estimate_noise_power(data, frequency_hz, scene_radius_m: float, *, margin_bins: int = 2):
    """σ² = E|n|² of white noise in phase-history samples, from the range bins outside the scene.

    Parameters
    ----------
    data : ndarray (P, M) complex
    frequency_hz : ndarray (M,) or (P, M)
        Must be uniformly spaced along each pulse (to 1 % of the step: recorded frequencies are
        often quantised).
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
    f = np.broadcast_to(np.asarray(frequency_hz, np.float64), d.shape)
    df = np.diff(f, axis=1)
    step = np.median(np.abs(df))
    if not step > 0 or np.max(np.abs(np.abs(df) - step)) > 1e-2 * step:
        return None
    m = d.shape[1]
    r_bin = 299_792_458.0 / (2.0 * step * m)  # range per bin (m); the window is m bins
    guard = int(np.ceil(scene_radius_m / r_bin)) + _BH_MAINLOBE_BINS + int(margin_bins)
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
        when ``r_min > UNFITTABLE_RATIO`` (module docstring).
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


def auto_lambda(ph, grid, scaled, data_scale: float, solve: Callable, *, lams=LAM_PATH,
                tau: float = DISCREPANCY_TAU, kappa: float | None = DISCREPANCY_KAPPA):
    """λ for :func:`sarcli.regularize.regularize` by the discrepancy principle, and its record.

    Parameters
    ----------
    ph : PhaseHistory
    grid : Grid
    scaled : NormalEquations
        The scaled problem (``b̂ = b / data_scale``).
    data_scale : float
        ``s_b`` of :func:`sarcli.regularize.scale_problem`.
    solve : callable
        ``solve(lam, x0) -> u`` on the scaled problem.

    Returns
    -------
    choice : LamChoice or None
        None when no noise power is known or can be estimated.
    record : dict
        JSON-ready: criterion, κ, σ² and its source, status, the target ratio, the λ path and
        the ratios ``‖Âu − b̂‖² / (n_b σ̂²)`` (criterion's curve).
    """
    sigma2, source = noise_power(ph, grid)
    record = {"criterion": "discrepancy" if kappa is None else "discrepancy, dof-corrected",
              "kappa": kappa, "noise_power": sigma2, "noise_source": source}
    if sigma2 is None:
        return None, record
    noise_energy = ph.data.size * sigma2 / data_scale**2
    gram = scaled.gram

    def residual2(u):
        return scaled.residual_norm2(u, gram.forward(u))

    choice = discrepancy_lambda(solve, residual2, noise_energy, lams=lams, tau=tau, kappa=kappa)
    record.update(status=choice.status, lam=choice.lam, target=choice.target, lams=list(choice.lams),
                  ratios=list(choice.ratios), data_norm_ratio=float(scaled.bnorm2 / noise_energy))
    return choice, record
