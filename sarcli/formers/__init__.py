"""Image formation: phase history -> image.

- :mod:`.former`: the one interface of every former: options (:class:`Options`), the plan made
  from a collection's geometry and a grid (:class:`Plan`: predicted error, seconds, bytes;
  :meth:`Plan.form`), and :class:`Former`.
- :mod:`.options`: each family's options dataclass (knobs, defaults, ranges, help).
- :mod:`.families`: each family's plan (:data:`FORMERS`).
- :mod:`.formation`: :func:`form_image` and :func:`regrid`, the entry point that checks the data,
  builds the grid and the window weights and forms the plan of the method asked for;
  :func:`plan_image`, that plan.
- :mod:`.direct`: the exact matched filter (eq. ``mf``), far-field and spherical, the reference.
- :mod:`.nufft`: the far-field matched filter as one type-1 NUFFT (FINUFFT).
- :mod:`.pfa`: the polar format algorithm (gridding onto a Cartesian k-grid, then FFT).
- :mod:`.backprojection`: per-pulse range-profile interpolation (any flight path);
  :class:`Backprojector`, its prepared form (the pulses' range profiles made once, images of any
  group of pulses), loaded on first use.
- :mod:`.ffbp`, :mod:`.subimage`: fast factorised backprojection, the sub-image NUFFT.
- :mod:`.planning`: auto's choice (:mod:`.planning.planner`), the cost models (:mod:`.planning.cost`), their
  constants (:mod:`.planning.calibration`).
"""

from .families import FORMERS
from .formation import METHODS, check_form_image, form_image, image_error, plan_image, regrid
from .former import Former, Options, Plan, Settings
from .options import (OPTIONS, AutoOptions, BackprojectionOptions, DirectOptions, FfbpOptions, NufftOptions,
                      PfaOptions, SubimageOptions)

__all__ = ["METHODS", "form_image", "plan_image", "check_form_image", "image_error", "regrid", "Backprojector",
           "Former", "Options", "Plan", "Settings", "FORMERS", "OPTIONS", "DirectOptions", "NufftOptions",
           "PfaOptions", "BackprojectionOptions", "FfbpOptions", "SubimageOptions", "AutoOptions"]


def __getattr__(name):
    # the prepared backprojector (autofocus's imager) loads the compiled kernels: only when asked
    if name == "Backprojector":
        from .backprojection import Backprojector

        return Backprojector
    raise AttributeError(f"module 'sarcli.formers' has no attribute {name!r}")
