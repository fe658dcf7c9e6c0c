"""A patch of a larger scene, regularised on its own: the rest of the scene taken out of the data.

On a patch of a real collection the data hold the echoes of the whole illuminated scene; a
regulariser on the patch's grid can explain only the patch's, and the rest acts as noise (the
criterion for λ then smooths, and the rest leaks in as artefacts). Given an image of the whole
scene ``f`` (a regularised image, whose forward model reproduces the data: ``A f ≈ b``), the
data of the patch alone are

    b_patch = b − A (f · 1[outside the patch and a guard band])

with A the exact forward model of the collection (the spherical reprojection, or the far-field NUFFT
for far-field data). The guard band (default: four resolution cells) keeps the patch's own
point responses, which spill over its edge, in the data.
"""

from __future__ import annotations

import numpy as np

from ..core.grid import Grid
from ..core.types import Image, PhaseHistory
from ..errors import SarcliInputError

__all__ = ["without_outside", "GUARD_CELLS"]

#: Default guard band around the patch, in resolution cells (the coarser of range and cross-range).
GUARD_CELLS = 4.0


def _forward(ph: PhaseHistory, grid: Grid):
    from ..linops import NufftOperator, SphericalOperator

    acq = ph.acquisition
    if ph.model == "spherical" and acq.has_positions:
        return SphericalOperator.from_acquisition(acq, grid)
    return NufftOperator.from_acquisition(acq, grid)


def without_outside(ph: PhaseHistory, scene: Image, patch: Grid, *, guard_m: float | None = None) -> PhaseHistory:
    """The phase history with the scene outside ``patch`` (and a guard band) taken out.

    Parameters
    ----------
    ph : PhaseHistory
        The collection.
    scene : Image
        An image of the whole scene in the pixel-model reflectivity of :func:`sarcli.regularize`
        (its forward model reproduces the data), on a grid that contains ``patch``.
    patch : Grid
        The grid to be regularised on its own.
    guard_m : float, optional
        Width of the band around the patch that is kept in the data (default :data:`GUARD_CELLS`
        resolution cells).

    Returns
    -------
    PhaseHistory
        ``b − A (f outside)`` (module docstring), with the attribute ``outside_removed`` recording
        the scene image's grid, the patch and the guard.
    """
    g = scene.grid
    x0, x1 = patch.x[0] - patch.dx / 2, patch.x[-1] + patch.dx / 2
    y0, y1 = patch.y[0] - patch.dy / 2, patch.y[-1] + patch.dy / 2
    if x0 < g.x[0] - g.dx / 2 - 1e-9 or x1 > g.x[-1] + g.dx / 2 + 1e-9 or \
            y0 < g.y[0] - g.dy / 2 - 1e-9 or y1 > g.y[-1] + g.dy / 2 + 1e-9:
        raise SarcliInputError("the scene image does not contain the patch: image the whole scene on a grid that "
                               "covers the patch")
    if guard_m is None:
        guard_m = GUARD_CELLS * max(ph.acquisition.resolutions())
    if not (np.isfinite(guard_m) and guard_m >= 0):
        raise SarcliInputError(f"guard band must be a finite width >= 0 m, got {guard_m}")
    xx, yy = np.meshgrid(g.x, g.y)
    inside = (xx >= x0 - guard_m) & (xx <= x1 + guard_m) & (yy >= y0 - guard_m) & (yy <= y1 + guard_m)
    outside = np.where(inside, 0, np.asarray(scene.image, np.complex128))
    data = np.asarray(ph.data, np.complex128) - _forward(ph, g).forward(outside)
    attrs = {**ph.attrs, "outside_removed": {"scene_grid": g.as_dict(), "patch": patch.as_dict(),
                                             "guard_m": float(guard_m)}}
    return PhaseHistory(data, ph.acquisition, attrs=attrs)
