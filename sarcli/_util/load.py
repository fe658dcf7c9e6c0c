"""How busy the machine is now: other runnable threads, and what they do to a command's wall time.

``sar plan`` predicts times for an idle machine (the calibrated constants are per-operation
costs on an idle machine, and auto's pick must not depend on the moment). Beside them it gives
the time at the present load: with ``n`` other runnable threads on ``p`` usable processors, a
command running ``t`` threads gets ``p t / (t + n)`` processors once ``t + n > p`` (the
scheduler shares them out evenly), so its wall time stretches by ``max(1, (t + n) / p)``.

The count of runnable threads is Linux's ``procs_running`` (``/proc/stat``), sampled a few times
over a fraction of a second; this process's own sampling thread is one of them. Elsewhere
(no ``/proc``) the machine counts as idle.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

__all__ = ["Load", "present_load", "usable_cpus"]


def usable_cpus() -> int:
    """Processors this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def _procs_running(path: str = "/proc/stat") -> int | None:
    try:
        with open(path) as fh:
            for line in fh:
                if line.startswith("procs_running"):
                    return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return None


@dataclass(frozen=True)
class Load:
    """Other runnable threads (mean over the samples) and the usable processors."""

    others: float
    cpus: int

    def slowdown(self, threads: int) -> float:
        """Factor by which a command of ``threads`` busy threads takes longer than on an idle machine."""
        t = max(1, int(threads))
        return max(1.0, (t + max(self.others, 0.0)) / max(self.cpus, 1))


def present_load(samples: int = 5, interval_s: float = 0.04, path: str = "/proc/stat") -> Load:
    """The machine's load now: ``samples`` readings of the runnable-thread count ``interval_s`` apart,
    less this process's own thread (zero others where the count cannot be read)."""
    counts = []
    for i in range(max(1, int(samples))):
        if i:
            time.sleep(interval_s)
        n = _procs_running(path)
        if n is None:
            return Load(0.0, usable_cpus())
        counts.append(n)
    return Load(max(0.0, sum(counts) / len(counts) - 1.0), usable_cpus())
