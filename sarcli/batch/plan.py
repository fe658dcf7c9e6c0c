"""Plans of ``sar batch``: validation of the YAML, expansion into jobs, sub-aperture and tile layouts.

:func:`load_plan` reads a plan file, checks every key (one line per mistake, naming the plan file
and the key, all raised together as one :class:`~sarcli.errors.ConfigError`) and expands it into
:class:`Job` records: one per input for plain jobs, one per azimuth window plus a composite for
``subapertures``, one per tile plus a stitch for ``tiles``. The plan language is documented in
``docs/batch.md``; running the jobs is :mod:`sarcli.batch.run`; sub-aperture and tile
layouts are :mod:`sarcli.batch.layout`.

Public API
----------
load_plan(path) -> Plan
parse_plan(mapping, *, source, base_dir) -> Plan
"""

from __future__ import annotations

import glob as _glob
import hashlib
import inspect
import os
import string
from dataclasses import asdict, dataclass, field
from pathlib import Path

from ..core.grid import Grid, resolve_grid
from ..core.types import to_json
from .._util.yamlsafe import short_repr
from ..errors import ConfigError, SarcliError
from .layout import input_geometry, subaperture_windows, tile_layout

__all__ = ["Job", "Plan", "load_plan", "parse_plan", "subaperture_windows", "tile_layout", "COMPOSITES",
           "POINTWISE_METHODS", "DEFAULT_MARGIN_PX"]

#: Composite of sub-aperture images: per-pixel maximum or incoherent mean of the magnitudes.
COMPOSITES = ("max", "mean")
#: Methods whose pixel values do not depend on the other pixels of the grid: tiles stitch exactly.
POINTWISE_METHODS = ("direct", "nufft", "backprojection")
#: Default tile margin (pixels) for methods that are not pointwise (pfa, regularize).
DEFAULT_MARGIN_PX = 16
_GRID_KEYS = {"center", "extent", "pixel_size"}
_COMMON_KEYS = {"input", "method", "options", "grid"}
_KEYS = {
    "": {"jobs", "defaults", "threads_per_job", "description"},
    "defaults": {"method", "options", "grid"},
    "job": _COMMON_KEYS | {"output"},
    "subapertures": _COMMON_KEYS | {"window_deg", "overlap_deg", "composite", "name"},
    "tiles": _COMMON_KEYS | {"tiles", "margin_px", "name"},
}
_GENERATORS = ("subapertures", "tiles")
_DEFAULT_OUTPUT = {"job": "{stem}_{method}.h5", "subapertures": "{stem}_subapertures",
                   "tiles": "{stem}_tiles"}


# ---------------------------------------------------------------------------------------------
# records
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Job:
    """One unit of work: form one image, or combine the images of other jobs.

    Attributes
    ----------
    name : str
        Output path relative to the output folder (unique within a plan).
    kind : {'image', 'composite', 'stitch'}
    input : str
        Absolute path of the phase-history (``.h5``) or GOTCHA (``.mat``) file.
    method : str
        ``form_image`` method or ``'regularize'``.
    options : dict
        Keyword options of that function.
    grid : dict
        Grid overrides ``{center, extent, pixel_size}``, or an exact grid ``{nx, ny, dx, dy, cx, cy}``.
    pulses : tuple of int, optional
        Pulse indices to image (sub-apertures).
    depends : tuple of str
        Names of the jobs whose outputs a combining job reads.
    extra : dict
        Kind-specific settings (composite mode, tile layout, azimuth window), recorded in the output.
    threads : int
        Threads of the compiled kernels (:func:`sarcli._native.threads`) and of FINUFFT inside
        the job.
    dep_fingerprints : tuple of str
        Fingerprints of ``depends`` (a combining job is redone when one of its inputs changes).
    origin : str
        The plan key the job came from (for messages; not part of the fingerprint).
    """

    name: str
    kind: str = "image"
    input: str = ""
    method: str = ""
    options: dict = field(default_factory=dict)
    grid: dict = field(default_factory=dict)
    pulses: tuple | None = None
    depends: tuple = ()
    extra: dict = field(default_factory=dict)
    threads: int = 1
    dep_fingerprints: tuple = ()
    origin: str = ""

    def spec(self) -> dict:
        """Everything that shapes the output (the fingerprint's content)."""
        d = asdict(self)
        for k in ("name", "threads", "origin"):
            d.pop(k)
        return d

    @property
    def fingerprint(self) -> str:
        """SHA-256 of the canonical JSON of :meth:`spec`."""
        return hashlib.sha256(to_json(self.spec()).encode()).hexdigest()


