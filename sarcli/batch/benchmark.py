"""Error against run time: every image former and its accuracy knobs, measured (``sar bench``).

For one phase history, :func:`run_benchmark` forms the image with each method over a sweep of its
accuracy knobs and records, per setting,

- ``error``: the relative error ``‖f − f_ref‖₂ / ‖f_ref‖₂`` (docs/conventions.md,
  :func:`sarcli.formers.formation.image_error`) of the complex image against the exact matched
  filter ``f_ref = form_image(ph, 'direct')`` with the same window. ``direct`` costs
  ``P·M·pixels`` exponentials; when that exceeds ``max_reference_cost`` the reference is formed
  on a strided sub-grid (every ``s``-th pixel, over the whole image) and every image is compared
  on those pixels only (``reference_grid`` in the result says which);
- ``error_truth``: for simulated data, ``‖|f| − |t|‖₂ / ‖t‖₂`` with ``t`` the truth on the image
  grid: for extended scenes ``|ph.truth.scene|`` over every pixel; for point-only scenes the target
  amplitudes at their nearest pixels (the peak-amplitude error; see :func:`truth_on_grid`). For
  extended scenes a matched filter is the truth blurred by the PSF (Theorem ``main-theorem``) and
  speckled, so this number is dominated by the PSF and nearly equal for the fast formers; it is the
  meaningful axis for the regularisers, which try to undo the PSF;
- ``seconds``: the median of ``repeat`` calls after one warm-up call; ``compile_s`` = warm-up time
  minus that median (FFT/FINUFFT planning, first touches of memory, caches), floored at 0;
- ``peak_mb``: peak of Python-visible allocations (``tracemalloc``, which sees NumPy arrays) during
  one extra call. Memory that FINUFFT and sarcli's C++ kernels allocate themselves is *not* seen,
  so for ``nufft`` and ``backprojection`` it is a lower bound.

For the regularisers (:mod:`sarcli.regularize`, when present) the sweep is over the iteration cap:
the image after ``n`` iterations is formed by a run capped at ``n`` (the solvers are deterministic,
so it is the ``n``-th iterate), and its error to the truth and its run time give one point each.

Outputs: :func:`write_csv` (``error_vs_time.csv``), :func:`plot` (``error_vs_time.png``: log-log,
one marker per method, the Pareto front of error against time drawn) and :func:`format_table`.
"""

from __future__ import annotations

import csv
import json
import statistics
import time
import tracemalloc
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._util.atomic import atomic_path, open_held
from .._util.options import with_options
from ..analysis.accuracy import MAX_REFERENCE_COST, pareto_front, reference_grid, truth_error, truth_on_grid
from ..errors import SarcliInputError
from ..formers.formation import form_image, image_error
from ..core.grid import Grid, resolve_grid
from ..core.types import PhaseHistory
from .._util.progress import progress

__all__ = ["BenchRow", "BenchResult", "BenchOptions", "sweep", "run_benchmark", "regularizer_sweep", "measure",
           "write_csv", "format_table",
           "load_input", "NUFFT_EPS", "PFA_OVERSAMPLE", "PFA_WIDTH", "BP_UPSAMPLE", "BP_INTERP",
           "BP_PRECISION", "CSV_COLUMNS"]

NUFFT_EPS = tuple(10.0 ** -k for k in range(2, 13))
PFA_OVERSAMPLE = (1.25, 1.5, 2.0, 3.0)
PFA_WIDTH = (2, 4, 6, 8)
BP_UPSAMPLE = (1, 2, 4, 8, 16)
BP_INTERP = ("linear", "cubic", "lagrange", "lanczos")
BP_PRECISION = ("float32", "float64")
FAST_METHODS = ("nufft", "pfa", "backprojection")
#: Formers for spherical data, swept when asked for (``sar bench --methods ...,ffbp,subimage``).
SPHERICAL_METHODS = ("ffbp", "subimage")
#: ffbp: polar-grid oversampling (range = angle) × base sub-aperture, optimal kernels; plus cubic.
FFBP_OS = (1.5, 2.0, 3.0, 4.0)
FFBP_BASE = (8, 16, 32)   # 16: the default
#: subimage: the tolerance its tile (and NUFFT eps) is chosen for.
SUBIMAGE_TOL = (1e-1, 1e-2, 1e-3)
#: Largest P·M·pixels the exact reference is computed for (about 10 s on one core); beyond it a sub-grid.
CSV_COLUMNS = ("method", "knobs", "error", "error_truth", "seconds", "compile_s", "peak_mb", "warnings")


