"""Linear operators of the regularised reconstruction: the SAR forward model A and the
sparsifying transforms T (paper section ``sec: reg``, Appendix A)."""

from .base import (Adjoint, Compose, Diagonal, Identity, Linop, MatrixLinop, Scaled, Sum,
                   gram_eigmax, power_norm)
from .finite_diff import PRIORS, FiniteDifference, phase_operator, sparsifying_operator
from .fourier import NufftOperator, SubsampledDFT, wrapped_pixel_frequencies
from .spherical import SphericalOperator
from .toeplitz import NormalEquations, ToeplitzGram, normal_equations

__all__ = [
    "Linop", "Identity", "Diagonal", "MatrixLinop", "Compose", "Sum", "Scaled", "Adjoint",
    "power_norm", "gram_eigmax", "FiniteDifference", "phase_operator", "sparsifying_operator",
    "PRIORS", "NufftOperator", "SubsampledDFT", "wrapped_pixel_frequencies", "ToeplitzGram",
    "NormalEquations", "normal_equations", "SphericalOperator",
]
