"""``sar plan PH.h5 [grid options] --tolerance TOL``: the formers that meet an accuracy, and auto's pick."""

from __future__ import annotations

import json

import click

from ..formers.formation import DEFAULT_TOLERANCE
from .options import grid_options, handle_errors, parse_pair, threads_option


def _knobs(k: dict) -> str:
    return ",".join(f"{n}={v:g}" if isinstance(v, float) else f"{n}={v}" for n, v in k.items() if n != "tolerance")


@click.command("plan")
@click.argument("input_path", metavar="PH.h5", type=click.Path(dir_okay=False))
@grid_options
@click.option("--tolerance", type=click.FloatRange(min=1e-12, max=0.5), default=DEFAULT_TOLERANCE, show_default=True,
              help="Target relative error against the exact matched filter.")
@click.option("--json", "as_json", is_flag=True, help="Print the candidates as JSON.")
@threads_option
@handle_errors
def command(input_path, center, extent, pixel_size, tolerance, as_json, nthreads):
    """List image formers with knobs, predicted error, time and memory; mark the one --method auto picks.

    Errors come from each former's error model, times from per-operation constants measured on
    this machine (sarcli/formers/cost_model.json, refreshed by bench/bench_ffbp.py --calibrate).
    """
    from ..core.grid import resolve_grid
    from ..formers.planner import candidates, recommend
    from ..io import open_input

    _, ph = open_input(input_path, expect=("phase-history", "gotcha", "cphd"), truth=False)
    grid = resolve_grid(ph.acquisition.grid, center=parse_pair(center, "--center"),
                        extent=parse_pair(extent, "--extent"), pixel_size=pixel_size)
    cands = candidates(ph, grid, tolerance, nthreads=nthreads)
    pick = recommend(ph, grid, tolerance, nthreads=nthreads)
    if as_json:
        click.echo(json.dumps({"tolerance": tolerance, "grid": grid.as_dict(), "auto": pick.as_dict(),
                               "candidates": [c.as_dict() for c in cands]}, indent=1, default=float))
        return
    click.echo(f"{ph.model} data, {ph.data.shape[0]} x {ph.data.shape[1]} samples -> {grid.nx} x {grid.ny} "
               f"pixels of {grid.dx:g} m; tolerance {tolerance:g}")
    click.echo(f"{'method':<15} {'knobs':<58} {'pred.err':>9} {'pred.s':>8} {'MiB':>7}  ")
    for c in cands:
        mark = "<- auto" if c is pick or (c.method == pick.method and c.knobs == pick.knobs) else \
            ("" if c.meets else "(misses)")
        click.echo(f"{c.method:<15} {_knobs(c.knobs)[:58]:<58} {c.predicted_error:9.2e} {c.seconds:8.3g} "
                   f"{c.memory / 2**20:7.1f}  {mark}")
