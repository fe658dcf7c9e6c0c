"""Image formation: phase history -> image.

- :mod:`.formation`: :func:`form_image` and :func:`regrid`, the one entry point that checks the
  data, builds the grid and the window weights and dispatches to a former.
- :mod:`.direct`: the exact matched filter (eq. ``mf``), far-field and spherical, the reference.
- :mod:`.nufft`: the far-field matched filter as one type-1 NUFFT (FINUFFT).
- :mod:`.pfa`: the polar format algorithm (gridding onto a Cartesian k-grid, then FFT).
- :mod:`.backprojection`: per-pulse range-profile interpolation (any flight path); compiled
  kernels in :mod:`._bp_kernels`; :class:`Backprojector`, its prepared form (the pulses' range
  profiles made once, images of any group of pulses), loaded on first use.
"""

from .formation import METHODS, form_image, image_error, regrid

__all__ = ["METHODS", "form_image", "image_error", "regrid", "Backprojector"]


def __getattr__(name):
    # the prepared backprojector (autofocus's imager) loads the compiled kernels: only when asked
    if name == "Backprojector":
        from ._bp_prepared import Backprojector

        return Backprojector
    raise AttributeError(f"module 'sarcli.formers' has no attribute {name!r}")
