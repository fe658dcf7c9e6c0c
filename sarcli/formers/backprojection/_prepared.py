"""Backprojection prepared for repeated images and pulse contractions of one phase history on one grid
(minimum-entropy autofocus: many images of the same data with a different per-pulse phase each).

The maps are those of :mod:`sarcli.formers.backprojection._maps` (its module docstring); what is prepared
is what does not change between calls: the checks, the per-pulse constants and the range profiles of
all pulses.
"""

from __future__ import annotations

import numpy as np

from ..._native import using_threads
from ...core.grid import Grid
from ...errors import SarcliInputError
from ._kernels import kernels
from ._setup import Setup, check_data, profiles
from ._maps import knobs_of

__all__ = ["Backprojector"]


class Backprojector:
    """:func:`~sarcli.formers.backprojection.backproject` and
    :func:`~sarcli.formers.backprojection.pulse_contractions` of one phase history on one grid, prepared
    for repeated calls: the checks and per-pulse constants once, the range profiles of all pulses
    once (held: ``P × (L + 6)`` complex samples of the working precision).

    An image of the data multiplied per pulse by ``e^{-iφ_p}`` has the profiles
    ``e^{-iφ_p} · profile_p`` (the profile is linear in its pulse), so :meth:`image` with a
    ``phase`` multiplies the held profiles; :meth:`contract` uses them as they are. The numbers
    are those of ``backproject`` and ``pulse_contractions`` of the phase-multiplied data to the
    working precision's rounding. Arguments as for ``backproject`` (``collection``, ``grid``,
    ``options``: a :class:`~sarcli.formers.options.BackprojectionOptions` or None for the maps'
    defaults, ``nthreads``).
    """

    def __init__(self, data, collection, grid, options=None, *, nthreads=None, _profiles_of=None):
        d = check_data(data)
        self._collection, self._options = collection, options
        self._data = d
        self.grid = grid
        self._st = st = Setup(d.shape, collection, grid, *knobs_of(options))
        self._nthreads = nthreads
        self._cdt = np.complex64 if st.dtype == np.float32 else np.complex128
        if _profiles_of is not None:
            self.profiles = _profiles_of.profiles
        else:
            self.profiles = profiles(d[0:st.n_pulses], st.weights, st.total_weight, st.n_len, self._cdt)

    def on(self, grid: Grid) -> "Backprojector":
        """The same data and options on another ``grid``, sharing these profiles."""
        return Backprojector(self._data, self._collection, grid, self._options, nthreads=self._nthreads,
                             _profiles_of=self)

    def _view(self, prof):
        return prof.view(self._st.dtype).reshape(prof.shape + (2,))

    def image(self, phase=None) -> np.ndarray:
        """``backproject(data · exp(-i phase)[:, None])``, shape ``grid.shape``, complex128
        (``phase`` per pulse, radians; ``None``: the data as they are)."""
        st = self._st
        prof = self.profiles
        if phase is not None:
            e = np.exp(-1j * np.asarray(phase, np.float64)).astype(self._cdt)
            if e.shape != (st.n_pulses,):
                raise SarcliInputError(f"phase has shape {e.shape}, expected ({st.n_pulses},)")
            prof = prof * e[:, None]
        out_re = np.zeros(st.kernel_shape)
        out_im = np.zeros(st.kernel_shape)
        with using_threads(self._nthreads):
            kernels().bp_tiles(self._view(prof), *st.kernel_args(slice(0, st.n_pulses)), st.cache_block,
                               out_re, out_im)
        return st.image(out_re, out_im)

    def contract(self, g) -> np.ndarray:
        """``pulse_contractions`` of the data as they are with an image-shaped ``g``, shape (P,)."""
        st = self._st
        gg = np.asarray(g)
        if gg.shape != st.shape:
            raise SarcliInputError(f"g shape {gg.shape} does not match the grid {st.shape}")
        gre, gim = st.kernel_input(gg)
        acc = np.empty((st.n_pulses, 2))
        with using_threads(self._nthreads):
            kernels().bp_contract(self._view(self.profiles), gre, gim, *st.kernel_args(slice(0, st.n_pulses)),
                                  st.cache_block, acc)
        return acc[:, 0] + 1j * acc[:, 1]

    def group_images(self, bounds):
        """The images of consecutive groups of pulses, ``bounds[b] <= p < bounds[b + 1]``, each
        normalised as its share of the image of all pulses (their sum is :meth:`image`): yields
        ``(b, real, imag)``, float64 arrays of the grid's shape that are reused for the next group
        (copy what is kept; transposed views when the kernels run on the transposed grid,
        :attr:`Setup.transposed <sarcli.formers.backprojection.Setup>`).
        """
        st = self._st
        bounds = np.asarray(bounds, dtype=np.int64)
        if bounds.ndim != 1 or bounds.size < 2 or bounds[0] != 0 or bounds[-1] != st.n_pulses \
                or np.any(np.diff(bounds) < 1):
            raise SarcliInputError(f"bounds must increase from 0 to the {st.n_pulses} pulses, got {bounds}")
        out_re = np.empty(st.kernel_shape)
        out_im = np.empty(st.kernel_shape)
        kern = kernels()
        for b in range(bounds.size - 1):
            sl = slice(int(bounds[b]), int(bounds[b + 1]))
            out_re.fill(0.0)
            out_im.fill(0.0)
            with using_threads(self._nthreads):
                kern.bp_tiles(self._view(self.profiles[sl]), *st.kernel_args(sl), st.cache_block, out_re, out_im)
            yield b, st.image_view(out_re), st.image_view(out_im)

