"""Scenes for the simulator: point targets, built-in phantoms and image files.

Extended scenes never commit the inverse crime: they are synthesised as point scatterers on a
grid ``upsample`` times finer than the reconstruction grid (default 2, at least 2), aligned so each
reconstruction pixel holds ``upsample²`` fine cells. The truth written to ``/truth/scene`` is the
block mean of the fine complex values (the pixel model the image formers estimate), and
``/truth/magnitude`` the block mean of their magnitudes. With ``random_phase`` (paper section
``sec:rand``) each fine cell (``phase_cell: fine``, the paper's model) or each reconstruction pixel
(``phase_cell: pixel``) gets an independent phase uniform on [-π, π).

Scene section of the YAML (validated by :mod:`sarcli.io.scene_spec`) (all keys optional, combinable)::

    scene:
      points:
        - {position_m: [0, 0], amplitude: 1}          # amplitude: number, [re, im] or {magnitude, phase_deg}
      phantom: {name: shepp-logan, half_width_m: 4, random_phase: true, phase_cell: fine, upsample: 2, amplitude: 1}
      image_file: {path: scene.png, half_width_m: 4, random_phase: false, upsample: 2, amplitude: 1}
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.grid import Grid

__all__ = ["synthesize_extended", "ExtendedScene", "shepp_logan", "disks"]

# --------------------------------------------------------------------------------------------
# phantoms: values on normalised coordinates u, v in [-1, 1]
# --------------------------------------------------------------------------------------------
# modified Shepp-Logan (Toft): intensity, a, b, x0, y0, phi (deg)
_SHEPP = [
    (1.0, 0.69, 0.92, 0.0, 0.0, 0),
    (-0.8, 0.6624, 0.8740, 0.0, -0.0184, 0),
    (-0.2, 0.1100, 0.3100, 0.22, 0.0, -18),
    (-0.2, 0.1600, 0.4100, -0.22, 0.0, 18),
    (0.1, 0.2100, 0.2500, 0.0, 0.35, 0),
    (0.1, 0.0460, 0.0460, 0.0, 0.1, 0),
    (0.1, 0.0460, 0.0460, 0.0, -0.1, 0),
    (0.1, 0.0460, 0.0230, -0.08, -0.605, 0),
    (0.1, 0.0230, 0.0230, 0.0, -0.606, 0),
    (0.1, 0.0230, 0.0460, 0.06, -0.605, 0),
]


def shepp_logan(u, v):
    """Modified Shepp-Logan phantom evaluated analytically at normalised points (north up)."""
    out = np.zeros(np.broadcast(u, v).shape)
    for val, a, b, x0, y0, phi in _SHEPP:
        t = np.radians(phi)
        du, dv = u - x0, v - y0
        ur = du * np.cos(t) + dv * np.sin(t)
        vr = -du * np.sin(t) + dv * np.cos(t)
        out += val * ((ur / a) ** 2 + (vr / b) ** 2 <= 1.0)
    return out


def disks(u, v):
    """Disks and rectangles of several sizes and levels (a resolution / contrast target)."""
    out = np.zeros(np.broadcast(u, v).shape)
    for x0, y0, r, val in [(-0.5, 0.5, 0.3, 1.0), (0.45, 0.5, 0.2, 0.6), (0.5, -0.1, 0.1, 0.8),
                           (0.75, -0.1, 0.05, 1.0), (0.25, -0.1, 0.05, 0.4)]:
        out[(u - x0) ** 2 + (v - y0) ** 2 <= r * r] = val
    out[(np.abs(u + 0.4) <= 0.35) & (np.abs(v + 0.55) <= 0.2)] = 0.7
    out[(np.abs(u - 0.45) <= 0.3) & (np.abs(v + 0.65) <= 0.06)] = 0.5
    return out


def _image_file_values(path, u, v):
    from scipy.ndimage import map_coordinates

    p = Path(path)
    if p.suffix.lower() == ".npy":
        arr = np.load(p)
    else:
        import matplotlib.image as mpimg

        arr = mpimg.imread(p)
        if arr.ndim == 3:
            arr = arr[..., :3].mean(axis=-1)
    arr = np.asarray(arr)
    if arr.ndim != 2:
        raise ValueError(f"{path}: expected a 2-D image, got shape {arr.shape}")
    arr = arr[::-1]  # files store row 0 at the top (north); ours is south
    ny, nx = arr.shape
    cols = (u + 1) / 2 * nx - 0.5
    rows = (v + 1) / 2 * ny - 0.5
    inside = (np.abs(u) <= 1) & (np.abs(v) <= 1)
    if np.iscomplexobj(arr):
        val = (map_coordinates(arr.real, [rows, cols], order=1, mode="nearest")
               + 1j * map_coordinates(arr.imag, [rows, cols], order=1, mode="nearest"))
    else:
        val = map_coordinates(arr.astype(float), [rows, cols], order=1, mode="nearest")
    return np.where(inside, val, 0)


@dataclass(frozen=True, eq=False)
class ExtendedScene:
    """An extended scene synthesised on a fine grid.

    Attributes
    ----------
    fine_values : ndarray (nyf, nxf) complex
        Scattering amplitude of each fine cell (already divided by upsample²).
    fine_grid : Grid
    truth : ndarray (ny, nx) complex
        Block sum of ``fine_values`` on the reconstruction grid (the pixel-model truth).
    truth_magnitude : ndarray (ny, nx)
        Block sum of ``|fine_values|``.
    """

    fine_values: np.ndarray
    fine_grid: Grid
    truth: np.ndarray
    truth_magnitude: np.ndarray


def synthesize_extended(spec: dict, grid: Grid, rng: np.random.Generator) -> ExtendedScene:
    """Rasterise a phantom or image file on a grid ``upsample``× finer than ``grid``.

    The fine grid covers the reconstruction grid and, if larger, the scene's own extent (snapped
    to the reconstruction pixel lattice); the truth is reported on ``grid`` itself.
    """
    u = int(spec["upsample"])
    hw = float(spec["half_width_m"])
    # extend the coarse lattice (same pixel centres) until it covers the scene
    kx = max(0, int(np.ceil((hw + abs(grid.cx) - grid.extent[0] / 2) / grid.dx)))
    ky = max(0, int(np.ceil((hw + abs(grid.cy) - grid.extent[1] / 2) / grid.dy)))
    ext = Grid(grid.nx + 2 * kx, grid.ny + 2 * ky, grid.dx, grid.dy, grid.cx, grid.cy)
    fdx, fdy = grid.dx / u, grid.dy / u
    fine = Grid(ext.nx * u, ext.ny * u, fdx, fdy,
                ext.cx - grid.dx / 2 + fdx / 2, ext.cy - grid.dy / 2 + fdy / 2)
    xx, yy = np.meshgrid(fine.x / hw, fine.y / hw)
    if spec["kind"] == "phantom":
        values = (shepp_logan if spec["name"] == "shepp-logan" else disks)(xx, yy)
    else:
        values = _image_file_values(spec["path"], xx, yy)
    values = np.asarray(values, dtype=np.complex128) * spec["amplitude"]
    if spec.get("random_phase"):
        if spec.get("phase_cell", "fine") == "fine":
            phase = rng.uniform(-np.pi, np.pi, size=values.shape)
        else:
            coarse = rng.uniform(-np.pi, np.pi, size=ext.shape)
            phase = np.repeat(np.repeat(coarse, u, axis=0), u, axis=1)
        values = values * np.exp(1j * phase)
    values /= u * u

    def block_sum(a):
        return a.reshape(ext.ny, u, ext.nx, u).sum(axis=(1, 3))[ky:ky + grid.ny, kx:kx + grid.nx]

    return ExtendedScene(fine_values=values, fine_grid=fine, truth=block_sum(values),
                         truth_magnitude=block_sum(np.abs(values)))
