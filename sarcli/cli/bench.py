"""``sar bench CONFIG|PH.h5|GOTCHA.mat... -o DIR``: error against run time for every method and knob."""

from __future__ import annotations

import click

from .options import (echo_info, grid_options, handle_errors, output_folder, parse_pair, prepare_outputs,
                      threads_option, wrote)


@click.command("bench")
@click.argument("inputs", nargs=-1, required=True, metavar="CONFIG.yaml|PH.h5|GOTCHA.mat...",
                type=click.Path(dir_okay=False))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Folder for error_vs_time.csv and error_vs_time.png (created if its parent exists).")
@click.option("--methods", default=None,
              help="Comma-separated methods to sweep [default: direct,nufft,pfa,backprojection, and ffbp,subimage "
                   "for spherical data].")
@click.option("--repeat", type=click.IntRange(1, 100), default=3, show_default=True, help="Timed runs per setting (after a warm-up).")
@click.option("--windows", default="none,taylor", show_default=True,
              help="Windows to measure ('none' carries the knob sweep).")
@click.option("--regularizers", default="", help="Priors to sweep over iterations, e.g. 'ptv,tv' (needs a truth).")
@click.option("--reg-iters", default="1,2,5,10,20,50", show_default=True, help="Iteration caps for --regularizers.")
@click.option("--max-reference-cost", type=click.FloatRange(min=1), default=1e9, show_default=True,
              help="Largest P*M*pixels for the exact reference; beyond it every s-th pixel is used.")
@click.option("--model", type=click.Choice(["farfield", "spherical"]), default=None,
              help="Data model when simulating a YAML config (default: the config's).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Seed when simulating a YAML config.")
@click.option("--no-memory", is_flag=True, help="Skip the peak-memory call.")
@threads_option
@grid_options
@click.pass_context
@handle_errors
def command(ctx, inputs, out_dir, **options):
    """Form the image with every method and knob setting; write error against run time (CSV, PNG)."""
    from pathlib import Path

    from ..batch import benchmark as bm
    from ..viz import plot_benchmark

    o = options
    iters = _reg_iters(o["reg_iters"])  # before anything is read or made
    output_folder(out_dir)
    prepare_outputs([("input", i) for i in inputs], [("output", Path(out_dir) / "error_vs_time.csv"),
                                                    ("output", Path(out_dir) / "error_vs_time.png")])
    ph = bm.load_input(inputs, seed=o["seed"], model=o["model"])
    res = bm.run_benchmark(ph, center=parse_pair(o["center"], "--center"), extent=parse_pair(o["extent"], "--extent"),
                           pixel_size=o["pixel_size"], options=_bench_options(o, ph.model, iters))
    out = Path(out_dir)
    csv_path = bm.write_csv(res, out / "error_vs_time.csv")
    png_path = plot_benchmark(res, out / "error_vs_time.png", title=f"{ph.acquisition.name or Path(inputs[0]).name}: "
                       f"P={ph.data.shape[0]}, M={ph.data.shape[1]}, {res.grid.ny}x{res.grid.nx} px")
    echo_info(ctx, bm.format_table(res))
    wrote(csv_path, f"{len(res.rows)} rows")
    wrote(png_path, "error against run time")


def _split(text):
    return tuple(t.strip() for t in text.split(",") if t.strip())


def _reg_iters(text: str) -> tuple:
    from ..errors import SarcliInputError

    try:
        return tuple(int(t) for t in _split(text))
    except ValueError:
        raise SarcliInputError(f"--reg-iters expects comma-separated integers, got {text!r}") from None


def _bench_options(o: dict, model: str, iters: tuple):
    """The :class:`~sarcli.batch.benchmark.BenchOptions` of the command's options ``o`` (data of
    ``model``: the default methods add the spherical ones for spherical data)."""
    from ..batch import benchmark as bm

    methods = o["methods"]
    if methods is None:
        methods = ",".join(("direct",) + bm.FAST_METHODS + (bm.SPHERICAL_METHODS if model == "spherical" else ()))
    return bm.BenchOptions(methods=_split(methods), repeat=o["repeat"], windows=_split(o["windows"]) or ("none",),
                           max_reference_cost=o["max_reference_cost"], regularizers=_split(o["regularizers"]),
                           reg_iters=iters, memory=not o["no_memory"], nthreads=o["nthreads"])
