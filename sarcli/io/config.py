"""YAML acquisition files: schema, validation, and the derived default grid.

The loader converts units once, at the edge (``_ghz``, ``_mhz``, ``_deg`` keys become SI), and
every mistake is one :class:`~sarcli.errors.ConfigError` naming the file, the key, the value and
what is expected. The schema (every key, its unit and default) is in ``docs/config.md``; in short::

    name: three-points                       # optional
    model: spherical                         # farfield | spherical (default: spherical with a path)
    frequencies: {center_frequency_ghz: 10, bandwidth_mhz: 600, count: 512}   # or {list_ghz: [...]}
    elevation_deg: 30
    azimuths: {center_deg: 50, extent_deg: 3, count: 128}  # or {list_deg: [...]} or {full_circle: true, count: 360}
    geometry: {path: circle, standoff_range_m: 10000}     # farfield | circle | line | positions
    image: {half_width_m: 5, pixels: 500}                 # optional: derived from the sampling
    noise: {snr_db: 30}                                   # optional
    scene: {points: [{position_m: [0, 0], amplitude: 1}]} # or phantom / image_file
    location: {scene_center_lat_deg: 40.0, scene_center_lon_deg: -84.0}  # optional (exports)
"""

from __future__ import annotations

import difflib
import math
import warnings
from pathlib import Path

import numpy as np

from ..core import geometry
from ..core.acquisition import Acquisition
from ..errors import AliasingWarning, ConfigError, SarcliInputError
from ..core.grid import Grid, derive_grid
from .._util.resources import check_memory
from .._util.yamlsafe import load_yaml, short_repr

__all__ = ["load_acquisition", "parse_acquisition", "derive_grid", "SCHEMA"]

#: Valid keys of each section (the schema); nested scene keys are checked in :mod:`sarcli.io.scene_spec`.
SCHEMA = {
    "": {"name", "model", "frequencies", "elevation_deg", "azimuths", "geometry", "image", "noise",
         "scene", "location", "seed", "description"},
    "frequencies": {"center_frequency_ghz", "bandwidth_mhz", "count", "list_ghz"},
    "azimuths": {"center_deg", "extent_deg", "count", "list_deg", "full_circle", "start_deg"},
    "geometry": {"path", "standoff_range_m", "antenna_position_m"},
    "image": {"half_width_m", "pixels", "oversampling"},
    "noise": {"snr_db"},
    "location": {"scene_center_lat_deg", "scene_center_lon_deg", "scene_center_height_m"},
    "scene": {"points", "phantom", "image_file"},
}
REQUIRED = {"": ("frequencies", "azimuths")}
PATHS = ("farfield", "circle", "line", "positions")


class _Ctx:
    """Where values come from, for error messages."""

    def __init__(self, source):
        self.source = str(source) if source is not None else "<config>"

    def fail(self, key, message):
        raise ConfigError(message, source=self.source, key=key)


def _check_keys(ctx, section: str, mapping):
    if not isinstance(mapping, dict):
        ctx.fail(section or "(top level)", f"expected a mapping of keys, got {type(mapping).__name__} {short_repr(mapping)}")
    valid = SCHEMA[section]
    for key in mapping:
        if key not in valid:
            close = difflib.get_close_matches(str(key)[:100], sorted(valid), n=1, cutoff=0.5)
            hint = f"; did you mean '{close[0]}'?" if close else f"; valid keys: {', '.join(sorted(valid))}"
            key = short_repr(key, 80).strip("'")
            ctx.fail(f"{section}.{key}" if section else key, f"unknown key{hint}")
    for key in REQUIRED.get(section, ()):
        if key not in mapping:
            ctx.fail(f"{section}.{key}" if section else key, "missing required key")


