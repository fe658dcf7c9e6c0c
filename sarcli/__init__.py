"""sarcli: spotlight SAR image formation, regularised reconstruction and accuracy analysis.

Public API (function-first; the ``sar`` CLI only calls these):

- :func:`load_acquisition` — YAML acquisition file -> :class:`Acquisition`
- :func:`simulate` — acquisition -> :class:`PhaseHistory`
- :func:`read_phase_history`, :func:`write_phase_history` — the HDF5 phase-history contract
- :func:`read_image`, :func:`write_image` — the HDF5 image contract
- :func:`form_image` — phase history -> :class:`Image` (direct, nufft, pfa, backprojection)

Names are imported lazily so ``import sarcli`` stays cheap.
"""

from __future__ import annotations

import importlib

from ._version import __version__

_LAZY = {
    "Acquisition": "acquisition",
    "Grid": "grid",
    "resolve_grid": "grid",
    "load_acquisition": "config",
    "parse_acquisition": "config",
    "PhaseHistory": "io",
    "Image": "io",
    "Truth": "io",
    "read_phase_history": "io",
    "write_phase_history": "io",
    "read_image": "io",
    "write_image": "io",
    "form_image": "formation",
}

# ``simulate`` is both a submodule and its main function: bind the function eagerly so that
# ``sarcli.simulate(...)`` works whichever is imported first.
from .simulate import simulate  # noqa: E402

__all__ = ["__version__", "simulate", *_LAZY]


def __getattr__(name):
    if name in _LAZY:
        module = importlib.import_module(f".{_LAZY[name]}", __name__)
        return getattr(module, name)
    raise AttributeError(f"module 'sarcli' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
