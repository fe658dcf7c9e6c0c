"""Linear operators of the regularised reconstruction: the SAR forward model A and the
sparsifying transforms T (paper section ``sec: reg``, Appendix A).

Names are imported lazily, so a module that needs one operator (or the compiled reductions of
``_reduce``) does not pay for FINUFFT and SciPy's FFTs that others need.
"""

from __future__ import annotations

import importlib

_LAZY = {
    "Linop": "base", "Identity": "base", "Diagonal": "base", "MatrixLinop": "base", "Compose": "base",
    "Sum": "base", "Scaled": "base", "Adjoint": "base", "power_norm": "base", "gram_eigmax": "base",
    "FiniteDifference": "finite_diff", "phase_operator": "finite_diff", "sparsifying_operator": "finite_diff",
    "PRIORS": "finite_diff", "NufftOperator": "fourier", "SubsampledDFT": "fourier",
    "wrapped_pixel_frequencies": "fourier", "ToeplitzGram": "toeplitz", "NormalEquations": "toeplitz",
    "normal_equations": "toeplitz", "SphericalOperator": "spherical",
    "WarpedNufftOperator": "warped", "WarpedGram": "warped_gram",
}
#: The compiled reductions of ``_reduce`` that the solvers and the regulariser use, public here.
_LAZY.update({name: "_reduce" for name in (
    "empty", "rdot", "norm2", "rdot_diff", "norm2_diff", "rdot_diff2", "shrink_update", "axpy",
    "add_twice_diff", "step_dots")})

__all__ = list(_LAZY)


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'sarcli.linops' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
