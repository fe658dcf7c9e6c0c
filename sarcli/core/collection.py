"""A collection as the range-model formers take it: frequencies, antenna positions, reference
ranges, window weights and, for separate transmit and receive positions, the receive positions.

Backprojection and its adjoint (:mod:`sarcli.formers.backprojection`), their at-height forms
(:mod:`sarcli.formers.points`) and the sub-image former (:mod:`sarcli.formers.subimage`) take one
:class:`Collection` beside the samples and the grid: what travels together travels as one object.
:meth:`Acquisition.collection <sarcli.core.acquisition.Acquisition.collection>` makes one from an
acquisition's own range geometry. The arrays are kept as given; each former checks them against the
samples.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

__all__ = ["Collection"]


@dataclass(frozen=True, eq=False)
class Collection:
    """The range geometry and window of a collection (docs/conventions.md "Data models").

    Attributes
    ----------
    frequency_hz : array_like, shape (M,) or (P, M)
        Frequencies α_pj.
    antenna_position_m : array_like, shape (P, 3)
        Antenna phase centres ``a_p`` (any flight path); with ``receive_position_m``, the transmit
        positions ``t_p``.
    range_to_center_m : array_like, shape (P,)
        Reference ranges ``r0_p``.
    weights : array_like, shape (M,) or (P, M), optional
        Window weights ``w_pj`` (default 1; the formers normalise by ``W = Σ w_pj``).
    receive_position_m : array_like, shape (P, 3), optional
        Separate receive positions ``q_p``: the differential range is then
        ``(|t_p - x| + |q_p - x|)/2 - r0_p`` (moving platform or bistatic).
    """

    frequency_hz: object
    antenna_position_m: object
    range_to_center_m: object
    weights: object = None
    receive_position_m: object = None

    @property
    def n_pulses(self) -> int:
        """P, from the antenna positions."""
        return int(np.shape(self.antenna_position_m)[0])

    @property
    def n_frequencies(self) -> int:
        """M, from the frequencies."""
        return int(np.shape(self.frequency_hz)[-1])

    def pulses(self, sl: slice) -> "Collection":
        """The collection of the pulses in ``sl`` (per-pulse frequencies and weights sliced with them)."""
        def rows(x, per_pulse_ndim):
            return None if x is None or np.ndim(x) < per_pulse_ndim else np.asarray(x)[sl]

        f, w = self.frequency_hz, self.weights
        return Collection(f if np.ndim(f) < 2 else np.asarray(f)[sl], np.asarray(self.antenna_position_m)[sl],
                          np.asarray(self.range_to_center_m)[sl], w if np.ndim(w) < 2 else rows(w, 2),
                          rows(self.receive_position_m, 2))

    def with_(self, **changes) -> "Collection":
        """A copy with some fields replaced (e.g. ``weights``)."""
        return replace(self, **changes)
