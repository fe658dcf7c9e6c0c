"""Pixel mappings shared by the exporters: magnitude, dB, north-up flip."""

from __future__ import annotations

import numpy as np

from ..errors import SarcliInputError

__all__ = ["KINDS", "north_up", "magnitude", "decibels", "db_to_uint8"]

KINDS = ("magnitude", "db", "complex")

#: What every north-up export records about the flip (docs/conventions.md: our row 0 is south).
FLIP_NOTE = "rows flipped to north-up: file row 0 is the northern edge (sarcli image row 0 is south)"


def check_kind(kind: str, allowed=KINDS, fmt: str = "") -> str:
    if kind not in allowed:
        where = f" for {fmt}" if fmt else ""
        raise SarcliInputError(f"kind {kind!r} is not available{where}; choose one of {', '.join(allowed)}")
    return kind


def check_dynamic_range(dynamic_range_db: float) -> float:
    dr = float(dynamic_range_db)
    if not (dr > 0 and np.isfinite(dr)):
        raise SarcliInputError(f"dynamic range must be a positive number of dB, got {dynamic_range_db}")
    return dr


def north_up(a: np.ndarray) -> np.ndarray:
    """Flip rows so that row 0 is the northern edge (our arrays have row 0 south)."""
    return np.ascontiguousarray(np.asarray(a)[::-1])


def magnitude(image: np.ndarray) -> np.ndarray:
    """|f| as float32."""
    return np.abs(np.asarray(image)).astype(np.float32)


def decibels(image: np.ndarray, dynamic_range_db: float, *, relative: bool) -> np.ndarray:
    """``20 log10 |f|`` (or ``20 log10(|f| / max|f|)`` if ``relative``), floored at peak - DR.

    An all-zero image maps to -DR everywhere (relative) so no -inf ever reaches a file.
    """
    mag = np.abs(np.asarray(image)).astype(np.float64)
    peak = float(mag.max()) if mag.size else 0.0
    if peak <= 0 or not np.isfinite(peak):
        return np.full(mag.shape, -dynamic_range_db, dtype=np.float32)
    ref = peak if relative else 1.0
    floor_db = 20.0 * np.log10(peak / ref) - dynamic_range_db
    with np.errstate(divide="ignore"):
        db = 20.0 * np.log10(mag / ref)
    return np.maximum(db, floor_db).astype(np.float32)


def db_to_uint8(image: np.ndarray, dynamic_range_db: float) -> np.ndarray:
    """Relative dB clipped to [-DR, 0] mapped linearly onto 0..255 (peak exactly 255, -DR → 0)."""
    db = decibels(image, dynamic_range_db, relative=True).astype(np.float64)
    v = np.rint((np.clip(db, -dynamic_range_db, 0.0) + dynamic_range_db) * (255.0 / dynamic_range_db))
    return np.clip(v, 0, 255).astype(np.uint8)
