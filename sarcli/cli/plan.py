"""``sar plan PH.h5 [grid options] --tolerance TOL``: the formers that meet an accuracy, and auto's pick."""

from __future__ import annotations

import json
import shutil

import click

from ..formers.formation import DEFAULT_TOLERANCE
from .options import grid_options, handle_errors, parse_pair, threads_option


#: Status words of the table (and the JSON's ``status``), with what each means.
STATUS_LEGEND = (
    ("safe", "predicted error at most TOL/{safety:g}: meets the tolerance with the margin auto asks "
             "for (the error models' own uncertainty)"),
    ("meets", "predicted error at most TOL, without that margin (auto does not pick it)"),
    ("misses", "predicted error above TOL"),
    ("unknown", "no error model (pfa)"),
)


def status_of(cand, tolerance: float, safety: float) -> str:
    """``safe``, ``meets``, ``misses`` or, for a former with no error model, ``unknown`` (see
    :data:`STATUS_LEGEND`)."""
    if cand.predicted_error != cand.predicted_error:
        return "unknown"
    if cand.predicted_error <= tolerance / safety:
        return "safe"
    return "meets" if cand.predicted_error <= tolerance else "misses"


def _knobs(k: dict) -> str:
    return ", ".join(f"{n}={v:g}" if isinstance(v, float) else f"{n}={v}" for n, v in k.items() if n != "tolerance")


def table(cands, pick, tolerance: float, safety: float, width: int = 80, seconds=None) -> list[str]:
    """Lines of the plan table: one row per candidate, its knobs and then the ``sar form-image``
    flags that run it wrapped below it (``default``: what ``--method X`` runs with no knob), then
    the legend.

    Fits ``width`` columns (at least 60): the fixed columns take 56, the knobs and the legend wrap.
    ``seconds``: the time column, one per candidate (default each candidate's formation time).
    """
    import textwrap

    from ..formers.planning.planner import same_run

    width = max(60, int(width))
    lines = [f"{'method':<15} {'pred.err':>9} {'pred.s':>9} {'MiB':>8}  {'status':<7}"]
    marked = False
    for c, sec in zip(cands, seconds if seconds is not None else [c.seconds for c in cands]):
        auto = not marked and (c is pick or same_run(c, pick))
        marked = marked or auto
        lines.append(f"{c.method:<15} {c.predicted_error:9.2e} {sec:9.3g} {c.memory / 2**20:8.1f}  "
                     f"{status_of(c, tolerance, safety):<7}{' <- auto' if auto else ''}")
        knobs = _knobs(c.knobs)
        if c.notes:
            knobs = f"{knobs}; {c.notes}" if knobs else c.notes
        flags = " ".join(c.flags()) + ("  (default)" if c.default else "")
        for text in (knobs, flags):
            if text:
                lines += textwrap.wrap(text, width=width, initial_indent="    ", subsequent_indent="      ",
                                       break_on_hyphens=False)
    lines.append("status:")
    for word, text in STATUS_LEGEND:
        lines += textwrap.wrap(f"{word} = {text.format(safety=safety)}", width=width, initial_indent="  ",
                               subsequent_indent="    ")
    return lines


@click.command("plan")
@click.argument("input_path", metavar="PH.h5", type=click.Path(dir_okay=False))
@grid_options
@click.option("--tolerance", type=click.FloatRange(min=1e-12, max=0.5), default=DEFAULT_TOLERANCE, show_default=True,
              help="Target relative error against the exact matched filter.")
@click.option("--json", "as_json", is_flag=True, help="Print the candidates as JSON.")
@click.option("--calibrate", is_flag=True,
              help="Measure this machine's cost model again first (done once on first use; a few seconds).")
@threads_option
@handle_errors
def command(input_path, center, extent, pixel_size, tolerance, as_json, calibrate, nthreads):
    """List image formers with knobs, predicted error, time and memory; mark the one --method auto picks.

    Each former is listed first as `sar form-image --method X` runs it with no knob (marked
    default), then with the knobs its error model predicts to meet --tolerance; below each row,
    the `sar form-image` flags that run it. Errors come from each former's error model. Times are of the whole `sar form-image` command
    with that former (start-up, reading, forming, writing), from per-operation constants measured
    on this machine: the first `sar plan` on a machine measures them (a few seconds) and keeps
    them in the user's cache folder; --calibrate measures them again.
    """
    from ..core.grid import resolve_grid
    from ..formers.planning import calibration
    from ..formers.formation import plan_rows
    from ..formers.planning.planner import SAFETY, calibrate as measure, command_seconds, recommend
    from ..io import open_input
    from .._util.load import present_load

    if calibrate or not calibration.is_calibrated():
        click.echo(f"measuring this machine's cost model (a few seconds, once; kept in "
                   f"{calibration.user_cost_model_path()})", err=True)
        measure()

    # the samples stay on disk, as `sar form-image` leaves them (planning needs only the geometry)
    _, ph = open_input(input_path, expect=("phase-history", "gotcha", "cphd"), truth=False, lazy=True)
    grid = resolve_grid(ph.acquisition.grid, center=parse_pair(center, "--center"),
                        extent=parse_pair(extent, "--extent"), pixel_size=pixel_size)
    cands = plan_rows(ph, grid, tolerance, nthreads=nthreads)
    pick = recommend(ph, grid, tolerance, nthreads=nthreads)
    whole = [command_seconds(c, ph, grid, tolerance=tolerance) for c in cands]
    load = present_load()
    now = [command_seconds(c, ph, grid, tolerance=tolerance, load=load, nthreads=nthreads) for c in cands]
    idle = command_seconds(pick, ph, grid, auto=True, tolerance=tolerance)
    busy = command_seconds(pick, ph, grid, auto=True, tolerance=tolerance, load=load, nthreads=nthreads)
    if as_json:
        click.echo(json.dumps({"tolerance": tolerance, "grid": grid.as_dict(),
                               "load": {"other_runnable_threads": load.others, "cpus": load.cpus},
                               "auto": {**pick.as_dict(), "predicted_command_s": idle, "predicted_command_now_s": busy},
                               "status_legend": {w: t.format(safety=SAFETY) for w, t in STATUS_LEGEND},
                               "candidates": [{**c.as_dict(), "predicted_command_s": None if w != w else w,
                                               "predicted_command_now_s": None if n != n else n,
                                               "status": status_of(c, tolerance, SAFETY)}
                                              for c, w, n in zip(cands, whole, now)]}, indent=1, default=float))
        return
    click.echo(f"{ph.model} data, {ph.data.shape[0]} x {ph.data.shape[1]} samples -> {grid.nx} x {grid.ny} "
               f"pixels of {grid.dx:g} m; tolerance {tolerance:g}")
    for line in table(cands, pick, tolerance, SAFETY, shutil.get_terminal_size((80, 24)).columns, whole):
        click.echo(line)
    click.echo("pred.s: the whole `sar form-image` command with that former (start-up, read, form, write) "
               "on this machine, idle")
    if busy > 1.05 * idle:
        click.echo(f"this machine is busy now ({load.others:.1f} other runnable threads on {load.cpus} "
                   f"processors): auto's command would take about {busy:.3g} s rather than {idle:.3g} s")
