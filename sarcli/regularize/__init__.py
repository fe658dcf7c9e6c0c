"""Regularised reconstruction: :func:`regularize` and the choice of its weight λ.

- :mod:`.driver` — :func:`regularize` (phase history -> regularised :class:`~sarcli.core.types.Image`:
  TV, HOTV, ℓ1, phase-corrected TV by ADMM, Tikhonov by CG), the scaling that gives λ its meaning,
  the matched filter of the same operator, and the λ path's solvers.
- :mod:`.lampath` — the λ path of ``lam='auto'``: two solvers side by side (data, data plus a
  probe) and the record of the choice.
- :mod:`.regparam` — ``lam='auto'``: the noise power (file or range bins outside the scene),
  SURE and modified GCV with Monte-Carlo degrees of freedom on a warm-started path, and the
  discrepancy principle.

Sits above :mod:`sarcli.linops` and :mod:`sarcli.solvers`, below :mod:`sarcli.analysis`,
:mod:`sarcli.batch` and :mod:`sarcli.cli`.
"""

from __future__ import annotations

from .driver import (DEFAULT_BETA_RATIO, DEFAULT_LAM, OPERATORS, PRIORS, matched_filter, regularize,
                     scale_problem)

__all__ = ["regularize", "PRIORS", "OPERATORS", "DEFAULT_LAM", "DEFAULT_BETA_RATIO", "matched_filter",
           "scale_problem"]
