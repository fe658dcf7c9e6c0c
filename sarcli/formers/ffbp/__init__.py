"""Fast factorised backprojection: sub-aperture polar images merged in stages.

- :mod:`._image`: :func:`ffbp` (the algorithm, its accuracy and its knobs: its module docstring)
  and :func:`ffbp_image`;
- :mod:`._plan`: :class:`FfbpPlan`, the stages made from a geometry before any data
  (:func:`plan_stages`, :func:`layout_stages`);
- :mod:`.model`: the error model of its kernels and stages;
- :mod:`._grids`, :mod:`._stage0`, :mod:`._kernels`: the polar grids, stage 0, the compiled kernels.
"""

from ._image import FINAL_COLUMNS, ffbp, ffbp_image
from ._plan import (BAND_SLACK, DEFAULTS, OS_ANGLE_DEAPODIZED, OS_RANGE_DEAPODIZED, SUBTREE_BYTES, UPSAMPLE_ANALYTIC,
                    FfbpPlan, StageLayout, layout_stages, plan_stages, subtree_groups)
from .model import interp_error, optimal_kernel, predict_error

__all__ = ["ffbp", "ffbp_image", "FINAL_COLUMNS", "plan_stages", "layout_stages", "subtree_groups", "FfbpPlan", "StageLayout",
           "optimal_kernel", "predict_error", "interp_error", "DEFAULTS", "BAND_SLACK", "OS_RANGE_DEAPODIZED",
           "OS_ANGLE_DEAPODIZED", "UPSAMPLE_ANALYTIC", "SUBTREE_BYTES"]