@dataclass
class BenchRow:
    """One measured setting: method, its knobs and the four numbers of the module docstring."""

    method: str
    knobs: dict
    error: float
    error_truth: float
    seconds: float
    compile_s: float
    peak_mb: float
    warnings: list = field(default_factory=list)

    def as_dict(self) -> dict:
        return {"method": self.method, "knobs": json.dumps(self.knobs, sort_keys=True),
                "error": self.error, "error_truth": self.error_truth, "seconds": self.seconds,
                "compile_s": self.compile_s, "peak_mb": self.peak_mb, "warnings": ";".join(self.warnings)}


@dataclass
class BenchResult:
    """Rows plus how the reference was obtained (``notes`` is printed and written to the CSV header)."""

    rows: list
    grid: Grid
    reference_grid: Grid
    reference_cost: float
    notes: list = field(default_factory=list)


def load_input(paths, *, seed: int = 0, snr_db="config", model=None) -> PhaseHistory:
    """A phase history from a YAML config (simulated with ``seed``, and ``model`` if given: the
    far-field model isolates the numerical knobs from the far-field approximation's own error),
    a phase-history file (sarcli HDF5 or CPHD), or GOTCHA ``.mat`` files (joined by
    :func:`sarcli.io.gotcha.read_gotcha`); each file is recognised by its content
    (:func:`sarcli.io.detect_format`)."""
    from ..io import detect_format, open_input

    paths = [Path(p) for p in ([paths] if isinstance(paths, (str, Path)) else paths)]
    if not paths:
        raise SarcliInputError("no input given")
    if len(paths) > 1:
        for p in paths:
            fmt = detect_format(p)
            if fmt != "gotcha":
                raise SarcliInputError(f"{p}: is a {fmt} file; several inputs are only accepted for "
                                       "GOTCHA .mat files")
        from ..io.gotcha import read_gotcha

        return read_gotcha([str(p) for p in paths])
    fmt, src = open_input(paths[0], expect=("config", "phase-history", "gotcha", "cphd"))
    if fmt == "config":
        from ..simulation.simulator import simulate

        return simulate(src, seed=seed, snr_db=snr_db, model=model)
    return src


def sweep(methods=FAST_METHODS, *, windows=("none", "taylor")) -> list:
    """The (method, knobs) settings of the issue: each knob of each method, and a window on/off.

    The knob grids are :data:`NUFFT_EPS`, PFA kernel × :data:`PFA_OVERSAMPLE` × :data:`PFA_WIDTH`
    (the linear kernel has a fixed width of 2 cells), backprojection :data:`BP_UPSAMPLE` ×
    :data:`BP_INTERP` × :data:`BP_PRECISION`, ffbp :data:`FFBP_OS` × :data:`FFBP_BASE` (and cubic
    kernels), subimage :data:`SUBIMAGE_TOL`, all without a window; every window other than
    'none' is added once per method at the method's default knobs.
    """
    out = []
    for m in methods:
        if m == "nufft":
            out += [("nufft", {"eps": e}) for e in NUFFT_EPS]
        elif m == "pfa":
            out += [("pfa", {"kernel": "kaiser", "oversample": s, "width": w})
                    for s in PFA_OVERSAMPLE for w in PFA_WIDTH]
            out += [("pfa", {"kernel": "linear", "oversample": s, "width": 2}) for s in PFA_OVERSAMPLE]
        elif m == "backprojection":
            out += [("backprojection", {"upsample": u, "interp": i, "precision": p})
                    for u in BP_UPSAMPLE for i in BP_INTERP for p in BP_PRECISION]
        elif m == "ffbp":
            out += [("ffbp", {"os_range": s, "os_angle": s, "base": b}) for s in FFBP_OS for b in FFBP_BASE]
            out += [("ffbp", {"os_range": s, "os_angle": s, "interp": "cubic"}) for s in (2.0, 4.0)]
        elif m == "subimage":
            out += [("subimage", {"tolerance": t}) for t in SUBIMAGE_TOL]
        elif m != "direct":
            raise SarcliInputError(f"unknown method {m!r}; choose from direct, {', '.join(FAST_METHODS + SPHERICAL_METHODS)}")
        out += [(m, {"window": w}) for w in windows if w != "none" and m != "direct"]
    return out