@dataclass(frozen=True, eq=False)
class Plan:
    """A validated, expanded plan: its source file and its jobs in submission order."""

    source: str
    jobs: tuple

    def __len__(self):
        return len(self.jobs)


# ---------------------------------------------------------------------------------------------
# plan validation and expansion
# ---------------------------------------------------------------------------------------------
class _Errors:
    """Collects one line per mistake; raises them together as a ConfigError."""

    def __init__(self, source):
        self.source = str(source)
        self.lines: list[str] = []
        self.first_key = None

    def add(self, key, message):
        line = str(ConfigError(message, source=self.source, key=key))
        if line not in self.lines:
            self.lines.append(line)
        self.first_key = self.first_key or key

    def raise_if_any(self):
        if self.lines:
            exc = ConfigError("\n".join(self.lines))
            exc.source, exc.key = self.source, self.first_key
            raise exc


def _method_signatures() -> dict:
    """Keyword options each method accepts, with a default of their type (the plan's ``options``
    are checked against them): ``form_image``'s settings and the method's knobs
    (:data:`sarcli.formers.options.OPTIONS`; a knob whose default is chosen by the former is
    checked as a number where it is one)."""
    from dataclasses import fields

    from ..formers.formation import MAP_KEYS, form_image
    from ..formers.options import OPTIONS

    skip = {"ph", "method", "grid", "center", "extent", "pixel_size", "init", "callback", "options"}

    def options(func):
        return {n: p.default for n, p in inspect.signature(func).parameters.items() if n not in skip}

    from ..regularize import regularize

    common = {**options(form_image), "taylor_nbar": 4, "taylor_sll_db": -35.0, **dict.fromkeys(MAP_KEYS)}
    sigs = {m: {**common, **{f.name: f.default if f.default is not None or f.metadata["kind"] is str else 0
                             for f in fields(cls)}} for m, cls in OPTIONS.items()}
    sigs["regularize"] = options(regularize)
    return sigs


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _check_keys(err, where, section, mapping) -> bool:
    if not isinstance(mapping, dict):
        err.add(where, f"expected a mapping, got {type(mapping).__name__} {short_repr(mapping)}")
        return False
    for key in mapping:
        if key not in _KEYS[section]:
            err.add(f"{where}.{key}" if where else str(key),
                    f"unknown key; valid keys: {', '.join(sorted(_KEYS[section]))}")
    return True


def _check_number(err, key, value, *, integer=False, lo=None, lo_open=False, hi=None, hi_open=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (integer and not isinstance(value, int)):
        err.add(key, f"expected {'an integer' if integer else 'a number'}, got {short_repr(value)}")
        return None
    if (lo is not None and (value <= lo if lo_open else value < lo)) or \
       (hi is not None and (value >= hi if hi_open else value > hi)):
        lo_s = "" if lo is None else f"{'>' if lo_open else '>='} {lo}"
        hi_s = "" if hi is None else f"{'<' if hi_open else '<='} {hi}"
        err.add(key, f"expected a value {' and '.join(s for s in (lo_s, hi_s) if s)}, got {short_repr(value)}")
        return None
    return value


def _check_grid(err, key, grid) -> dict:
    if grid is None:
        return {}
    if not isinstance(grid, dict):
        err.add(key, f"expected a mapping with {', '.join(sorted(_GRID_KEYS))}, got {short_repr(grid)}")
        return {}
    out = {}
    for k, v in grid.items():
        if k not in _GRID_KEYS:
            err.add(f"{key}.{k}", f"unknown key; valid keys: {', '.join(sorted(_GRID_KEYS))}")
        elif k == "pixel_size":
            out[k] = _check_number(err, f"{key}.{k}", v, lo=0, lo_open=True)
        else:
            vals = v if isinstance(v, list) else [v]
            n_ok = (1, 2) if k == "extent" else (2,)
            if len(vals) not in n_ok or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in vals):
                err.add(f"{key}.{k}", f"expected {'W or [W, H]' if k == 'extent' else '[x, y]'} in metres, got {short_repr(v)}")
            elif k == "extent" and min(vals) <= 0:
                err.add(f"{key}.{k}", f"expected positive side lengths, got {short_repr(v)}")
            else:
                out[k] = [float(x) for x in vals] if len(vals) == 2 else float(vals[0])
    return out


