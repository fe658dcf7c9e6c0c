"""The memory limit and the one check every size-driving parameter goes through.

Estimates live next to the code they estimate (:mod:`sarcli.formers.planning.cost`,
:mod:`sarcli.simulation.cost`, the YAML loader); they call :func:`check_memory` before anything
is allocated. The limit is the ``sar --max-memory`` option, else the machine's available memory
(``MemAvailable`` of ``/proc/meminfo``, else free physical pages).
"""

from __future__ import annotations

import os
import re

from ..errors import SarcliInputError

__all__ = ["available_memory", "memory_limit", "set_memory_limit", "check_memory", "parse_size",
           "format_bytes"]

_state: dict = {"limit": None}
_UNITS = {"": 1, "B": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation, or None when unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def parse_size(text) -> int:
    """``"4G"``, ``"512MiB"``, ``"1.5 GB"`` or a number of bytes -> bytes (binary units)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([KMGT]?)(?:i?B)?\s*", str(text), re.IGNORECASE)
    if not m:
        raise SarcliInputError(f"memory size {str(text)[:40]!r} not understood; expected e.g. 512M, 4G or 2.5GiB")
    value = float(m.group(1)) * _UNITS[m.group(2).upper()]
    if not value >= 1 << 20:
        raise SarcliInputError(f"memory size {str(text)[:40]!r} is below 1 MiB")
    return int(value)


def set_memory_limit(nbytes) -> None:
    """Set the limit in bytes (None: the available memory, looked up at each check)."""
    _state["limit"] = None if nbytes is None else int(nbytes)


def memory_limit() -> int | None:
    """The limit in force: the one set, else :func:`available_memory`."""
    return _state["limit"] if _state["limit"] is not None else available_memory()


def format_bytes(n: float) -> str:
    """Human-readable binary size, e.g. ``'7.28 TiB'``."""
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} PiB"  # pragma: no cover


def check_memory(estimate_bytes: float, what: str) -> None:
    """Raise :class:`SarcliInputError` when ``what`` would need more memory than the limit.

    Parameters
    ----------
    estimate_bytes : float
        Estimated peak memory of the step (may be astronomically large; never allocated).
    what : str
        The step and the parameters that drive its size, for the message.
    """
    limit = memory_limit()
    if limit is None or not estimate_bytes > limit:
        return
    src = "--max-memory" if _state["limit"] is not None else "the available memory"
    raise SarcliInputError(f"{what} needs about {format_bytes(estimate_bytes)} of memory, more than the limit "
                           f"{format_bytes(limit)} ({src}); reduce the size or raise sar --max-memory")

