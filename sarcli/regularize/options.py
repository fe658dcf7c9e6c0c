"""The settings of a regularised reconstruction: :class:`RegularizeOptions`.

One home for every knob of :func:`sarcli.regularize.regularize` and ``sar regularize``: its default,
its check (one line naming the knob and what is expected) and its help. The constants beside it
are the defaults' sources.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..core import geometry
from ..errors import SarcliInputError
from ..formers.planning.cost import NUFFT_EPS

__all__ = ["RegularizeOptions", "PRIORS", "OPERATORS", "DEFAULT_LAM", "DEFAULT_BETA_RATIO",
           "DEFAULT_OPERATOR_TOLERANCE", "MIN_PULSES_PER_RUN", "DEFOCUS_WARN_RAD"]

PRIORS = ("l1", "tv", "hotv", "ptv", "tikhonov")
OPERATORS = ("auto", "nufft", "toeplitz", "warped", "spherical")
#: Relative error of AᴴA (against the exact spherical model) the 'warped' operator is held to.
DEFAULT_OPERATOR_TOLERANCE = 1e-3
#: 'auto' takes the warped operator only with at least this many pulses per sub-aperture: with
#: fewer, spreading every pixel once per sub-aperture costs about what backprojecting them does.
MIN_PULSES_PER_RUN = 32
#: Default λ per prior, in the normalised units of :mod:`sarcli.regularize.problem` (ℓ1: λ ≥ 2
#: zeroes the image).
DEFAULT_LAM = {"l1": 0.05, "tv": 0.02, "hotv": 0.02, "ptv": 0.02, "tikhonov": 0.05}
#: Default β = ratio · λ: the shrinkage threshold λ/β is then 1/32 of the normalised image scale,
#: the reference solver's β = 2⁵ (with its data term μ/2 = 1/λ).
DEFAULT_BETA_RATIO = 32.0
#: Phase error (rad) above which 'auto' picks the spherical pair (and a far-field pair warns).
DEFOCUS_WARN_RAD = geometry.DEFOCUS_WARN_RAD


def _help(text: str) -> dict:
    return {"help": text}


@dataclass
class RegularizeOptions:
    """What to solve and how (paper eq. ``eq: reg`` / ``eq: main-L1``).

    Attributes
    ----------
    prior : {'l1', 'tv', 'hotv', 'ptv', 'tikhonov'}
        ℓ1 (T = I), TV (D), higher-order TV (Dᵏ), phase-corrected TV (Dᵏ Θ), Tikhonov (‖Dᵏf‖²).
    order : {1, 2, 3}
        k for 'hotv', 'ptv' and 'tikhonov'.
    lam : float, 'auto' or None
        λ in normalised units; 'auto': chosen on a warm-started path (:mod:`.lampath`); None:
        :data:`DEFAULT_LAM`.
    beta : float, optional
        ADMM penalty β (default ``DEFAULT_BETA_RATIO · λ``; with ``lam='auto'`` the ratio β/λ of
        a given β at the default λ is kept).
    iters, tol : int, float
        Iteration cap and relative-change tolerance (CG residual tolerance for 'tikhonov').
    operator : {'auto', 'nufft', 'toeplitz', 'warped', 'spherical'}
        Forward model (:func:`sarcli.regularize.problem.choose_operator`).
    tolerance : float
        Relative error of AᴴA, against the exact spherical model, the warped operator is held to.
    isotropic : bool
        Isotropic (per-pixel vector) or anisotropic shrinkage of the differences.
    inner_iters : int
        Gradient steps per ADMM iteration.
    reestimate_every : int
        'ptv': re-estimate Θ from the iterate every this many iterations (0: never).
    eps : float
        NUFFT tolerance of the far-field operators.
    """

    prior: str = field(default="ptv", metadata=_help(
        "Regulariser: TV, higher-order TV, l1, phase-corrected TV, Tikhonov."))
    order: int = field(default=1, metadata=_help("Difference order k (hotv, ptv, tikhonov)."))
    lam: float | str | None = field(default="auto", metadata=_help(
        "Regularisation weight λ in normalised units (l1: λ ≥ 2 zeroes the image); auto: SURE with the noise "
        "power from the file or from range bins outside the scene, else generalised cross-validation (no "
        "noise level needed)."))
    beta: float | None = field(default=None, metadata=_help("ADMM penalty β (default 32 λ)."))
    iters: int = field(default=300, metadata=_help("Iteration cap."))
    tol: float = field(default=1e-4, metadata=_help("Relative-change tolerance."))
    operator: str = field(default="auto", metadata=_help(
        "Forward operator: far-field NUFFT pair or its pre-gridded Toeplitz form; for spherical data, warped "
        "sub-aperture NUFFTs held to --tolerance or the exact backprojection pair. auto: Toeplitz where the "
        "far field holds, else warped where it meets --tolerance, else the exact pair."))
    tolerance: float = field(default=DEFAULT_OPERATOR_TOLERANCE, metadata=_help(
        "Relative error of AᴴA, against the exact spherical model, that the warped operator is held to "
        "(--tol is the solver's stopping tolerance)."))
    isotropic: bool = field(default=True, metadata=_help("Isotropic TV shrinkage."))
    inner_iters: int = field(default=1, metadata=_help("Gradient steps per ADMM iteration."))
    reestimate_every: int = field(default=0, metadata=_help(
        "ptv: re-estimate the phases Θ from the iterate every N iterations (0: never)."))
    eps: float = field(default=NUFFT_EPS, metadata=_help("NUFFT tolerance of the far-field operators."))

    @classmethod
    def from_knobs(cls, options: "RegularizeOptions | None" = None, **knobs) -> "RegularizeOptions":
        """``options`` (default: the defaults) with ``knobs`` replacing fields; an unknown knob is
        one line naming it and the knobs there are."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(knobs) - names)
        if unknown:
            raise SarcliInputError(f"regularize: unknown option {unknown[0]!r}; the options are "
                                   f"{', '.join(sorted(names))}")
        return dataclasses.replace(cls() if options is None else options, **knobs)

    @property
    def auto(self) -> bool:
        """λ is chosen by the path (``lam='auto'``)."""
        return isinstance(self.lam, str)

    def resolved(self) -> "RegularizeOptions":
        """A checked copy with λ and β as numbers (λ 'auto' starts the path's ratio at
        :data:`DEFAULT_LAM`): one :class:`~sarcli.errors.SarcliInputError` line per mistake."""
        if self.prior not in PRIORS:
            raise SarcliInputError(f"unknown prior {self.prior!r}; choose one of {', '.join(PRIORS)}")
        if self.operator not in OPERATORS:
            raise SarcliInputError(f"unknown operator {self.operator!r}; choose one of {', '.join(OPERATORS)}")
        if int(self.order) not in (1, 2, 3):
            raise SarcliInputError(f"order must be 1, 2 or 3, got {self.order}")
        if self.auto and self.lam != "auto":
            raise SarcliInputError(f"lam must be a number >= 0 or 'auto', got {self.lam!r}")
        lam = DEFAULT_LAM[self.prior] if (self.lam is None or self.auto) else float(self.lam)
        if not (np.isfinite(lam) and lam >= 0):
            raise SarcliInputError(f"lam must be a finite number >= 0, got {lam}")
        beta = DEFAULT_BETA_RATIO * lam if self.beta is None else float(self.beta)
        if self.prior != "tikhonov" and beta == 0.0:
            beta = DEFAULT_BETA_RATIO * np.finfo(float).tiny ** 0.5  # λ = 0: any β > 0 works
        if self.prior != "tikhonov" and not (np.isfinite(beta) and beta > 0):
            raise SarcliInputError(f"beta must be a finite number > 0, got {beta}")
        if int(self.iters) < 1 or not (self.tol > 0):
            raise SarcliInputError(f"iters must be >= 1 and tol > 0, got {self.iters}, {self.tol}")
        if not (0 < self.tolerance < 1):
            raise SarcliInputError(f"tolerance must be in (0, 1), got {self.tolerance}")
        return dataclasses.replace(self, order=int(self.order), iters=int(self.iters), tol=float(self.tol),
                                   lam="auto" if self.auto else lam, beta=beta)

    @property
    def beta_ratio(self) -> float:
        """β/λ that the path keeps (:data:`DEFAULT_BETA_RATIO` unless β was given at a λ > 0)."""
        lam = DEFAULT_LAM[self.prior] if self.auto or self.lam is None else float(self.lam)
        return DEFAULT_BETA_RATIO if (self.beta is None or lam == 0) else float(self.beta) / lam
