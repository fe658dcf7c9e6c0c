"""The ``scene`` section of an acquisition file: its schema and validation.

Scene section of the YAML (all keys optional, combinable)::

    scene:
      points:
        - {position_m: [0, 0], amplitude: 1}          # amplitude: number, [re, im] or {magnitude, phase_deg}
      phantom: {name: shepp-logan, half_width_m: 4, random_phase: true, phase_cell: fine, upsample: 2, amplitude: 1}
      image_file: {path: scene.png, half_width_m: 4, random_phase: false, upsample: 2, amplitude: 1}

:func:`validate_scene` turns the section into a normalised dict (positions in metres, complex
amplitudes, image-file paths resolved), which :mod:`sarcli.simulation.scenes` synthesises.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["validate_scene", "scene_half_width", "point_targets", "PHANTOMS"]

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
