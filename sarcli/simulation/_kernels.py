"""Compiled loops of the simulator (numba)."""

from __future__ import annotations

import numba
import numpy as np

from ..core.geometry import C


@numba.njit(parallel=True, cache=True, fastmath=False)
def spherical_sum(freq, antenna, offset, points_xy, amp, out):  # pragma: no cover - compiled
    """out[p, j] += Σ_s amp[s] exp(-i 4π f[p, j] (|a_p - x_s| - r0_p) / c), exact, in float64.

    The differential range is computed cancellation-free (see geometry.differential_range);
    ``offset[p] = |a_p| - r0_p`` is taken in extended precision by the caller.
    When the frequencies of a pulse are equally spaced the phasor is advanced by multiplication,
    re-anchored every 64 steps to keep rounding below 1e-13.
    """
    P, M = freq.shape
    S = points_xy.shape[0]
    for p in numba.prange(P):
        ax, ay, az = antenna[p, 0], antenna[p, 1], antenna[p, 2]
        na = np.sqrt(ax * ax + ay * ay + az * az)
        df = freq[p, 1] - freq[p, 0] if M > 1 else 0.0
        uniform = True
        for j in range(1, M):
            if abs((freq[p, j] - freq[p, j - 1]) - df) > 1e-9 * abs(freq[p, 0]):
                uniform = False
                break
        acc = np.zeros(M, np.complex128)
        for s in range(S):
            x = points_xy[s, 0]
            y = points_xy[s, 1]
            xx = x * x + y * y
            ax_dot = ax * x + ay * y
            dist = np.sqrt(na * na - 2.0 * ax_dot + xx)
            dr = (xx - 2.0 * ax_dot) / (dist + na) + offset[p]
            k0 = 4.0 * np.pi * dr / C
            a = amp[s]
            if uniform:
                step = np.exp(-1j * k0 * df)
                for j0 in range(0, M, 64):
                    z = a * np.exp(-1j * k0 * freq[p, j0])
                    for j in range(j0, min(M, j0 + 64)):
                        acc[j] += z
                        z *= step
            else:
                for j in range(M):
                    acc[j] += a * np.exp(-1j * k0 * freq[p, j])
        for j in range(M):
            out[p, j] += acc[j]
