"""The images whose sharpness the autofocus methods report and guard (one choice for both)."""

from __future__ import annotations

import numpy as np

from ..core.grid import Grid
from ._common import form
from ._imager import Imager

__all__ = ["sharpness_imager"]


class _Formed:
    """Images of ``d · exp(-iφ)`` by :func:`~sarcli.autofocus._common.form` (no prepared backprojector)."""

    def __init__(self, ph, grid: Grid):
        self._ph, self.grid = ph, grid

    def image(self, phi) -> np.ndarray:
        return form(self._ph, self.grid, phi)


def sharpness_imager(ph, grid: Grid, *, like=None):
    """The images whose sharpness both autofocus methods report and guard: the estimator's
    single-precision backprojection (:data:`~sarcli.autofocus._imager.ESTIMATION_BP`,
    :class:`~sarcli.autofocus._imager.Imager`, sharing ``like``'s range profiles) where the data
    take one, else :func:`~sarcli.autofocus._common.form`. One choice for both methods, so that PGA
    and minimum entropy report the same entropy "before" for the same data and grid."""
    im = Imager(ph, grid, like=like, stack=False)
    return im if im._bp is not None else _Formed(ph, grid)