def _number(ctx, key, value, *, lo=None, hi=None, lo_open=False, hi_open=False, integer=False, what=""):
    """Validate a number (not a bool, not a string) against a range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        kind = "an integer" if integer else "a number"
        hint = ""
        if isinstance(value, str) and len(value) < 40:
            try:
                float(value)
                hint = " (YAML 1.1 reads 1e12 or 1.0e12 as text: write 1.0e+12)"
            except ValueError:
                pass
        ctx.fail(key, f"value {short_repr(value)} is {type(value).__name__}, expected {kind}{what}{hint}")
    if integer and (not float(value).is_integer()):
        ctx.fail(key, f"value {short_repr(value)} is not an integer")
    v = int(value) if integer else float(value)
    if not math.isfinite(v):
        ctx.fail(key, f"value {short_repr(value)} must be finite")
    if lo is not None and (v < lo or (lo_open and v == lo)):
        ctx.fail(key, f"value {short_repr(value)} out of range: expected {'>' if lo_open else '>='} {lo}{what}")
    if hi is not None and (v > hi or (hi_open and v == hi)):
        ctx.fail(key, f"value {short_repr(value)} out of range: expected {'<' if hi_open else '<='} {hi}{what}")
    return v


def _number_list(ctx, key, value, *, lo=None, hi=None, lo_open=False):
    if not isinstance(value, (list, tuple)) or len(value) == 0:
        ctx.fail(key, f"value {short_repr(value)} must be a non-empty list of numbers")
    return np.array([_number(ctx, f"{key}[{i}]", v, lo=lo, hi=hi, lo_open=lo_open) for i, v in enumerate(value)])


def _parse_frequencies(ctx, sec) -> np.ndarray:
    _check_keys(ctx, "frequencies", sec)
    if "list_ghz" in sec:
        if set(sec) - {"list_ghz"}:
            ctx.fail("frequencies", "give either 'list_ghz' or centre/bandwidth/count, not both")
        f = _number_list(ctx, "frequencies.list_ghz", sec["list_ghz"], lo=0, lo_open=True)
        if f.max() > 1e3:
            ctx.fail("frequencies.list_ghz", f"value {f.max():g} looks like Hz; the key expects GHz (e.g. 10.0 for 10 GHz)")
        if len(np.unique(f)) != f.size:
            ctx.fail("frequencies.list_ghz", "frequencies must be distinct")
        return np.sort(f) * 1e9
    for key in ("center_frequency_ghz", "bandwidth_mhz", "count"):
        if key not in sec:
            ctx.fail(f"frequencies.{key}", "missing required key (or give 'list_ghz')")
    fc = _number(ctx, "frequencies.center_frequency_ghz", sec["center_frequency_ghz"], lo=0, lo_open=True)
    if fc > 1e3:
        ctx.fail("frequencies.center_frequency_ghz", f"value {fc:g} looks like Hz; the key expects GHz (e.g. 10.0 for 10 GHz)")
    bw = _number(ctx, "frequencies.bandwidth_mhz", sec["bandwidth_mhz"], lo=0)
    if bw > 1e6:
        ctx.fail("frequencies.bandwidth_mhz", f"value {bw:g} looks like Hz; the key expects MHz (e.g. 600 for 600 MHz)")
    m = _number(ctx, "frequencies.count", sec["count"], lo=1, integer=True)
    check_count(ctx, "frequencies.count", m)
    if bw / 2e3 >= fc:
        ctx.fail("frequencies.bandwidth_mhz", f"value {bw:g} MHz reaches zero or negative frequencies around {fc:g} GHz")
    if m > 1 and bw == 0:
        ctx.fail("frequencies.bandwidth_mhz", "value 0 with count > 1 gives duplicated frequencies: expected > 0")
    if m == 1:
        return np.array([fc * 1e9])
    return fc * 1e9 + (np.arange(m) - (m - 1) / 2) * (bw * 1e6 / (m - 1))


def _parse_azimuths(ctx, sec) -> np.ndarray:
    _check_keys(ctx, "azimuths", sec)
    if "list_deg" in sec:
        if set(sec) - {"list_deg"}:
            ctx.fail("azimuths", "give either 'list_deg' or centre/extent/count or full_circle, not a mix")
        a = _number_list(ctx, "azimuths.list_deg", sec["list_deg"])
        return np.radians(a)
    if sec.get("full_circle"):
        if not isinstance(sec["full_circle"], bool):
            ctx.fail("azimuths.full_circle", f"value {short_repr(sec['full_circle'])} must be true or false")
        if "count" not in sec:
            ctx.fail("azimuths.count", "missing required key")
        p = _number(ctx, "azimuths.count", sec["count"], lo=1, integer=True)
        check_count(ctx, "azimuths.count", p)
        start = _number(ctx, "azimuths.start_deg", sec.get("start_deg", 0.0))
        return np.radians(start + 360.0 * np.arange(p) / p)
    for key in ("center_deg", "extent_deg", "count"):
        if key not in sec:
            ctx.fail(f"azimuths.{key}", "missing required key (or give 'list_deg' or 'full_circle')")
    c = _number(ctx, "azimuths.center_deg", sec["center_deg"])
    e = _number(ctx, "azimuths.extent_deg", sec["extent_deg"], lo=0, hi=360)
    p = _number(ctx, "azimuths.count", sec["count"], lo=1, integer=True)
    check_count(ctx, "azimuths.count", p)
    if p > 1 and e == 0:
        ctx.fail("azimuths.extent_deg", "value 0 with count > 1 gives duplicated pulses: expected > 0")
    if p == 1:
        return np.radians([c])
    return np.radians(c + (np.arange(p) - (p - 1) / 2) * (e / (p - 1)))


def _parse_geometry(ctx, sec, az, el_rad):
    """Return (antenna positions or None, azimuths, elevations, path)."""
    if sec is None:
        sec = {"path": "farfield"}
    _check_keys(ctx, "geometry", sec)
    path = sec.get("path", "farfield")
    if path not in PATHS:
        ctx.fail("geometry.path", f"value {short_repr(path)} unknown; expected one of {', '.join(PATHS)}")
    if path == "farfield":
        if set(sec) - {"path"}:
            ctx.fail("geometry", "a far-field geometry takes no range or positions")
        return None, az, np.full(az.shape, el_rad), path
    if path in ("circle", "line"):
        if "standoff_range_m" not in sec:
            ctx.fail("geometry.standoff_range_m", f"missing required key for path '{path}'")
        r0 = _number(ctx, "geometry.standoff_range_m", sec["standoff_range_m"], lo=0, lo_open=True)
        if path == "circle":
            pos = geometry.antenna_positions_circle(az, el_rad, r0)
        else:
            center = 0.5 * (az.min() + az.max())
            if np.ptp(az) >= np.pi - 1e-9:
                ctx.fail("geometry.path", "a straight line cannot cover an aperture of 180° or more; use 'circle'")
            pos = geometry.antenna_positions_line(az, el_rad, r0, center)
        az2, el2, _ = geometry.angles_from_positions(pos)
        return pos, az2, el2, path
    raw = sec.get("antenna_position_m")
    if raw is None:
        ctx.fail("geometry.antenna_position_m", "missing required key for path 'positions'")
    try:
        pos = np.array(raw, dtype=np.float64)
    except (TypeError, ValueError):
        ctx.fail("geometry.antenna_position_m", "expected a list of [x, y, z] triples in metres")
    if pos.ndim != 2 or pos.shape[1] != 3 or not np.all(np.isfinite(pos)):
        ctx.fail("geometry.antenna_position_m", f"expected a list of finite [x, y, z] triples, got shape {pos.shape}")
    if np.any(pos[:, 2] <= 0):
        ctx.fail("geometry.antenna_position_m", "antenna heights (z) must be > 0")
    az2, el2, _ = geometry.angles_from_positions(pos)
    return pos, az2, el2, path


#: Resolution cells kept around each point target on a derived grid, in range and in cross-range:
#: the main lobe and the first sidelobes (which end two cells out without a window, three with
#: the widest windows sarcli offers).
POINT_MARGIN_CELLS = 4.0


def _points_half_width(scene, freq, az, el, pos, model) -> float:
    """Half-width of the centred square holding every point target's focus (its layover included,
    :func:`sarcli.core.geometry.image_plane_position`) with :data:`POINT_MARGIN_CELLS` range cells
    along the range direction and as many cross-range cells across it (0 without points)."""
    from .scene_spec import point_targets

    pts, _ = point_targets(scene)
    if len(pts) == 0:
        return 0.0
    rho_r, rho_cr = (r if np.isfinite(r) else 0.0 for r in geometry.resolutions(freq, az, el))
    spherical = model == "spherical" and pos is not None
    focus = geometry.image_plane_position(pts, model="spherical" if spherical else "farfield",
                                          antenna_position_m=pos,
                                          range_to_center_m=None if pos is None else np.linalg.norm(pos, axis=1))
    if geometry.total_aperture(az) >= np.pi:  # every direction is a range direction somewhere
        hx = hy = max(rho_r, rho_cr)
    else:
        th = float(np.angle(np.mean(np.exp(1j * np.asarray(az, dtype=np.float64)))))
        c, s = abs(math.cos(th)), abs(math.sin(th))
        # half-extents along x and y of the ellipse with semi-axes rho_r (range) and rho_cr
        hx, hy = math.hypot(rho_r * c, rho_cr * s), math.hypot(rho_r * s, rho_cr * c)
    k = POINT_MARGIN_CELLS
    return float(max(np.max(np.abs(focus[:, 0]) + k * hx), np.max(np.abs(focus[:, 1]) + k * hy)))


def parse_acquisition(cfg, *, source=None, text=None) -> Acquisition:
    """Build an :class:`Acquisition` from an already-parsed YAML mapping.

    Parameters
    ----------
    cfg : dict
    source : str, optional
        File name for messages and provenance (relative scene files resolve against its folder).
    text : str, optional
        The YAML text, kept for provenance.
    """
    from . import scene_spec

    ctx = _Ctx(source)
    if cfg is None:
        ctx.fail("(top level)", "the file is empty; expected an acquisition mapping")
    _check_keys(ctx, "", cfg)
    freq = _parse_frequencies(ctx, cfg["frequencies"])
    el = _number(ctx, "elevation_deg", cfg.get("elevation_deg", 30.0), lo=0, hi=90, lo_open=True, hi_open=True,
                 what=" (degrees above the ground plane)")
    az = _parse_azimuths(ctx, cfg["azimuths"])
    pos, az, el_arr, path = _parse_geometry(ctx, cfg.get("geometry"), az, np.radians(el))
    model = cfg.get("model", "farfield" if pos is None else "spherical")
    if model not in ("farfield", "spherical"):
        ctx.fail("model", f"value {short_repr(model)} unknown; expected 'farfield' or 'spherical'")
    if model == "spherical" and pos is None:
        ctx.fail("model", "value 'spherical' needs a flight path: set geometry.path to circle, line or positions")
    snr = None
    if cfg.get("noise") is not None:
        _check_keys(ctx, "noise", cfg["noise"])
        if cfg["noise"].get("snr_db") is not None:
            snr = _number(ctx, "noise.snr_db", cfg["noise"]["snr_db"], lo=-200, hi=400)
    scene = None
    if cfg.get("scene") is not None:
        _check_keys(ctx, "scene", cfg["scene"])
        base = Path(source).parent if source else Path(".")
        scene = scene_spec.validate_scene(cfg["scene"], ctx=ctx, base_dir=base)
    extra = _parse_extra(ctx, cfg, path)
    grid, scene_radius = _parse_image(ctx, cfg.get("image") or {}, scene, (freq, az, el_arr, pos, model))
    acq = Acquisition(frequency_hz=freq, azimuth_rad=az, elevation_rad=el_arr, grid=grid,
                      antenna_position_m=pos, model=model, snr_db=snr, scene=scene,
                      name=str(cfg.get("name", Path(source).stem if source else "")),
                      source=None if source is None else str(source), config_text=text, extra=extra)
    if scene_radius:
        r_rg, r_cr = acq.alias_free_radii()
        limit = min(r_rg, r_cr)
        if scene_radius > limit:
            warnings.warn(f"{ctx.source}: the scene reaches {scene_radius:.4g} m from the centre but the alias-free "
                          f"radius is {limit:.4g} m (range {r_rg:.4g} m, cross-range {r_cr:.4g} m): "
                          "scatterers beyond it wrap around", AliasingWarning, stacklevel=2)
    return acq


def _parse_extra(ctx, cfg, path) -> dict:
    """The acquisition's extras: the flight path's kind, the scene centre's location, the seed."""
    extra = {"geometry_path": path}
    if cfg.get("location") is not None:
        _check_keys(ctx, "location", cfg["location"])
        loc = cfg["location"]
        extra["scene_center_lat_deg"] = _number(ctx, "location.scene_center_lat_deg",
                                                loc.get("scene_center_lat_deg"), lo=-90, hi=90)
        extra["scene_center_lon_deg"] = _number(ctx, "location.scene_center_lon_deg",
                                                loc.get("scene_center_lon_deg"), lo=-180, hi=360)
        extra["scene_center_height_m"] = _number(ctx, "location.scene_center_height_m",
                                                 loc.get("scene_center_height_m", 0.0))
    if cfg.get("seed") is not None:
        extra["seed"] = _number(ctx, "seed", cfg["seed"], lo=0, integer=True)
    return extra


