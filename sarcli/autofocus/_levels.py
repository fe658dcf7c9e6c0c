"""The subspaces minimum entropy searches level by level, and the phase vectors' own algebra: the
unobservable constant and linear phase, and the mean of two estimates.

A per-pulse phase acts on the data through ``e^{-iφ_p}``: ``2π`` on one pulse changes nothing,
and a phase constant or linear in look azimuth changes no image magnitude (it shifts the image in
cross-range). Estimates are therefore kept continuous across the pulses, compared and averaged
modulo ``2π``, and returned without their constant and linear part.
"""

from __future__ import annotations

import numpy as np

__all__ = ["LEVELS", "gauge_basis", "without_gauge", "phase_mean", "predicted_residual", "wrapped", "level_basis", "spacing", "dof"]

#: The levels of the search: a smooth polynomial subspace, knots every 16 and 4 pulses, every pulse.
LEVELS = ("smooth", 16, 4, 1)


def gauge_basis(acq) -> np.ndarray:
    """Orthonormal basis ``Q`` (P × 2) of the unobservable constant and linear-in-azimuth phase."""
    th = np.unwrap(np.asarray(acq.azimuth_rad, np.float64))
    A = np.column_stack([np.ones_like(th), th - th.mean()])
    if np.ptp(th) == 0:
        A = A[:, :1]
    q, _ = np.linalg.qr(A)
    return q


def wrapped(phi) -> np.ndarray:
    """``φ`` modulo ``2π``, in ``[-π, π)``."""
    return np.mod(np.asarray(phi, np.float64) + np.pi, 2.0 * np.pi) - np.pi


def without_gauge(phi, gauge) -> np.ndarray:
    """``φ`` less its constant and linear part: of ``φ`` unwrapped across the pulses, or of ``φ``
    as it is, whichever leaves the smaller circular residual ``Σ (1 - cos r_p)``.

    A search can reach a cross-range shift (a linear phase) as a vector orthogonal to the linear
    phases, e.g. a ramp of 1 rad per pulse with ``2π`` jumps; unwrapped, that is the ramp, and
    nothing of it is left (on a window that does not hold the whole scene a shift can lower the
    entropy, by the same amount on both halves of the scene). A phase whose neighbours differ by
    more than ``π`` for a reason of its own (a large pulse-to-pulse error) would gain ``2π``
    steps from unwrapping, whose linear fit is a shift of no use: there the phase as it is serves.
    """
    phi = np.asarray(phi, np.float64)
    best, kept = np.inf, None
    for cand in (np.unwrap(phi), phi):
        r = cand - gauge @ (gauge.T @ cand)
        cost = float(np.sum(1.0 - np.cos(r)))
        if cost < best - 1e-9 * max(1.0, best if np.isfinite(best) else 1.0):
            best, kept = cost, r
    return kept


def phase_mean(a, b) -> np.ndarray:
    """The mean of two phase estimates modulo ``2π`` (``a + wrapped(b - a)/2``): two estimates a
    few whole turns apart on some pulses average to the estimate, not to it plus ``π``."""
    a = np.asarray(a, np.float64)
    return a + 0.5 * wrapped(np.asarray(b, np.float64) - a)


def predicted_residual(phi, a, b, gauge) -> dict:
    """What two halves' estimates ``a``, ``b`` of the scene say of the whole scene's estimate ``phi``
    (rad rms, modulo ``2π`` and the unobservable constant and linear phase).

    With ``a = ε + n_a`` and ``b = ε + n_b`` (a common error ``ε``, independent estimation noise):

    - ``spread_rad``, half the rms of ``a - b``: the rms noise of their mean ``m``;
    - ``departure_rad``: the rms of ``phi - m`` (how far the whole scene's estimate lies from the
      halves' mean);
    - ``predicted_rad = spread + departure``: at least the rms of ``phi - ε`` (triangle inequality)
      when the halves are unbiased;
    - ``signal_rad``: ``√mean(a_p b_p)``, an estimate of the rms of ``ε`` (the noise cancels in the
      product), and ``signal_low_rad`` the same two standard errors lower
      (``mean - 2 std(a_p b_p)/√P``, 0 when that is not positive): the least error the halves
      are sure of.

    ``phi`` nearer the truth than no correction is predicted when ``predicted_rad`` is below
    ``signal_low_rad`` (``trusted``).
    """
    a = without_gauge(np.asarray(a, np.float64), gauge)
    d = wrapped(without_gauge(wrapped(a - np.asarray(b, np.float64)), gauge))
    b = a - d   # b, moved by whole turns (and the gauge) to lie nearest a
    dep = wrapped(without_gauge(wrapped(np.asarray(phi, np.float64) - (a - 0.5 * d)), gauge))
    spread = float(np.sqrt(np.mean(d ** 2)) / 2.0)
    departure = float(np.sqrt(np.mean(dep ** 2)))
    ab = a * b
    low = float(np.mean(ab) - 2.0 * np.std(ab) / np.sqrt(ab.size))
    out = {"spread_rad": spread, "departure_rad": departure, "predicted_rad": spread + departure,
           "signal_rad": float(np.sqrt(max(float(np.mean(ab)), 0.0))), "signal_low_rad": float(np.sqrt(max(low, 0.0)))}
    out["trusted"] = bool(out["predicted_rad"] < out["signal_low_rad"])
    return out


def _degree(P: int) -> int:
    return int(min(12, max(2, P // 8)))


def spacing(level, P: int) -> int:
    """Pulses over which a level's phase is nearly constant: the knot spacing, or for the smooth
    level half the mean distance between the zeros of its highest-degree polynomial (``P / 2K``)."""
    return max(1, P // (2 * _degree(P))) if level == "smooth" else int(level)


def level_basis(level, P: int, gauge: np.ndarray) -> np.ndarray | None:
    """The basis ``A`` (P × K) of one level, orthogonal to ``gauge``; ``None`` for one phase per
    pulse (then the gradient itself is projected, ``(I - QQᵀ) g``).

    Parameters
    ----------
    level : 'smooth' or int
        ``'smooth'``: Legendre polynomials ``L_2 … L_K`` of ``u ∈ [-1, 1]`` across the pulses,
        ``K = min(12, max(2, P // 8))``; an int ``k``: hat functions on knots every ``k`` pulses
        (and at the last pulse), i.e. a phase piecewise linear between the knots.
    P : int
    gauge : ndarray, shape (P, g)
    """
    if level == 1 or P < 4:
        return None
    if level == "smooth":
        K = _degree(P)
        A = np.polynomial.legendre.legvander(np.linspace(-1.0, 1.0, P), K)[:, 2:]
    else:
        knots = np.unique(np.append(np.arange(0, P, int(level)), P - 1))
        if knots.size >= P:
            return None
        eye = np.eye(knots.size)
        A = np.column_stack([np.interp(np.arange(P), knots, eye[i]) for i in range(knots.size)])
    return A - gauge @ (gauge.T @ A)


def dof(level, P: int, gauge) -> int:
    """Free parameters of a level: the rank of its basis (``P`` less the unobservable ones for one
    phase per pulse). The smooth basis starts at degree 2 and holds no unobservable direction; the
    knots' hat functions span the constant and the linear phase, which the projection removes."""
    A = level_basis(level, P, gauge)
    if A is None:
        return max(1, P - gauge.shape[1])
    return max(1, A.shape[1] - (0 if level == "smooth" else gauge.shape[1]))
