"""CPHD (NGA.STND.0068) in and out, through sarkit (``docs/formats.md`` has the mapping).

Modules: :mod:`.read` (a channel as a phase history), :mod:`.signal` (the samples, read by rows
and decoded), :mod:`.validate` (what makes a file unreadable), :mod:`.corrections` (vendor
quirks, the phase sign against the data, the troposphere), :mod:`.write` (a phase history as a
one-channel FX file).

Public API
----------
read_cphd(path, lazy=False, channel=None, sgn=None, troposphere='auto') -> PhaseHistory
cphd_channels(path) -> list of dict
write_cphd(ph, path) -> Path
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .corrections import TROPOSPHERE_MODES
    from .read import AXES_TOLERANCE_RAD, cphd_channels, read_cphd
    from .signal import READ_BLOCK, CphdSignal
    from .write import CPHD_NS, NOMINAL_SPEED_M_S, pulse_times, write_cphd

__all__ = ["read_cphd", "cphd_channels", "write_cphd", "pulse_times", "CphdSignal", "NOMINAL_SPEED_M_S",
           "CPHD_NS", "READ_BLOCK", "AXES_TOLERANCE_RAD", "TROPOSPHERE_MODES"]

#: Where each public name lives: the package imports a module on first use of one of its names, so
#: that a command reading no CPHD (its options name the troposphere modes) pays nothing for lxml
#: and sarkit (10 ms of start-up).
_HOMES = {"read_cphd": "read", "cphd_channels": "read", "AXES_TOLERANCE_RAD": "read",
          "TROPOSPHERE_MODES": "corrections", "READ_BLOCK": "signal", "CphdSignal": "signal",
          "write_cphd": "write", "pulse_times": "write", "NOMINAL_SPEED_M_S": "write", "CPHD_NS": "write"}


def __getattr__(name):
    if name in _HOMES:
        return getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
