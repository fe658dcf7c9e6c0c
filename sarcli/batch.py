"""Batches of imaging jobs on dask: plan files, job expansion, resumable execution.

A *plan* (YAML) lists jobs; :func:`load_plan` validates it (one line per mistake, naming the plan
file and the key) and expands it into :class:`Job` objects; :func:`run_plan` runs them on a dask
``distributed`` cluster (an embedded :class:`~distributed.LocalCluster` by default, or an existing
scheduler) and returns a :class:`BatchReport`. The plan language is documented in ``docs/batch.md``::

    threads_per_job: 1                      # numba / FINUFFT threads inside one job (default 1)
    defaults: {method: backprojection, options: {window: none}, grid: {pixel_size: 0.05}}
    jobs:
      - input: data/pass1_*.h5              # a phase-history file or a glob (.mat: GOTCHA files)
        method: nufft                       # form_image's methods, or 'regularize'
        options: {eps: 1.0e-6}              # keyword options of that function
        grid: {center: [0, 0], extent: [8, 8], pixel_size: 0.0625}
        output: "{stem}_{method}.h5"        # relative to the output folder
      - subapertures: {input: circ.h5, window_deg: 30, overlap_deg: 0, composite: max}
      - tiles: {input: big.h5, tiles: 4, margin_px: 0}

Jobs are picklable frozen records and :func:`run_job` is a module-level function holding no
global state, so any dask worker that can import sarcli and read the plan's paths can run them.
Each output is written atomically and carries a fingerprint (SHA-256 of the job's spec) in its
attributes; a re-run skips every job whose output reads back as a valid image with the same
fingerprint, so an interrupted batch resumes where it stopped.

Public API
----------
load_plan(path) -> Plan
run_plan(plan, outdir, *, client=None, scheduler=None, n_workers=None, force=False) -> BatchReport
run_job(job, outdir, force=False) -> JobResult
subaperture_windows(azimuth_rad, window_deg, overlap_deg) -> list of (start_deg, stop_deg, pulses)
tile_layout(n, tiles) -> list of (start, stop)
"""

from __future__ import annotations

import glob as _glob
import hashlib
import inspect
import itertools
import json
import os
import string
import time
import traceback
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import yaml

from . import errors
from .errors import ConfigError, SarcliError
from .grid import Grid, resolve_grid
from .io import Image, PhaseHistory, read_image, to_json, write_image

__all__ = ["Job", "Plan", "JobResult", "BatchReport", "load_plan", "parse_plan", "run_plan", "run_job",
           "subaperture_windows", "tile_layout", "COMPOSITES", "POINTWISE_METHODS"]

#: Composite of sub-aperture images: per-pixel maximum or incoherent mean of the magnitudes.
COMPOSITES = ("max", "mean")
#: Methods whose pixel values do not depend on the other pixels of the grid: tiles stitch exactly.
POINTWISE_METHODS = ("direct", "nufft", "backprojection")
#: Default tile margin (pixels) for methods that are not pointwise (pfa, regularize).
DEFAULT_MARGIN_PX = 16
#: Attribute of every batch output holding its job fingerprint.
FINGERPRINT_ATTR = "batch_fingerprint"

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
        numba / FINUFFT threads inside the job.
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

    def spec(self) -> dict:
        """Everything that shapes the output (the fingerprint's content)."""
        d = asdict(self)
        d.pop("name")
        d.pop("threads")
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


@dataclass
class JobResult:
    """Outcome of one job: ``status`` is 'done', 'skipped' (valid output existed) or 'failed'.

    ``runtime_s`` is the image formation alone, ``wall_s`` and ``cpu_s`` the whole job (read, form,
    write) in wall-clock and CPU seconds of the worker process: ``cpu_s < wall_s`` on a single-threaded
    job means the worker waited for a core.
    """

    name: str
    input: str
    status: str
    error: str = ""
    runtime_s: float = 0.0
    wall_s: float = 0.0
    cpu_s: float = 0.0
    warnings: list = field(default_factory=list)