def _expand_inputs(err, key, pattern, base: Path) -> list[Path]:
    if not isinstance(pattern, str) or not pattern:
        err.add(key, f"expected a file path or glob, got {short_repr(pattern)}")
        return []
    full = Path(os.path.expanduser(pattern))
    full = full if full.is_absolute() else base / full
    if _glob.has_magic(str(full)):
        found = sorted(Path(p) for p in _glob.glob(str(full)) if Path(p).is_file())
        if not found:
            err.add(key, f"glob {pattern!r} matches no file (looked in {full.parent})")
        return [p.resolve() for p in found]
    if not full.is_file():
        err.add(key, f"no such file: {full}")
        return []
    return [full.resolve()]


def _render(err, key, template, **values) -> str | None:
    try:
        names = {f for _, f, _, _ in string.Formatter().parse(template) if f}
        unknown = names - set(values)
        if unknown:
            err.add(key, f"unknown placeholder {{{sorted(unknown)[0]}}} in {template!r}; "
                         f"use {', '.join('{' + v + '}' for v in sorted(values))}")
            return None
        return template.format(**values)
    except (ValueError, IndexError) as exc:
        err.add(key, f"bad template {template!r} ({exc})")
        return None


def parse_plan(plan: dict, *, source="<plan>", base_dir=None) -> Plan:
    """Validate a plan mapping and expand it into jobs (see the module docstring).

    Parameters
    ----------
    plan : dict
        The parsed YAML.
    source : str
        Name used in error messages (the plan file).
    base_dir : path, optional
        Folder that relative input paths are taken from (default: the current folder).

    Raises
    ------
    ConfigError
        Every mistake found, one line each, naming the plan file and the key.
    """
    err = _Errors(source)
    base = Path(base_dir or ".").resolve()
    if not _check_keys(err, "", "", plan):
        err.raise_if_any()
    if "jobs" not in plan:
        err.add("jobs", "missing required key (a list of jobs)")
    threads = _check_number(err, "threads_per_job", plan.get("threads_per_job", 1), integer=True, lo=1) or 1
    defaults = plan.get("defaults") or {}
    if _check_keys(err, "defaults", "defaults", defaults):
        defaults = {**defaults, "grid": _check_grid(err, "defaults.grid", defaults.get("grid"))}
    else:
        defaults = {}
    sigs = _method_signatures()
    raw_jobs = plan.get("jobs") or []
    if "jobs" in plan and (not isinstance(raw_jobs, list) or not raw_jobs):
        err.add("jobs", f"expected a non-empty list of jobs, got {short_repr(raw_jobs)}")
        raw_jobs = []
    jobs: list[Job] = []
    for i, entry in enumerate(raw_jobs):
        key = f"jobs[{i}]"
        if not isinstance(entry, dict):
            err.add(key, f"expected a mapping, got {short_repr(entry)}")
            continue
        gens = [g for g in _GENERATORS if g in entry]
        if gens:
            if len(entry) != 1:
                err.add(key, f"a '{gens[0]}' entry holds only that key, found {', '.join(sorted(entry))}")
                continue
            section, key, spec = gens[0], f"{key}.{gens[0]}", entry[gens[0]]
        else:
            section, spec = "job", entry
        if not _check_keys(err, key, section, spec):
            continue
        jobs.extend(_expand_entry(err, key, section, spec, defaults, sigs, threads, base))
    seen: dict[str, str] = {}
    for job in jobs:
        where = job.origin
        if job.name in seen:
            err.add(where, f"output {job.name!r} is also written by {seen[job.name]}; give distinct 'output'/'name'")
        seen.setdefault(job.name, where)
    err.raise_if_any()
    return Plan(source=str(source), jobs=tuple(jobs))


