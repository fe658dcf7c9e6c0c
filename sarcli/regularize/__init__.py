"""Regularised reconstruction: :func:`regularize` and the choice of its weight λ.

- :mod:`.options` — :class:`RegularizeOptions`: every setting, its default, check and help.
- :mod:`.problem` — :class:`Problem`: the operator chosen and built, its counted normal equations,
  the scaling that gives λ its meaning, the prior's transform; the matched filter of the same operator.
- :mod:`.driver` — :class:`Regularization` (problem, λ, final solve: an application object) and
  :func:`regularize`, its one-call form (phase history -> regularised :class:`~sarcli.core.types.Image`:
  TV, HOTV, ℓ1, phase-corrected TV by ADMM, Tikhonov by CG).
- :mod:`.forecast` — the products counted and the run's time and memory forecast.
- :mod:`.lampath` — the λ path of ``lam='auto'``: two solvers side by side (data, data plus a
  probe) and the record of the choice.
- :mod:`.regparam` — ``lam='auto'``: the noise power (file or range bins outside the scene),
  SURE and modified GCV with Monte-Carlo degrees of freedom on a warm-started path, and the
  discrepancy principle.

Sits above :mod:`sarcli.linops` and :mod:`sarcli.solvers`, below :mod:`sarcli.analysis`,
:mod:`sarcli.batch` and :mod:`sarcli.cli`.
"""

from __future__ import annotations

from .driver import Regularization, regularize
from .options import DEFAULT_BETA_RATIO, DEFAULT_LAM, OPERATORS, PRIORS, RegularizeOptions
from .problem import Problem, matched_filter, scale_problem

__all__ = ["regularize", "Regularization", "RegularizeOptions", "Problem", "PRIORS", "OPERATORS", "DEFAULT_LAM",
           "DEFAULT_BETA_RATIO", "matched_filter", "scale_problem"]