@dataclass
class BatchReport:
    """All job results of one run, in plan order, and the wall time of the run."""

    results: list
    wall_s: float = 0.0
    workers: int = 0

    def count(self, status: str) -> int:
        return sum(r.status == status for r in self.results)

    @property
    def failed(self) -> list:
        return [r for r in self.results if r.status == "failed"]

    @property
    def ok(self) -> bool:
        return not self.failed

    def summary(self) -> str:
        return (f"{len(self.results)} jobs: {self.count('done')} done, {self.count('skipped')} skipped "
                f"(valid output present), {self.count('failed')} failed; {self.wall_s:.3g} s on "
                f"{self.workers} worker(s)")

    def to_dict(self) -> dict:
        return {"wall_s": self.wall_s, "workers": self.workers, "results": [asdict(r) for r in self.results]}


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
    """Keyword options each method accepts (the plan's ``options`` are checked against them)."""
    from .formation import METHODS, form_image

    skip = {"ph", "method", "grid", "center", "extent", "pixel_size", "init", "callback"}

    def options(func):
        return {n: p.default for n, p in inspect.signature(func).parameters.items() if n not in skip}

    sigs = {m: options(form_image) for m in METHODS}
    try:
        from .regularize import regularize
    except ImportError:  # pragma: no cover - regularize is optional for batches
        return sigs
    sigs["regularize"] = options(regularize)
    return sigs


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _check_keys(err, where, section, mapping) -> bool:
    if not isinstance(mapping, dict):
        err.add(where, f"expected a mapping, got {type(mapping).__name__} {mapping!r}")
        return False
    for key in mapping:
        if key not in _KEYS[section]:
            err.add(f"{where}.{key}" if where else str(key),
                    f"unknown key; valid keys: {', '.join(sorted(_KEYS[section]))}")
    return True