def load_plan(path) -> Plan:
    """Read, validate and expand a plan file (relative inputs are taken from its folder)."""
    from .._util.yamlsafe import load_yaml

    p = Path(path)
    if not p.is_file():
        raise ConfigError("no such plan file", source=str(path))
    data, _ = load_yaml(p, what="plan file")  # duplicate keys, aliases, NaN/Inf refused
    if not isinstance(data, dict):
        raise ConfigError(f"expected a mapping with 'jobs', got {type(data).__name__}", source=str(path))
    return parse_plan(data, source=str(path), base_dir=p.parent)


def _expand_entry(err, key, section, spec, defaults, sigs, threads, base) -> list[Job]:
    ok = True
    method = spec.get("method", defaults.get("method"))
    mkey = f"{key}.method" if "method" in spec else "defaults.method"
    if method is None:
        err.add(f"{key}.method", "missing: give 'method' here or in 'defaults'")
        ok = False
    elif method not in sigs:
        err.add(mkey, f"unknown method {method!r}; choose one of {', '.join(sigs)}")
        ok = False
    opts = spec.get("options") or {}
    if not isinstance(opts, dict):
        err.add(f"{key}.options", f"expected a mapping of options, got {short_repr(opts)}")
        opts, ok = {}, False
    options = {**(defaults.get("options") or {}), **opts}
    for k, v in options.items() if ok else ():
        where = f"{key}.options.{k}" if k in opts else f"defaults.options.{k}"
        if k not in sigs[method]:
            err.add(where, f"not an option of method {method!r}; valid: {', '.join(sorted(sigs[method]))}")
            ok = False
        elif _is_number(sigs[method][k]) and not _is_number(v) and v is not None:
            hint = " (YAML reads 1e-6 as text: write 1.0e-6)" if isinstance(v, str) else ""
            err.add(where, f"expected a number, got {short_repr(v)}{hint}")
            ok = False
    grid = {**defaults.get("grid", {}), **_check_grid(err, f"{key}.grid", spec.get("grid"))}
    inputs = []
    if "input" not in spec:
        err.add(f"{key}.input", "missing required key (a file path or glob)")
    else:
        inputs = _expand_inputs(err, f"{key}.input", spec["input"], base)
    out_key = f"{key}.output" if section == "job" else f"{key}.name"
    template = spec.get("output" if section == "job" else "name", _DEFAULT_OUTPUT[section])
    if not isinstance(template, str) or not template:
        err.add(out_key, f"expected a file name template, got {short_repr(template)}")
        ok = False
    params = {"job": lambda *_: (), "subapertures": _subaperture_params, "tiles": _tile_params}[section](
        err, key, spec, method)
    if not ok or params is None or not inputs:
        return []
    common = dict(method=method, options=options, threads=threads)
    jobs = []
    for n, path in enumerate(inputs):
        name = _render(err, out_key, template, stem=path.stem, method=method, index=n)
        if name is None:
            return []
        if Path(name).is_absolute() or ".." in Path(name).parts:
            err.add(out_key, f"must be a path inside the output folder, got {name!r}")
            return []
        if section == "job":
            jobs.append(Job(name=name, input=str(path), grid=grid, origin=key, **common))
        elif section == "subapertures":
            jobs.extend(_expand_subapertures(err, key, params, name, path, grid, common))
        else:
            jobs.extend(_expand_tiles(err, key, params, name, path, grid, common))
    return jobs


def _base_grid(err, key, path, grid) -> tuple:
    try:
        az, g0 = input_geometry(path)
        return az, resolve_grid(g0, center=grid.get("center"), extent=grid.get("extent"),
                                pixel_size=grid.get("pixel_size"))
    except (SarcliError, ValueError, OSError) as exc:
        err.add(f"{key}.input", f"cannot read the geometry of {path} ({exc})")
        return None, None


