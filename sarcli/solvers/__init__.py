"""Solvers of the regularised problem: ADMM (Appendix A), complex shrinkage, Tikhonov by CG."""

from .admm import ADMM, HISTORY_KEYS, Reestimate
from .shrink import complex_shrinkage, shrink
from .tikhonov import tikhonov

__all__ = ["ADMM", "Reestimate", "HISTORY_KEYS", "shrink", "complex_shrinkage", "tikhonov"]
