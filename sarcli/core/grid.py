"""The image grid: pixel-centre coordinates of a Cartesian scene patch.

docs/conventions.md: arrays are indexed ``[row, col] = [y, x]`` with ``x = cx + (col - nx/2) hx`` and
``y = cy + (row - ny/2) hy``; row 0 is the southern edge. The acquisition's own grid is square,
``h = 2R/N``, centred on the scene centre; image formers may be handed any other grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError, SarcliInputError
from . import geometry

__all__ = ["Grid", "resolve_grid", "derive_grid"]


#: Largest grid accepted (pixels): 2^28, i.e. 4 GiB per complex128 image.
MAX_PIXELS = 1 << 28
#: Largest side (pixels) of a grid derived from the sampling alone.
MAX_DERIVED_PIXELS = 8192


@dataclass(frozen=True)
class Grid:
    """A Cartesian pixel grid in the ground plane (z = 0).

    Parameters
    ----------
    nx, ny : int
        Number of columns (x, east) and rows (y, north).
    dx, dy : float
        Pixel spacing in metres.
    cx, cy : float
        Coordinates of the pixel with index ``(ny // 2, nx // 2)`` (the centre for even sizes).
    """

    nx: int
    ny: int
    dx: float
    dy: float
    cx: float = 0.0
    cy: float = 0.0

    def __post_init__(self):
        if int(self.nx) < 1 or int(self.ny) < 1:
            raise SarcliInputError(f"grid needs at least one pixel per side, got {self.ny} x {self.nx}")
        if not (self.dx > 0 and self.dy > 0 and np.isfinite(self.dx) and np.isfinite(self.dy)):
            raise SarcliInputError(f"pixel size must be positive and finite, got {self.dx}, {self.dy}")
        if int(self.nx) * int(self.ny) > MAX_PIXELS:
            raise SarcliInputError(
                f"grid of {self.ny} x {self.nx} pixels is too large (> {MAX_PIXELS:.3g} pixels, "
                f"{16 * int(self.nx) * int(self.ny) / 2**30:.3g} GiB as complex128): reduce --extent or "
                "increase --pixel-size")

    # -- constructors -------------------------------------------------------------------------
    @classmethod
    def square(cls, half_width_m: float, n: int, center=(0.0, 0.0)) -> "Grid":
        """The paper's grid: N × N pixels of length ``h = 2R/N`` (docs/conventions.md)."""
        h = 2.0 * float(half_width_m) / int(n)
        return cls(int(n), int(n), h, h, float(center[0]), float(center[1]))

    @classmethod
    def from_extent(cls, extent_m, pixel_m, center=(0.0, 0.0)) -> "Grid":
        """A grid covering full side lengths ``extent_m = (W, H)`` with square pixels ``pixel_m``.

        The pixel counts are rounded up to even numbers so the centre falls on a pixel centre.
        """
        w, hgt = (extent_m, extent_m) if np.isscalar(extent_m) else extent_m
        nx = max(2, int(np.ceil(float(w) / pixel_m - 1e-9)))
        ny = max(2, int(np.ceil(float(hgt) / pixel_m - 1e-9)))
        nx += nx % 2
        ny += ny % 2
        return cls(nx, ny, float(pixel_m), float(pixel_m), float(center[0]), float(center[1]))

    @classmethod
    def from_axes(cls, x_m, y_m) -> "Grid":
        """Recover a grid from increasing, uniformly spaced pixel-centre coordinates."""
        x = np.asarray(x_m, dtype=np.float64)
        y = np.asarray(y_m, dtype=np.float64)
        dx = float(x[1] - x[0]) if x.size > 1 else 1.0
        dy = float(y[1] - y[0]) if y.size > 1 else dx
        if x.size == 1 and y.size > 1:
            dx = dy
        return cls(x.size, y.size, dx, dy, float(x[x.size // 2]), float(y[y.size // 2]))

    # -- coordinates --------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        """Array shape ``(ny, nx)``."""
        return (int(self.ny), int(self.nx))

    @property
    def x(self) -> np.ndarray:
        """Pixel-centre x coordinates (m), increasing, shape (nx,)."""
        return self.cx + (np.arange(self.nx) - self.nx // 2) * self.dx

    @property
    def y(self) -> np.ndarray:
        """Pixel-centre y coordinates (m), increasing, shape (ny,)."""
        return self.cy + (np.arange(self.ny) - self.ny // 2) * self.dy

    @property
    def extent(self) -> tuple[float, float]:
        """Full side lengths ``(W, H)`` in metres."""
        return (self.nx * self.dx, self.ny * self.dy)

    @property
    def half_diagonal(self) -> float:
        """Largest distance from the scene centre (origin) to a pixel corner (m)."""
        xs = np.abs([self.x[0] - self.dx / 2, self.x[-1] + self.dx / 2])
        ys = np.abs([self.y[0] - self.dy / 2, self.y[-1] + self.dy / 2])
        return float(np.hypot(xs.max(), ys.max()))

    def points(self) -> np.ndarray:
        """All pixel centres as an array of shape (ny, nx, 3) with z = 0."""
        xx, yy = np.meshgrid(self.x, self.y)
        return np.stack([xx, yy, np.zeros_like(xx)], axis=-1)

    def index_of(self, x_m: float, y_m: float) -> tuple[int, int]:
        """Nearest pixel ``(row, col)`` to a point (may fall outside the grid)."""
        col = int(np.rint((x_m - self.cx) / self.dx)) + self.nx // 2
        row = int(np.rint((y_m - self.cy) / self.dy)) + self.ny // 2
        return row, col

    def as_dict(self) -> dict:
        return {"nx": int(self.nx), "ny": int(self.ny), "dx": float(self.dx), "dy": float(self.dy),
                "cx": float(self.cx), "cy": float(self.cy)}


def resolve_grid(default: Grid, *, center=None, extent=None, pixel_size=None) -> Grid:
    """Apply the user's grid overrides to a default grid.

    Parameters
    ----------
    default : Grid
        The acquisition's grid.
    center : (float, float), optional
        New grid centre (m).
    extent : float or (float, float), optional
        Full side lengths (m); default: the default grid's extent.
    pixel_size : float, optional
        Square pixel size (m); default: the default grid's.

    Returns
    -------
    Grid
        ``default`` itself when nothing is overridden.
    """
    if center is None and extent is None and pixel_size is None:
        return default
    c = (default.cx, default.cy) if center is None else tuple(float(v) for v in center)
    h = default.dx if pixel_size is None else float(pixel_size)
    ext = default.extent if extent is None else extent
    if pixel_size is not None and not (h > 0 and np.isfinite(h)):
        raise SarcliInputError(f"--pixel-size must be a positive number of metres, got {pixel_size}")
    if extent is not None:
        w, hh = (ext, ext) if np.isscalar(ext) else ext
        if not (w > 0 and hh > 0 and np.isfinite(w) and np.isfinite(hh)):
            raise SarcliInputError(f"--extent must be positive side lengths in metres, got {extent}")
        if (w / h) * (hh / h) > MAX_PIXELS:
            raise SarcliInputError(f"--extent {w:g} x {hh:g} m at {h:g} m pixels is "
                                   f"{(w / h) * (hh / h):.3g} pixels (more than {MAX_PIXELS:.3g}): "
                                   "reduce --extent or increase --pixel-size")
    return Grid.from_extent(ext, h, center=c)


def derive_grid(freq_hz, azimuth_rad, elevation_rad, *, scene_half_width_m=None, oversampling=2.0) -> Grid:
    """Default grid from the sampling: pixel = finest resolution / oversampling, extent = the
    scene's half width or the alias-free radius, whichever is smaller (nothing computed that the
    scene does not need).
    """
    rho = [r for r in geometry.resolutions(freq_hz, azimuth_rad, elevation_rad) if np.isfinite(r)]
    radii = [r for r in geometry.alias_free_radii(freq_hz, azimuth_rad, elevation_rad) if np.isfinite(r)]
    if not rho:
        raise ConfigError("cannot derive a pixel size from a single frequency and a single pulse; "
                          "give image.half_width_m and image.pixels", key="image")
    h = min(rho) / float(oversampling)
    limits = radii + ([scene_half_width_m] if scene_half_width_m else [])
    if not limits:
        raise ConfigError("cannot derive the scene extent; give image.half_width_m", key="image.half_width_m")
    half = min(limits)
    n = int(2 * math.ceil(half / h))
    n = max(2, n + (n % 2))
    if n > MAX_DERIVED_PIXELS:
        n = MAX_DERIVED_PIXELS
        h = 2 * half / n
    return Grid.square(n * h / 2, n)
