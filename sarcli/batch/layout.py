"""How ``sar batch`` splits work: azimuth sub-aperture windows and image tiles.

Public API
----------
subaperture_windows(azimuth_rad, window_deg, overlap_deg) -> list of (start_deg, stop_deg, pulses)
tile_layout(n, tiles) -> list of (start, stop)
input_geometry(path) -> (azimuth_rad, grid)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.grid import Grid

__all__ = ["subaperture_windows", "tile_layout", "input_geometry", "INPUT_FORMATS"]

#: the input formats a batch job reads (keys of :data:`sarcli.io.FORMATS`, recognised by content)
INPUT_FORMATS = ("phase-history", "gotcha", "cphd")


def input_geometry(path: Path):
    """Azimuths (rad) and default grid of an input, reading as little as possible."""
    from ..io import detect_format, open_input

    fmt = detect_format(path)
    if fmt != "phase-history":  # GOTCHA, CPHD (its signal stays on disk), or one line naming the format
        acq = open_input(path, expect=INPUT_FORMATS, truth=False, lazy=True)[1].acquisition
        return acq.azimuth_rad, acq.grid
    import h5py

    from ..io.hdf5 import read_phase_history

    try:
        with h5py.File(path, "r") as f:
            if "grid" in f and "azimuth_rad" in f:
                g = f["grid"].attrs
                grid = Grid(int(g["nx"]), int(g["ny"]), float(g["dx"]), float(g["dy"]),
                            float(g["cx"]), float(g["cy"]))
                return np.asarray(f["azimuth_rad"][()], np.float64), grid
    except (OSError, KeyError):
        pass
    acq = read_phase_history(path).acquisition
    return acq.azimuth_rad, acq.grid


def subaperture_windows(azimuth_rad, window_deg: float, overlap_deg: float = 0.0) -> list:
    """Split pulses into azimuth windows of ``window_deg`` overlapping by ``overlap_deg``.

    Windows start at the first azimuth and advance by ``window_deg - overlap_deg``; a pulse
    belongs to ``[start, start + W)`` measured with half a pulse spacing of slack. When the
    windows leave pulses uncovered at the end, one more window is aligned to the end, so every
    pulse is imaged. Azimuths are unwrapped in pulse order (a collection may cross 180°).

    Returns
    -------
    list of (start_deg, stop_deg, pulses)
        ``pulses`` a tuple of pulse indices; windows without pulses are dropped.
    """
    az = np.degrees(np.unwrap(np.asarray(azimuth_rad, np.float64)))
    step = float(window_deg) - float(overlap_deg)
    spacing = float(np.median(np.abs(np.diff(az)))) if az.size > 1 else 0.0
    lo, total = float(az.min()), float(az.max() - az.min()) + spacing
    n = 1 if total <= window_deg else int(np.floor((total - window_deg) / step + 1e-9)) + 1
    starts = [lo + k * step for k in range(n)]
    if starts[-1] + window_deg < lo + total - 0.5 * spacing - 1e-9:
        starts.append(lo + total - window_deg)
    out = []
    for s in starts:
        sel = np.flatnonzero((az >= s - 0.5 * spacing) & (az < s + window_deg - 0.5 * spacing))
        if sel.size:
            out.append((s, s + window_deg, tuple(int(i) for i in sel)))
    return out


def tile_layout(n: int, tiles: int) -> list:
    """Split ``n`` pixels into ``tiles`` contiguous runs ``(start, stop)`` differing by at most one."""
    edges = np.linspace(0, n, tiles + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]
