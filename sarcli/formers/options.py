"""Every image former's options: one frozen dataclass per family, its knobs with their defaults,
ranges or choices and help (:func:`sarcli.formers.former.knob`).

``sar form-image``'s method options are generated from these (:mod:`sarcli.cli.form_image`),
:func:`sarcli.formers.formation.form_image` checks its keyword knobs against them, the planner
describes each candidate by them and ``sar plan`` prints their flags.
"""

from __future__ import annotations

from dataclasses import dataclass

from .planning import cost
from .former import Options, knob

__all__ = ["DirectOptions", "NufftOptions", "PfaOptions", "BackprojectionOptions", "FfbpOptions", "SubimageOptions",
           "AutoOptions", "OPTIONS", "KNOB_NAMES", "DEFAULT_TOLERANCE", "SUBIMAGE_TOLERANCE"]

#: Relative error against the exact matched filter that ``method='auto'`` meets when no tolerance
#: is given, and that ffbp's knobs are picked for when none is given.
DEFAULT_TOLERANCE = 1e-3
#: The tolerance subimage's tile is chosen for when neither a tile nor a tolerance is given.
SUBIMAGE_TOLERANCE = 1e-2
_INTERPS = ("linear", "cubic", "lanczos", "lagrange")


@dataclass(frozen=True)
class DirectOptions(Options):
    """The exact matched filter (float64 sums): no knobs."""

    method = "direct"


@dataclass(frozen=True)
class NufftOptions(Options):
    """The far-field matched filter as one type-1 NUFFT (FINUFFT)."""

    method = "nufft"
    eps: float = knob(cost.NUFFT_EPS, "NUFFT accuracy (relative error ~eps against direct)", range=cost.EPS_RANGE)


@dataclass(frozen=True)
class PfaOptions(Options):
    """The polar format algorithm: gridding onto a Cartesian k-grid, then an FFT."""

    method = "pfa"
    kernel: str = knob("kaiser", "gridding kernel", kind=str, choices=("kaiser", "linear"))
    oversample: float = knob(2.0, "k-grid oversampling", range=cost.OVERSAMPLE_RANGE)
    width: int = knob(6, "Kaiser-Bessel kernel width (cells)", kind=int, range=cost.WIDTH_RANGE)


@dataclass(frozen=True)
class BackprojectionOptions(Options):
    """Per-pulse range-profile interpolation (any flight path); the defaults reach ~2.6e-5."""

    method = "backprojection"
    upsample: float = knob(12, "range-profile upsampling", range=cost.UPSAMPLE_RANGE)
    interp: str = knob("lagrange", "range-profile interpolator", kind=str, choices=_INTERPS)
    precision: str = knob("float32", "precision of the profiles and sums (the ranges are float64 per tile "
                          "of pixels either way)", kind=str, choices=("float32", "float64"))


@dataclass(frozen=True)
class FfbpOptions(Options):
    """Fast factorised backprojection: sub-aperture polar images merged in stages. With none of
    its knobs given, those the planner picks for ffbp at ``tolerance``; with some, ffbp's defaults
    (:func:`sarcli.formers.ffbp.plan_stages`) for the others."""

    method = "ffbp"
    base: int = knob(None, "pulses per base sub-aperture", kind=int, range=(1, None), default_text="16")
    merge: int = knob(None, "sub-apertures merged per stage", kind=int, range=(2, None), default_text="4")
    os_range: float = knob(None, "polar-grid range oversampling", range=(1, None),
                           default_text="1.5 where its kernel can be deapodized, else 2")
    os_angle: float = knob(None, "polar-grid angular oversampling", range=(1, None),
                           default_text="1.5 where its kernel can be deapodized, else 2")
    upsample: float = knob(None, "range-profile upsampling", range=(1, None),
                           default_text="os-range with optimal (at least 1.5), else 4")
    interp: str = knob(None, "interpolator of the profiles and polar grids", kind=str,
                       choices=_INTERPS + ("optimal",), default_text="optimal")
    tolerance: float = knob(DEFAULT_TOLERANCE, "target relative error its knobs are picked for when none "
                            "is given", range=(1e-12, 0.5))

    def picked(self) -> bool:
        """Whether the planner picks the knobs (none given)."""
        return all(getattr(self, n) is None for n in ("base", "merge", "os_range", "os_angle", "upsample", "interp"))


@dataclass(frozen=True)
class SubimageOptions(Options):
    """One NUFFT per motion-compensated tile (spherical data; far-field data: one tile)."""

    method = "subimage"
    tile: int = knob(None, "tile side in pixels", kind=int, range=(1, None),
                     default_text="the largest predicted to meet tolerance")
    tolerance: float = knob(SUBIMAGE_TOLERANCE, "target relative error the tile is chosen for",
                            range=(1e-12, 0.5))
    eps: float = knob(None, "NUFFT accuracy of each tile", range=cost.EPS_RANGE,
                      default_text="tolerance/10; far-field data 1e-9")


@dataclass(frozen=True)
class AutoOptions(Options):
    """The cheapest former predicted to meet ``tolerance`` (:mod:`sarcli.formers.planning.planner`)."""

    method = "auto"
    tolerance: float = knob(DEFAULT_TOLERANCE, "target relative error against the exact matched filter",
                            range=(1e-12, 0.5))


#: Every former's options by method name (``auto`` last).
OPTIONS = {o.method: o for o in (DirectOptions, NufftOptions, PfaOptions, BackprojectionOptions, FfbpOptions,
                                   SubimageOptions, AutoOptions)}
#: Every knob name of any former, each once (``sar form-image``'s knob options).
KNOB_NAMES = tuple(dict.fromkeys(n for cls in OPTIONS.values() for n in cls.names()))
