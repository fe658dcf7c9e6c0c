"""Memory needed by :func:`sarcli.simulation.simulate`, checked before anything is allocated."""

from __future__ import annotations

from .._util.resources import check_memory

__all__ = ["simulate_bytes", "check_simulate"]


def simulate_bytes(acq, *, precision="float32") -> float:
    """Upper-bound estimate (bytes) of the simulator's working memory (:class:`Simulation`).

    A point scene: one block of pulses (``BLOCK_SAMPLES`` samples: the complex128 sums, the noise
    and the stored copy), and the whole stored collection when it is built in memory (at most
    ``IN_MEMORY_MAX_BYTES`` of file, :mod:`sarcli.io.h5output`). An extended scene: the whole collection
    in complex128 three times (the sum, the noise, the stored copy) and the scene on the grid.
    """
    from ..io.h5output import IN_MEMORY_MAX_BYTES
    from .simulator import BLOCK_SAMPLES

    item = 8 if precision == "float32" else 16
    pm = float(acq.frequency_hz.size if acq.frequency_hz.ndim == 1 else acq.frequency_hz.shape[-1]) \
        * float(acq.azimuth_rad.size)
    npix = float(acq.grid.nx) * float(acq.grid.ny)
    extended = bool(acq.scene) and any(k in acq.scene for k in ("phantom", "image_file"))
    if extended:
        return pm * (16 * 3 + item) + 8 * npix * 16
    stored = pm * item if pm * item <= IN_MEMORY_MAX_BYTES else 0.0
    return min(pm, BLOCK_SAMPLES) * (16 * 4 + item) + stored


def check_simulate(acq, *, precision="float32") -> None:
    """Refuse a simulation whose estimated memory exceeds the limit (``sar --max-memory``)."""
    p, m = acq.azimuth_rad.size, acq.frequency_hz.shape[-1]
    check_memory(simulate_bytes(acq, precision=precision), f"simulating {p} pulses x {m} frequencies")