def _subaperture_params(err, key, spec, method):
    w = _check_number(err, f"{key}.window_deg", spec.get("window_deg"), lo=0, lo_open=True, hi=360)
    o = _check_number(err, f"{key}.overlap_deg", spec.get("overlap_deg", 0.0), lo=0,
                      hi=w if w else None, hi_open=True)
    mode = spec.get("composite", "max")
    if mode not in COMPOSITES:
        err.add(f"{key}.composite", f"expected one of {', '.join(COMPOSITES)}, got {mode!r}")
        return None
    return None if w is None or o is None else (w, o, mode)


#: most sub-aperture windows one plan entry may ask for
MAX_WINDOWS = 10_000


def _expand_subapertures(err, key, params, name, path, grid, common) -> list[Job]:
    w, o, mode = params
    az, full = _base_grid(err, key, path, grid)
    if az is None:
        return []
    exact = full.as_dict()
    import numpy as np

    n_windows = float(np.ptp(np.degrees(np.unwrap(np.asarray(az, np.float64))))) / (w - o)
    if n_windows > MAX_WINDOWS:  # before the windows are listed: a tiny window would hang here
        err.add(f"{key}.window_deg", f"{w:g}° windows advancing by {w - o:g}° give about {n_windows:.3g} windows "
                                     f"(more than {MAX_WINDOWS}); use wider windows")
        return []
    jobs = []
    for k, (a0, a1, pulses) in enumerate(subaperture_windows(az, w, o)):
        extra = {"subaperture": {"index": k, "azimuth_deg": [a0, a1], "n_pulses": len(pulses)}}
        jobs.append(Job(name=f"{name}/window_{k:03d}.h5", input=str(path), grid=exact, pulses=pulses,
                        extra=extra, origin=key, **common))
    jobs.append(Job(name=f"{name}/composite.h5", kind="composite", input=str(path), method=common["method"],
                    grid=exact, depends=tuple(j.name for j in jobs),
                    dep_fingerprints=tuple(j.fingerprint for j in jobs), threads=common["threads"],
                    origin=key, extra={"composite": mode, "window_deg": w, "overlap_deg": o}))
    return jobs


def _tile_params(err, key, spec, method):
    t = _check_number(err, f"{key}.tiles", spec.get("tiles"), integer=True, lo=1)
    default_margin = 0 if method in POINTWISE_METHODS else DEFAULT_MARGIN_PX
    m = _check_number(err, f"{key}.margin_px", spec.get("margin_px", default_margin), integer=True, lo=0)
    return None if t is None or m is None else (t, m)


def _expand_tiles(err, key, params, name, path, grid, common) -> list[Job]:
    t, m = params
    _, full = _base_grid(err, key, path, grid)
    if full is None:
        return []
    if t > min(full.nx, full.ny):
        err.add(f"{key}.tiles", f"{t} tiles per side exceed the grid's {full.ny} x {full.nx} pixels")
        return []
    jobs, layout = [], []
    for i, (r0, r1) in enumerate(tile_layout(full.ny, t)):
        for j, (c0, c1) in enumerate(tile_layout(full.nx, t)):
            nx, ny = c1 - c0 + 2 * m, r1 - r0 + 2 * m
            sub = Grid(nx, ny, full.dx, full.dy,
                       full.cx + (c0 - m + nx // 2 - full.nx // 2) * full.dx,
                       full.cy + (r0 - m + ny // 2 - full.ny // 2) * full.dy)
            tile = {"row": i, "col": j, "rows": [r0, r1], "cols": [c0, c1], "margin_px": m}
            jobs.append(Job(name=f"{name}/tile_r{i}_c{j}.h5", input=str(path), grid=sub.as_dict(),
                            extra={"tile": tile}, origin=key, **common))
            layout.append(tile)
    jobs.append(Job(name=f"{name}/stitched.h5", kind="stitch", input=str(path), method=common["method"],
                    grid=full.as_dict(), depends=tuple(j.name for j in jobs),
                    dep_fingerprints=tuple(j.fingerprint for j in jobs), threads=common["threads"],
                    origin=key, extra={"tiles": t, "margin_px": m, "layout": layout}))
    return jobs