def _check_number(err, key, value, *, integer=False, lo=None, lo_open=False, hi=None, hi_open=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (integer and not isinstance(value, int)):
        err.add(key, f"expected {'an integer' if integer else 'a number'}, got {value!r}")
        return None
    if (lo is not None and (value <= lo if lo_open else value < lo)) or \
       (hi is not None and (value >= hi if hi_open else value > hi)):
        lo_s = "" if lo is None else f"{'>' if lo_open else '>='} {lo}"
        hi_s = "" if hi is None else f"{'<' if hi_open else '<='} {hi}"
        err.add(key, f"expected a value {' and '.join(s for s in (lo_s, hi_s) if s)}, got {value!r}")
        return None
    return value


def _check_grid(err, key, grid) -> dict:
    if grid is None:
        return {}
    if not isinstance(grid, dict):
        err.add(key, f"expected a mapping with {', '.join(sorted(_GRID_KEYS))}, got {grid!r}")
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
                err.add(f"{key}.{k}", f"expected {'W or [W, H]' if k == 'extent' else '[x, y]'} in metres, got {v!r}")
            elif k == "extent" and min(vals) <= 0:
                err.add(f"{key}.{k}", f"expected positive side lengths, got {v!r}")
            else:
                out[k] = [float(x) for x in vals] if len(vals) == 2 else float(vals[0])
    return out


def _expand_inputs(err, key, pattern, base: Path) -> list[Path]:
    if not isinstance(pattern, str) or not pattern:
        err.add(key, f"expected a file path or glob, got {pattern!r}")
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
        err.add("jobs", f"expected a non-empty list of jobs, got {raw_jobs!r}")
        raw_jobs = []
    jobs: list[Job] = []
    for i, entry in enumerate(raw_jobs):
        key = f"jobs[{i}]"
        if not isinstance(entry, dict):
            err.add(key, f"expected a mapping, got {entry!r}")
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
        where = job.extra.get("plan_key", "")
        if job.name in seen:
            err.add(where, f"output {job.name!r} is also written by {seen[job.name]}; give distinct 'output'/'name'")
        seen.setdefault(job.name, where)
    err.raise_if_any()
    return Plan(source=str(source), jobs=tuple(jobs))


def load_plan(path) -> Plan:
    """Read, validate and expand a plan file (relative inputs are taken from its folder)."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError("no such plan file", source=str(path))
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"not valid YAML ({str(exc).splitlines()[0]})", source=str(path)) from None
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
        err.add(f"{key}.options", f"expected a mapping of options, got {opts!r}")
        opts, ok = {}, False
    options = {**(defaults.get("options") or {}), **opts}
    for k, v in options.items() if ok else ():
        where = f"{key}.options.{k}" if k in opts else f"defaults.options.{k}"
        if k not in sigs[method]:
            err.add(where, f"not an option of method {method!r}; valid: {', '.join(sorted(sigs[method]))}")
            ok = False
        elif _is_number(sigs[method][k]) and not _is_number(v) and v is not None:
            hint = " (YAML reads 1e-6 as text: write 1.0e-6)" if isinstance(v, str) else ""
            err.add(where, f"expected a number, got {v!r}{hint}")
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
        err.add(out_key, f"expected a file name template, got {template!r}")
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
            jobs.append(Job(name=name, input=str(path), grid=grid, extra={"plan_key": key}, **common))
        elif section == "subapertures":
            jobs.extend(_expand_subapertures(err, key, params, name, path, grid, common))
        else:
            jobs.extend(_expand_tiles(err, key, params, name, path, grid, common))
    return jobs


def _input_geometry(path: Path):
    """Azimuths (rad) and default grid of an input, reading as little as possible."""
    if path.suffix.lower() == ".mat":
        from .gotcha import read_gotcha

        acq = read_gotcha(path).acquisition
        return acq.azimuth_rad, acq.grid
    import h5py

    from .io import read_phase_history

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


def _base_grid(err, key, path, grid) -> tuple:
    try:
        az, g0 = _input_geometry(path)
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


def _expand_subapertures(err, key, params, name, path, grid, common) -> list[Job]:
    w, o, mode = params
    az, full = _base_grid(err, key, path, grid)
    if az is None:
        return []
    exact = full.as_dict()
    jobs = []
    for k, (a0, a1, pulses) in enumerate(subaperture_windows(az, w, o)):
        extra = {"plan_key": key, "subaperture": {"index": k, "azimuth_deg": [a0, a1], "n_pulses": len(pulses)}}
        jobs.append(Job(name=f"{name}/window_{k:03d}.h5", input=str(path), grid=exact, pulses=pulses,
                        extra=extra, **common))
    jobs.append(Job(name=f"{name}/composite.h5", kind="composite", input=str(path), method=common["method"],
                    grid=exact, depends=tuple(j.name for j in jobs),
                    dep_fingerprints=tuple(j.fingerprint for j in jobs), threads=common["threads"],
                    extra={"plan_key": key, "composite": mode, "window_deg": w, "overlap_deg": o}))
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
                            extra={"plan_key": key, "tile": tile}, **common))
            layout.append(tile)
    jobs.append(Job(name=f"{name}/stitched.h5", kind="stitch", input=str(path), method=common["method"],
                    grid=full.as_dict(), depends=tuple(j.name for j in jobs),
                    dep_fingerprints=tuple(j.fingerprint for j in jobs), threads=common["threads"],
                    extra={"plan_key": key, "tiles": t, "margin_px": m, "layout": layout}))
    return jobs


# ---------------------------------------------------------------------------------------------
# running one job (module level, picklable, no global state)
# ---------------------------------------------------------------------------------------------
def _valid_output(path: Path, fingerprint: str) -> bool:
    if not path.is_file():
        return False
    try:
        return read_image(path).attrs.get(FINGERPRINT_ATTR) == fingerprint
    except SarcliError:
        return False


def _read_input(job: Job) -> PhaseHistory:
    if job.input.lower().endswith(".mat"):
        from .gotcha import read_gotcha

        ph = read_gotcha(job.input)
    else:
        from .io import read_phase_history

        ph = read_phase_history(job.input)
    if job.pulses is None:
        return ph
    sel = np.asarray(job.pulses, dtype=np.intp)
    return PhaseHistory(ph.data[sel], ph.acquisition.subset(pulses=sel), ph.truth, ph.attrs)


def _form(job: Job) -> Image:
    ph = _read_input(job)
    if {"nx", "ny"} <= set(job.grid):
        grid = Grid(**job.grid)
    else:
        grid = resolve_grid(ph.acquisition.grid, center=job.grid.get("center"), extent=job.grid.get("extent"),
                            pixel_size=job.grid.get("pixel_size"))
    options = dict(job.options)
    if job.method == "regularize":
        from .regularize import regularize

        return regularize(ph, grid=grid, **options)
    from .formation import form_image

    if job.method in ("nufft", "backprojection"):
        options.setdefault("nthreads", job.threads)
    return form_image(ph, job.method, grid=grid, **options)


def _combine(job: Job, outdir: Path) -> Image:
    """Composite or stitch the outputs of ``job.depends``, reading one at a time."""
    full = Grid(**job.grid)
    acc, runtime, first = None, 0.0, None
    for n, name in enumerate(job.depends):
        p = read_image(outdir / name)
        first = first or p
        runtime += p.runtime_s
        if job.kind == "composite":
            if p.image.shape != full.shape or not np.allclose(p.x_m, full.x) or not np.allclose(p.y_m, full.y):
                raise errors.SarcliInputError(f"{name}: its grid differs from the composite's")
            mag = np.abs(p.image)
            if acc is None:
                acc = mag
            elif job.extra["composite"] == "max":
                np.maximum(acc, mag, out=acc)
            else:
                acc += mag
        else:
            t = job.extra["layout"][n]
            (r0, r1), (c0, c1), m = t["rows"], t["cols"], t["margin_px"]
            if acc is None:
                acc = np.zeros(full.shape, dtype=p.image.dtype)
            acc[r0:r1, c0:c1] = p.image[m:m + r1 - r0, m:m + c1 - c0]
    if job.kind == "composite":
        mode = job.extra["composite"]
        image = (acc if mode == "max" else acc / len(job.depends)).astype(np.result_type(first.image.dtype, np.complex64))
        params = {"composite": mode, "quantity": "magnitude", "n_windows": len(job.depends),
                  "window_deg": job.extra["window_deg"], "overlap_deg": job.extra["overlap_deg"],
                  "windows": list(job.depends), "window_parameters": first.parameters}
        method = f"composite-{mode}"
        attrs = {"composite": f"per-pixel {'maximum' if mode == 'max' else 'incoherent mean'} "
                              "of sub-aperture magnitudes (imaginary part 0)"}
    else:
        image = acc
        params = {**{k: v for k, v in first.parameters.items() if k != "tile"}, "grid": full.as_dict(),
                  "tiles": job.extra["tiles"], "margin_px": job.extra["margin_px"],
                  "stitch": "exact" if job.method in POINTWISE_METHODS else "approximate (method not pointwise)"}
        method = first.method
        attrs = {"tiles": int(job.extra["tiles"])}
    return Image(image=image, x_m=full.x, y_m=full.y, method=method, parameters=params, runtime_s=runtime,
                 attrs=attrs)


def run_job(job: Job, outdir, force: bool = False) -> JobResult:
    """Run one job and write its output atomically under ``outdir``; never raises for job errors.

    Parameters
    ----------
    job : Job
    outdir : str or Path
    force : bool
        Redo the job even when a valid output with the same fingerprint exists.

    Returns
    -------
    JobResult
        'skipped' when a valid output existed, 'done', or 'failed' with the reason.
    """
    import numba

    t0, c0 = time.perf_counter(), time.process_time()
    out = Path(outdir) / job.name
    fp = job.fingerprint
    if not force and _valid_output(out, fp):
        return JobResult(job.name, job.input, "skipped", wall_s=time.perf_counter() - t0)
    old_threads = numba.get_num_threads()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            numba.set_num_threads(max(1, min(job.threads, numba.config.NUMBA_NUM_THREADS)))
            img = _form(job) if job.kind == "image" else _combine(job, Path(outdir))
        img.attrs = {**img.attrs, FINGERPRINT_ATTR: fp, "batch_job": to_json({"name": job.name, **job.spec()}),
                     "batch_input": job.input}
        if job.extra.get("subaperture"):
            img.parameters = {**img.parameters, "subaperture": job.extra["subaperture"]}
        if job.extra.get("tile"):
            img.parameters = {**img.parameters, "tile": job.extra["tile"]}
        write_image(out, img)
    except Exception as exc:  # noqa: BLE001 - a job's failure is reported, the batch goes on
        reason = str(exc) if isinstance(exc, SarcliError) else \
            f"{type(exc).__name__}: {exc} ({traceback.extract_tb(exc.__traceback__)[-1].name})"
        return JobResult(job.name, job.input, "failed", error=reason, wall_s=time.perf_counter() - t0)
    finally:
        numba.set_num_threads(old_threads)
    msgs = [(w.category.__name__, str(w.message)) for w in caught]
    return JobResult(job.name, job.input, "done", runtime_s=img.runtime_s, wall_s=time.perf_counter() - t0,
                     cpu_s=time.process_time() - c0, warnings=msgs)


# ---------------------------------------------------------------------------------------------
# running a plan on dask
# ---------------------------------------------------------------------------------------------
def _reemit(result: JobResult):
    for cat, msg in result.warnings:
        cls = getattr(errors, cat, None)
        cls = cls if isinstance(cls, type) and issubclass(cls, Warning) else errors.SarcliWarning
        warnings.warn(f"{result.name}: {msg}", cls, stacklevel=3)


def run_plan(plan, outdir, *, client=None, scheduler: str | None = None, n_workers: int | None = None,
             force: bool = False, report_file: str | None = "batch-report.json") -> BatchReport:
    """Run every job of a plan on a dask ``distributed`` cluster.

    Parameters
    ----------
    plan : Plan or path
        A plan, or a plan file for :func:`load_plan`.
    outdir : path
        Output folder (created); job outputs are paths inside it.
    client : distributed.Client, optional
        Use this client (left open). Otherwise connect to ``scheduler`` or start a LocalCluster.
    scheduler : str, optional
        Address of a running scheduler, e.g. ``tcp://10.0.0.5:8786`` (``dask scheduler``).
    n_workers : int, optional
        Workers of the embedded LocalCluster (default: one per core, one thread each).
    force : bool
        Redo jobs whose valid output exists.
    report_file : str or None
        Name of the JSON report written into ``outdir`` (None: none).

    Returns
    -------
    BatchReport
        Failed jobs carry their input and reason; the other jobs still ran.

    Notes
    -----
    Combining jobs (composite, stitch) are submitted once all the jobs they read have finished;
    if one of those failed, the combining job fails too, naming it.
    """
    from distributed import Client, LocalCluster, as_completed

    from .progress import progress

    if not isinstance(plan, Plan):
        plan = load_plan(plan)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    owned = []
    if client is None:
        if scheduler:
            client = Client(scheduler)
        else:
            import logging

            cluster = LocalCluster(n_workers=n_workers or os.cpu_count() or 1, threads_per_worker=1,
                                   processes=True, host="127.0.0.1", dashboard_address=None,
                                   silence_logs=logging.ERROR)
            owned.append(cluster)
            client = Client(cluster)
        owned.insert(0, client)
    try:
        results = _execute(plan, str(outdir.resolve()), client, force, as_completed, progress)
        n_workers = len(client.scheduler_info().get("workers", {}))
    finally:
        for obj in owned:
            obj.close()
    report = BatchReport([results[j.name] for j in plan.jobs], wall_s=time.perf_counter() - t0, workers=n_workers)
    if report_file:
        from ._atomic import atomic_path

        with atomic_path(outdir / report_file) as tmp:
            Path(tmp).write_text(json.dumps({"plan": plan.source, **report.to_dict()}, indent=1))
    return report


def _execute(plan: Plan, outdir: str, client, force, as_completed, progress) -> dict:
    jobs = {j.name: j for j in plan.jobs}
    waiting = {j.name: set(j.depends) for j in plan.jobs if j.depends}
    results: dict[str, JobResult] = {}
    by_key = {}
    counter = itertools.count()
    queue = as_completed()

    def submit(job):
        fut = client.submit(run_job, job, outdir, force, pure=False,
                            key=f"sarcli-batch-{job.fingerprint[:16]}-{next(counter)}")
        by_key[fut.key] = job
        queue.add(fut)

    for job in plan.jobs:
        if not job.depends:
            submit(job)
    with progress(total=len(jobs), desc="jobs", unit="job") as bar:
        def finish(res):
            results[res.name] = res
            bar.update()
            _reemit(res)
            for name, deps in list(waiting.items()):
                if res.name not in deps:
                    continue
                deps.discard(res.name)
                if deps:
                    continue
                del waiting[name]
                bad = [d for d in jobs[name].depends if results[d].status == "failed"]
                if bad:
                    finish(JobResult(name, jobs[name].input, "failed",
                                     error=f"{len(bad)} of the jobs it combines failed (first: {bad[0]})"))
                else:
                    submit(jobs[name])

        for fut in queue:
            job = by_key.pop(fut.key)
            try:
                res = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker or an unpicklable object
                res = JobResult(job.name, job.input, "failed", error=f"{type(exc).__name__}: {exc}")
            finish(res)
    return results
