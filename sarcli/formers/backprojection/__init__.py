"""Backprojection for any flight path (spherical model), its exact adjoint and its prepared form.

- :mod:`._maps`: :func:`backproject`, :func:`reproject` (its exact adjoint) and
  :func:`pulse_contractions` (the maps, their accuracy and defaults: its module docstring);
- :mod:`._prepared`: :class:`Backprojector`, backprojection prepared for many images of one phase
  history on one grid (the range profiles made once; autofocus's imager);
- :mod:`._setup`: checked inputs, per-pulse constants, the range profiles and the tiling, which
  ffbp and the at-height maps (:mod:`sarcli.formers.points`) share;
- :mod:`._rows`: which image axis the kernels' rows follow (the transposed problem when that puts
  them across the look direction) and the pulse block's share of the L2 cache;
- :mod:`._kernels`: the compiled kernels and the per-tile range model.
"""

from ._kernels import kernels
from ._maps import (DEFAULT_INTERP, DEFAULT_PRECISION, DEFAULT_UPSAMPLE, FORM_KNOBS, INTERPOLATORS, MAP_KNOBS,
                    MAP_PRECISION, MAP_UPSAMPLE, Knobs, backproject, knobs_of, pulse_contractions, reproject)
from ._prepared import Backprojector
from ._setup import (BLOCK, PAD, ProfileWork, Setup, TilingInputs, check_data, profile_length, profiles,
                     range_profiles, tiling_for)

__all__ = ["backproject", "reproject", "pulse_contractions", "Backprojector", "profile_length", "DEFAULT_UPSAMPLE",
           "DEFAULT_INTERP", "DEFAULT_PRECISION", "MAP_PRECISION", "MAP_UPSAMPLE", "Knobs", "MAP_KNOBS", "FORM_KNOBS", "knobs_of", "INTERPOLATORS", "BLOCK", "PAD", "ProfileWork", "Setup",
           "TilingInputs", "check_data", "profiles", "range_profiles", "tiling_for", "kernels"]