def measure(fn, repeat: int = 3, *, memory: bool = True):
    """Call ``fn`` once (warm-up), ``repeat`` times (timed), once more under tracemalloc.

    Returns ``(result, median_s, compile_s, peak_mb, warning_names)``; the warnings of the warm-up
    call are collected (class names, once each) and not re-emitted.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        out = fn()
        first = time.perf_counter() - t0
    times = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(max(0, int(repeat))):
            t0 = time.perf_counter()
            out = fn()
            times.append(time.perf_counter() - t0)
        peak = float("nan")
        if memory:
            tracemalloc.start()
            try:
                fn()
                peak = tracemalloc.get_traced_memory()[1] / 2 ** 20
            finally:
                tracemalloc.stop()
    med = statistics.median(times) if times else first
    names = sorted({w.category.__name__ for w in caught})
    return out, med, max(0.0, first - med), peak, names


@dataclass(frozen=True)
class BenchOptions:
    """What :func:`run_benchmark` sweeps and how it measures (each field also a keyword argument
    of it).

    Attributes
    ----------
    methods : sequence of str
        Among 'direct', 'nufft', 'pfa', 'backprojection' ('direct' adds the reference's own row).
    repeat : int
        Timed calls per setting (after one warm-up).
    max_reference_cost : float
        Largest ``P·M·pixels`` for the exact reference on the full grid (else a strided sub-grid over the whole image).
    windows : sequence of str
        Windows to measure ('none' is the knob sweep; others at default knobs).
    settings : list of (method, knobs), optional
        Replace :func:`sweep` (used by tests and reduced runs).
    regularizers : sequence of str
        Priors of :func:`sarcli.regularize.regularize` to sweep over ``reg_iters`` (needs a truth).
    reg_iters : sequence of int
        Iteration caps of the regularisers' sweep.
    memory : bool
        Measure peak memory (one extra call per setting).
    nthreads : int, optional
        Threads of the formers (default: all).
    """

    methods: tuple = ("direct",) + FAST_METHODS
    repeat: int = 3
    max_reference_cost: float = MAX_REFERENCE_COST
    windows: tuple = ("none", "taylor")
    settings: object = None
    regularizers: tuple = ()
    reg_iters: tuple = (1, 2, 5, 10, 20, 50)
    memory: bool = True
    nthreads: object = None


def run_benchmark(ph: PhaseHistory, *, grid: Grid | None = None, center=None, extent=None, pixel_size=None,
                  options: BenchOptions | None = None, **knobs) -> BenchResult:
    """Measure error, time and memory of every method over its knob sweep (module docstring).

    Parameters
    ----------
    ph : PhaseHistory
    grid, center, extent, pixel_size :
        Image grid (default the acquisition's), as in :func:`sarcli.form_image`.
    options : BenchOptions, optional
        What is swept and measured (default ``BenchOptions()``).
    **knobs
        Fields of :class:`BenchOptions` as keyword arguments (``run_benchmark(ph, repeat=1)``);
        they replace those of ``options``.

    Returns
    -------
    BenchResult
    """
    o = with_options(BenchOptions, options, knobs)
    if int(o.repeat) < 1:
        raise SarcliInputError(f"repeat must be >= 1, got {o.repeat}")
    grid = resolve_grid(grid or ph.acquisition.grid, center=center, extent=extent, pixel_size=pixel_size)
    sub, rs, cs, cost = reference_grid(ph, grid, o.max_reference_cost)
    truth = truth_on_grid(ph, grid)
    notes = _notes(grid, sub, cost, o.max_reference_cost, truth)
    settings = list(o.settings) if o.settings is not None else sweep([m for m in o.methods if m != "direct"],
                                                                     windows=o.windows)
    refs = {}
    rows = []

    def ref_for(window):
        if window not in refs:
            out, sec, comp, peak, wn = measure(
                lambda: form_image(ph, "direct", grid=sub, window=window), 1 if sub.nx * sub.ny < 4096 else 0,
                memory=False)
            refs[window] = out.image
            if "direct" in o.methods:
                rows.append(BenchRow("direct", {"window": window, "pixels": sub.nx * sub.ny}, 0.0,
                                     truth_error(out.image, truth) if sub == grid else float("nan"),
                                     sec, comp, float("nan"), wn))
        return refs[window]

    for method, setting in progress(settings, desc="bench", unit="setting"):
        window = setting.get("window", "none")
        ref = ref_for(window)
        kw = dict(setting)
        kw.setdefault("window", window)
        try:
            out, sec, comp, peak, wn = measure(lambda: form_image(ph, method, grid=grid, nthreads=o.nthreads, **kw),
                                               o.repeat, memory=o.memory)
        except SarcliInputError as exc:  # a method that refuses these data (e.g. one frequency): say so
            nan = float("nan")
            rows.append(BenchRow(method, setting, nan, nan, nan, nan, nan, [f"refused: {exc}"]))
            continue
        img = out.image
        rows.append(BenchRow(method, setting, image_error(img[np.ix_(rs, cs)], ref), truth_error(img, truth),
                             sec, comp, peak, wn))
    for prior in o.regularizers:
        rows += regularizer_sweep(ph, prior, grid=grid, iters=o.reg_iters, truth=truth)
    return BenchResult(rows, grid, sub, cost, notes)


def _notes(grid: Grid, sub: Grid, cost: float, max_reference_cost: float, truth) -> list:
    """What the table's reference, truth error and memory figures are."""
    notes = [f"reference: exact matched filter ('direct') on {sub.ny} x {sub.nx} pixels"
             + ("" if sub == grid else
                f" (every {int(round(sub.dx / grid.dx))}th pixel of the {grid.ny} x {grid.nx} image: "
                f"P*M*pixels = {cost:.3g} > {max_reference_cost:.3g}; errors are measured on that sub-grid)")]
    if truth is None:
        notes.append("error_truth: not available (no truth on this grid)")
    elif truth[1] is None:
        notes.append("error_truth: || |f| - |truth| || / ||truth|| over the grid (truth: the simulated scene)")
    else:
        notes.append(f"error_truth: || |f| - |a| || / ||a|| at the {int(truth[1].sum())} point targets' pixels "
                     "(peak amplitudes)")
    notes.append("peak_mb: tracemalloc (Python/NumPy allocations; FINUFFT and C++ kernel memory not seen)")
    return notes


def regularizer_sweep(ph: PhaseHistory, prior: str, *, grid: Grid, iters=(1, 2, 5, 10, 20, 50), truth=None,
                      **kwargs) -> list:
    """Error to the truth against iteration and time for one prior of :func:`sarcli.regularize.regularize`.

    One run per cap ``n`` in ``iters`` (``tol`` tiny, so each runs exactly ``n`` iterations);
    ``seconds`` is that run's ``runtime_s`` (set-up included), ``error`` is NaN (a regularised image
    is not the matched filter). The knobs record ``iters`` and the run's last ``objective``.
    Every run uses one λ, so only the iteration count varies: ``lam`` if given, else the λ that
    ``lam='auto'`` chooses once for this data (recorded in the knobs).
    """
    from ..regularize import regularize

    if "lam" not in kwargs:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            chosen = regularize(ph, prior=prior, iters=int(max(iters)), grid=grid, lam="auto", **kwargs)
        kwargs = {**kwargs, "lam": float(chosen.parameters["lam"])}
    truth = truth_on_grid(ph, grid) if truth is None else truth
    rows = []
    for n in progress(list(iters), desc=f"regularize {prior}", unit="cap"):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            img = regularize(ph, prior=prior, iters=int(n), tol=1e-300, grid=grid, **kwargs)
        hist = img.history or {}
        obj = hist.get("objective")
        knobs = {"iters": int(n), **{k: v for k, v in kwargs.items() if np.isscalar(v)}}
        if obj is not None and len(obj):
            knobs["objective"] = float(obj[-1])
        rows.append(BenchRow(f"regularize-{prior}", knobs, float("nan"), truth_error(img.image, truth),
                             float(img.runtime_s), 0.0, float("nan"),
                             sorted({w.category.__name__ for w in caught})))
    return rows


def write_csv(result: BenchResult, path) -> Path:
    """``error_vs_time.csv``: the notes as ``#`` lines, then one row per setting (:data:`CSV_COLUMNS`)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        with open_held(tmp, "w", opener=lambda p, m: open(p, m, newline="")) as fh:
            for note in result.notes:
                fh.write(f"# {note}\n")
            w = csv.DictWriter(fh, fieldnames=CSV_COLUMNS)
            w.writeheader()
            for row in result.rows:
                w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.as_dict().items()})
    return path


def format_table(result: BenchResult, *, front_only: bool = False) -> str:
    """A short text table: per method the Pareto-optimal settings (or all with ``front_only=False``)."""
    rows = result.rows
    front = set(pareto_front([r.error for r in rows], [r.seconds for r in rows]).tolist())
    lines = [f"{'method':<16} {'knobs':<52} {'error':>9} {'err_truth':>9} {'seconds':>9} {'compile':>8} "
             f"{'peak MB':>8}  front"]
    for i, r in enumerate(rows):
        if front_only and i not in front:
            continue
        knobs = ",".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.knobs.items())
        lines.append(f"{r.method:<16} {knobs[:52]:<52} {r.error:9.2e} {r.error_truth:9.2e} {r.seconds:9.3g} "
                     f"{r.compile_s:8.3g} {r.peak_mb:8.3g}  {'*' if i in front else ''}")
    return "\n".join(result.notes + lines)
