"""Solvers of the regularised problem: ADMM (Appendix A), complex shrinkage, Tikhonov by CG."""

from .admm import ADMM, HISTORY_KEYS
from .shrink import complex_shrinkage, shrink
from .tikhonov import tikhonov

__all__ = ["ADMM", "HISTORY_KEYS", "shrink", "complex_shrinkage", "tikhonov"]
