"""Scenes for the simulator: point targets, built-in phantoms and image files.

Extended scenes never commit the inverse crime: they are synthesised as point scatterers on a
grid ``upsample`` times finer than the reconstruction grid (default 2, at least 2), aligned so each
reconstruction pixel holds ``upsample²`` fine cells. The truth written to ``/truth/scene`` is the
block mean of the fine complex values (the pixel model the image formers estimate), and
``/truth/magnitude`` the block mean of their magnitudes. With ``random_phase`` (paper section
``sec:rand``) each fine cell (``phase_cell: fine``, the paper's model) or each reconstruction pixel
(``phase_cell: pixel``) gets an independent phase uniform on [-π, π).

Scene section of the YAML (all keys optional, combinable)::

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

__all__ = ["validate_scene", "scene_half_width", "point_targets", "synthesize_extended", "ExtendedScene",
           "shepp_logan", "disks"]

PHANTOMS = ("shepp-logan", "disks")
EXT_KEYS = {"name", "path", "half_width_m", "random_phase", "phase_cell", "upsample", "amplitude"}


def _amplitude(ctx, key, value) -> complex:
    if isinstance(value, bool):
        ctx.fail(key, f"value {value!r} is not a number")
    if isinstance(value, (int, float)):
        return complex(value)
    if isinstance(value, (list, tuple)) and len(value) == 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return complex(value[0], value[1])
    if isinstance(value, dict) and set(value) <= {"magnitude", "phase_deg"} and "magnitude" in value:
        mag, ph = value["magnitude"], value.get("phase_deg", 0.0)
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (mag, ph)):
            ctx.fail(key, f"value {value!r}: magnitude and phase_deg must be numbers")
        return mag * np.exp(1j * np.radians(ph))
    ctx.fail(key, f"value {value!r} must be a number, [re, im], or {{magnitude, phase_deg}}")


def validate_scene(sec, *, ctx, base_dir=Path(".")) -> dict:
    """Validate the ``scene`` section; returns a normalised dict (positions in m, complex amplitudes)."""
    out: dict = {}
    if "points" in sec:
        pts = sec["points"]
        if not isinstance(pts, list):
            ctx.fail("scene.points", f"expected a list of points, got {type(pts).__name__}")
        pos, amp = [], []
        for i, p in enumerate(pts):
            key = f"scene.points[{i}]"
            if not isinstance(p, dict):
                ctx.fail(key, "expected a mapping {position_m: [x, y], amplitude: a}")
            unknown = set(p) - {"position_m", "amplitude"}
            if unknown:
                ctx.fail(f"{key}.{sorted(unknown)[0]}", "unknown key; valid keys: amplitude, position_m")
            xy = p.get("position_m")
            if (not isinstance(xy, (list, tuple)) or len(xy) not in (2, 3)
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in xy)):
                ctx.fail(f"{key}.position_m", f"value {xy!r} must be [x, y] or [x, y, z] in metres")
            xyz = [float(v) for v in xy] + ([0.0] if len(xy) == 2 else [])
            if not np.all(np.isfinite(xyz)):
                ctx.fail(f"{key}.position_m", f"value {xy!r} must be finite")
            pos.append(xyz)
            amp.append(_amplitude(ctx, f"{key}.amplitude", p.get("amplitude", 1.0)))
        out["points"] = {"position_m": np.array(pos, float).reshape(-1, 3), "amplitude": np.array(amp, complex)}
    for kind in ("phantom", "image_file"):
        if kind not in sec:
            continue
        s = sec[kind]
        key = f"scene.{kind}"
        if not isinstance(s, dict):
            ctx.fail(key, "expected a mapping")
        unknown = set(s) - EXT_KEYS
        if unknown:
            ctx.fail(f"{key}.{sorted(unknown)[0]}", f"unknown key; valid keys: {', '.join(sorted(EXT_KEYS))}")
        spec = {"kind": kind}
        if kind == "phantom":
            name = s.get("name", "shepp-logan")
            if name not in PHANTOMS:
                ctx.fail(f"{key}.name", f"value {name!r} unknown; expected one of {', '.join(PHANTOMS)}")
            spec["name"] = name
        else:
            if "path" not in s:
                ctx.fail(f"{key}.path", "missing required key (a .png or .npy file)")
            path = Path(s["path"])
            path = path if path.is_absolute() else Path(base_dir) / path
            if path.suffix.lower() not in (".png", ".npy"):
                ctx.fail(f"{key}.path", f"value {s['path']!r}: expected a .png or .npy file")
            if not path.exists():
                ctx.fail(f"{key}.path", f"file {str(path)!r} does not exist")
            spec["path"] = str(path)
        if "half_width_m" not in s:
            ctx.fail(f"{key}.half_width_m", "missing required key (half the side of the scene, metres)")
        hw = s["half_width_m"]
        if isinstance(hw, bool) or not isinstance(hw, (int, float)) or not hw > 0:
            ctx.fail(f"{key}.half_width_m", f"value {hw!r} must be a number > 0")
        spec["half_width_m"] = float(hw)
        rp = s.get("random_phase", False)
        if not isinstance(rp, bool):
            ctx.fail(f"{key}.random_phase", f"value {rp!r} must be true or false")
        spec["random_phase"] = rp
        pc = s.get("phase_cell", "fine")
        if pc not in ("fine", "pixel"):
            ctx.fail(f"{key}.phase_cell", f"value {pc!r} must be 'fine' or 'pixel'")
        spec["phase_cell"] = pc
        up = s.get("upsample", 2)
        if isinstance(up, bool) or not isinstance(up, int) or up < 2:
            ctx.fail(f"{key}.upsample", f"value {up!r} must be an integer >= 2 (no inverse crime)")
        spec["upsample"] = up
        spec["amplitude"] = _amplitude(ctx, f"{key}.amplitude", s.get("amplitude", 1.0))
        out[kind] = spec
    if "phantom" in out and "image_file" in out:
        ctx.fail("scene", "give at most one extended scene: 'phantom' or 'image_file'")
    return out


def scene_half_width(scene: dict, *, radius: bool = False, points: bool = True) -> float:
    """How far the scene reaches from the centre (m).

    With ``radius=False`` the largest |x| or |y| (half the side of the bounding square); with
    ``radius=True`` the largest distance from the centre (what aliasing is judged by).
    ``points=False`` leaves the point targets out (extended parts only).
    """
    half = 0.0
    if points and scene.get("points") is not None and len(scene["points"]["amplitude"]):
        xy = scene["points"]["position_m"][:, :2]
        half = float(np.max(np.hypot(xy[:, 0], xy[:, 1]) if radius else np.abs(xy)))
    for kind in ("phantom", "image_file"):
        if kind in scene:
            half = max(half, scene[kind]["half_width_m"])
    return half


def point_targets(scene: dict | None):
    """Point targets of a scene as ``(positions (S, 3), amplitudes (S,))``."""
    if not scene or "points" not in scene:
        return np.zeros((0, 3)), np.zeros(0, complex)
    return scene["points"]["position_m"], scene["points"]["amplitude"]


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
