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
           "format_bytes", "retain_freed_memory"]

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


#: glibc's ``mallopt`` parameters (malloc.h).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3


def retain_freed_memory(block_bytes: int = 256 << 20) -> bool:
    """Let the process reuse the memory it frees (glibc; elsewhere nothing happens).

    By default glibc maps every block above its (adaptive) threshold afresh and unmaps it when
    freed, so a loop that makes and drops image-sized arrays pays page faults and the kernel's
    zeroing on every pass: a quarter of an ADMM iteration's time on an 800² grid. Here blocks up
    to ``block_bytes`` come from the heap and, freed, stay there for the next allocation (the top
    of the heap is returned beyond ``4 · block_bytes``); larger blocks are mapped as before.
    Process-wide: the ``sar`` commands that iterate call it; a library call does not.

    Returns
    -------
    bool
        Whether the allocator took the setting.
    """
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    block = int(min(block_bytes, 1 << 30))
    return bool(mallopt(_M_MMAP_THRESHOLD, block)) and bool(mallopt(_M_TRIM_THRESHOLD, 4 * block))