def _parse_image(ctx, img: dict, scene, collection):
    """The image grid (``image.half_width_m`` and ``image.pixels``, or derived from the collection
    and the scene at ``image.oversampling``) and the scene's radius (None without a scene).
    ``collection``: frequencies, azimuths, elevations, antenna positions and model."""
    from . import scene_spec

    freq, az, el_arr, pos, model = collection
    _check_keys(ctx, "image", img)
    over = _number(ctx, "image.oversampling", img.get("oversampling", 2.0), lo=0.5, hi=64)
    scene_half = scene_radius = None
    if scene:
        scene_half = max(scene_spec.scene_half_width(scene, points=False),
                         _points_half_width(scene, freq, az, el_arr, pos, model)) or None
        scene_radius = scene_spec.scene_half_width(scene, radius=True)
    if "half_width_m" in img or "pixels" in img:
        if not ("half_width_m" in img and "pixels" in img):
            missing = "pixels" if "half_width_m" in img else "half_width_m"
            ctx.fail(f"image.{missing}", "missing: give both image.half_width_m (R) and image.pixels (N), or neither")
        r = _number(ctx, "image.half_width_m", img["half_width_m"], lo=0, lo_open=True)
        n = _number(ctx, "image.pixels", img["pixels"], lo=2, integer=True, what=" (an even pixel count N)")
        if n % 2:
            ctx.fail("image.pixels", f"value {n} is odd: expected an even pixel count N >= 2")
        return Grid.square(r, n), scene_radius
    try:
        return derive_grid(freq, az, el_arr, scene_half_width_m=scene_half, oversampling=over), scene_radius
    except ConfigError as exc:
        ctx.fail(exc.key, str(exc).split(": ", 1)[-1])


def check_count(ctx, key, n, *, per_item_bytes=8 * 4):
    """Refuse a sample count whose arrays would not fit in memory (before they are allocated)."""
    try:
        check_memory(n * per_item_bytes, f"value {n}")
    except SarcliInputError as exc:
        ctx.fail(key, str(exc))


def load_acquisition(path) -> Acquisition:
    """Read a YAML acquisition file (the public entry point).

    The file is read by :func:`sarcli._util.yamlsafe.load_yaml`: duplicate keys, anchors and
    aliases, NaN and infinities are refused with the line they are on.

    Raises
    ------
    ConfigError
        Missing file, YAML syntax error, unknown/missing keys, wrong types, out-of-range values.
    """
    cfg, text = load_yaml(path, what="YAML acquisition file")
    return parse_acquisition(cfg, source=str(path), text=text)
