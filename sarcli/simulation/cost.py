"""Memory needed by :func:`sarcli.simulation.simulate`, checked before anything is allocated."""

from __future__ import annotations

from .._util.resources import check_memory

__all__ = ["simulate_bytes", "check_simulate"]


def simulate_bytes(acq, *, single=False) -> float:
    """Upper-bound estimate (bytes) of the simulator's working memory: the samples (complex128
    while summing), the stored copy, the noise and, for extended scenes, the scene on the grid."""
    pm = float(acq.frequency_hz.size if acq.frequency_hz.ndim == 1 else acq.frequency_hz.shape[-1]) \
        * float(acq.azimuth_rad.size)
    npix = float(acq.grid.nx) * float(acq.grid.ny)
    extended = bool(acq.scene) and any(k in acq.scene for k in ("phantom", "image_file"))
    return pm * (16 * 3 + (8 if single else 16)) + (8 * npix * 16 if extended else 0)


def check_simulate(acq, *, single=False) -> None:
    """Refuse a simulation whose estimated memory exceeds the limit (``sar --max-memory``)."""
    p, m = acq.azimuth_rad.size, acq.frequency_hz.shape[-1]
    check_memory(simulate_bytes(acq, single=single), f"simulating {p} pulses x {m} frequencies")
