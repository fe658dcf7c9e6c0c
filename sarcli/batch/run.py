"""``sar batch``: run many imaging jobs on dask, resumably.

A plan (YAML, see ``docs/batch.md`` and :mod:`sarcli.batch.plan`) lists jobs: phase-history
inputs (files or globs) with a method, its options and a grid, or the generators ``subapertures``
(azimuth windows of W degrees with overlap O, one image each, plus their composite) and ``tiles``
(T x T tiles of a large grid, stitched). :func:`run_plan` runs the expanded jobs on a dask
``distributed`` cluster (an embedded :class:`~distributed.LocalCluster` by default, or an existing
scheduler) and returns a :class:`BatchReport`::

    threads_per_job: 1
    defaults: {method: backprojection, grid: {pixel_size: 0.05}}
    jobs:
      - input: data/pass1_*.h5
        method: nufft
        options: {eps: 1.0e-6}
      - subapertures: {input: circ.h5, window_deg: 30, overlap_deg: 0, composite: max}
      - tiles: {input: big.h5, tiles: 4, margin_px: 0}

Jobs are picklable frozen records and :func:`run_job` is a module-level function holding no
global state, so any dask worker that can import sarcli and read the plan's paths can run them.
Each output is written atomically and carries a fingerprint (SHA-256 of the job's spec) in its
attributes; a re-run skips every job whose output reads back as a valid image with the same
fingerprint, so an interrupted batch resumes where it stopped.

Public API
----------
load_plan(path) -> Plan                     (from :mod:`sarcli.batch.plan`)
run_plan(plan, outdir, *, client=None, scheduler=None, n_workers=None, force=False) -> BatchReport
run_job(job, outdir, force=False) -> JobResult
"""

from __future__ import annotations

import itertools
import json
import os
import time
import traceback
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .. import errors
from .layout import INPUT_FORMATS, subaperture_windows, tile_layout
from .plan import COMPOSITES, POINTWISE_METHODS, Job, Plan, load_plan, parse_plan
from ..errors import SarcliError
from ..core.grid import Grid, resolve_grid
from ..core.types import Image, PhaseHistory, to_json
from ..io.hdf5 import read_image, write_image

__all__ = ["Job", "Plan", "JobResult", "BatchReport", "load_plan", "parse_plan", "run_plan", "run_job",
           "subaperture_windows", "tile_layout", "COMPOSITES", "POINTWISE_METHODS", "FINGERPRINT_ATTR"]

#: Attribute of every batch output holding its job fingerprint.
FINGERPRINT_ATTR = "batch_fingerprint"
#: Seconds to wait for an existing scheduler (``--scheduler``) before giving up.
SCHEDULER_TIMEOUT_S = 15.0


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
    from ..io import open_input

    # a sarcli phase history or a CPHD file is left on disk: a worker reads its pulses (by blocks,
    # for backprojection, ffbp and direct), so a file larger than the worker's memory can be imaged
    ph = open_input(job.input, expect=INPUT_FORMATS, truth=False, lazy=True)[1]
    if job.pulses is None:
        return ph
    sel = np.asarray(job.pulses, dtype=np.intp)
    data = ph.data[np.sort(sel)] if np.all(np.diff(sel) > 0) else np.asarray(ph.data)[sel]
    return PhaseHistory(data, ph.acquisition.subset(pulses=sel), ph.truth, ph.attrs)


def _form(job: Job) -> Image:
    ph = _read_input(job)
    if {"nx", "ny"} <= set(job.grid):
        grid = Grid(**job.grid)
    else:
        grid = resolve_grid(ph.acquisition.grid, center=job.grid.get("center"), extent=job.grid.get("extent"),
                            pixel_size=job.grid.get("pixel_size"))
    options = dict(job.options)
    if job.method == "regularize":
        from ..regularize import regularize

        return regularize(ph, grid=grid, **options)
    from ..formers.formation import form_image

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
        comp = acc if mode == "max" else acc / len(job.depends)
        image = comp.astype(np.result_type(first.image.dtype, np.complex64))
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
    from .._native import threads

    t0, c0 = time.perf_counter(), time.process_time()
    out = Path(outdir) / job.name
    fp = job.fingerprint
    if not force and _valid_output(out, fp):
        return JobResult(job.name, job.input, "skipped", wall_s=time.perf_counter() - t0)
    # the kernels' thread count is kept per calling thread: this job's setting leaves the jobs
    # running beside it in other threads of the worker alone
    old_threads = threads()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            threads(max(1, job.threads))
            img = _form(job) if job.kind == "image" else _combine(job, Path(outdir))
        img.attrs = {**img.attrs, FINGERPRINT_ATTR: fp, "batch_job": to_json({"name": job.name, **job.spec()}),
                     "batch_input": job.input}
        if job.extra.get("subaperture"):
            img.parameters = {**img.parameters, "subaperture": job.extra["subaperture"]}
        if job.extra.get("tile"):
            img.parameters = {**img.parameters, "tile": job.extra["tile"]}
        out.parent.mkdir(parents=True, exist_ok=True)  # the batch owns its output folder (run_plan)
        write_image(out, img)
    except Exception as exc:  # noqa: BLE001 - a job's failure is reported, the batch goes on
        reason = str(exc) if isinstance(exc, SarcliError) else \
            f"{type(exc).__name__}: {exc} ({traceback.extract_tb(exc.__traceback__)[-1].name})"
        return JobResult(job.name, job.input, "failed", error=reason, wall_s=time.perf_counter() - t0)
    finally:
        threads(old_threads)
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

    Raises
    ------
    ConfigError
        An invalid plan (nothing runs).
    SarcliInputError
        The scheduler cannot be reached.

    Notes
    -----
    Combining jobs (composite, stitch) are submitted once all the jobs they read have finished;
    if one of those failed, the combining job fails too, naming it.
    """
    from distributed import Client, LocalCluster, as_completed

    from .._util.progress import progress

    if not isinstance(plan, Plan):
        plan = load_plan(plan)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    owned = []
    if client is None:
        if scheduler:
            try:
                client = Client(scheduler, timeout=SCHEDULER_TIMEOUT_S)
            except (OSError, TimeoutError, ValueError) as exc:
                raise errors.SarcliInputError(f"cannot reach the dask scheduler at {scheduler} within "
                                              f"{SCHEDULER_TIMEOUT_S:g} s ({exc})") from None
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
        from .._util.atomic import atomic_path, open_held

        with atomic_path(outdir / report_file) as tmp, open_held(tmp, "w") as fh:
            fh.write(json.dumps({"plan": plan.source, **report.to_dict()}, indent=1))
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
