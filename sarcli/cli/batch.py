"""``sar batch PLAN.yaml -o OUTDIR [--scheduler ADDRESS] [--workers N]``."""

from __future__ import annotations

import sys

import click

from .options import echo_info, handle_errors, output_folder


@click.command("batch")
@click.argument("plan_path", metavar="PLAN.yaml", type=click.Path(dir_okay=False))
@click.option("-o", "--output", "outdir", required=True, type=click.Path(file_okay=False),
              help="Output folder, created if its parent exists; each job writes its image inside it.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run on an existing dask cluster, e.g. tcp://host:8786 (default: a local cluster).")
@click.option("--workers", "n_workers", type=click.IntRange(min=1), default=None,
              help="Workers of the local cluster (default: one per core).")
@click.option("--force", is_flag=True, help="Redo jobs whose valid output already exists.")
@click.pass_context
@handle_errors
def command(ctx, plan_path, outdir, scheduler, n_workers, force):
    """Run a plan of many imaging jobs on dask; re-running resumes where a batch stopped.

    Exit code 0 when every job succeeded, 1 when some failed (each is listed with its input and
    reason), 2 for a bad plan.
    """
    import importlib
    import logging

    importlib.import_module("distributed")  # configures its loggers on import; quieten them after

    from ..batch.run import load_plan, run_plan

    if not (ctx.obj or {}).get("verbose"):  # dask's INFO lines about its own start-up and shutdown
        logging.getLogger("distributed").setLevel(logging.ERROR)
    if scheduler and n_workers:
        raise click.BadParameter("--workers sizes the local cluster; it cannot be used with --scheduler",
                                 param_hint="--workers")
    from pathlib import Path

    from .._util.atomic import reserve
    from .._util.guard import refuse_overwrite

    plan = load_plan(plan_path)
    out = Path(outdir)
    inputs = [("plan", plan_path)] + sorted({("input of a job", j.input) for j in plan.jobs if j.input})
    refuse_overwrite(inputs, [("output", out / "batch-report.json")] + [("output", out / j.name) for j in plan.jobs])
    output_folder(out)
    reserve(out / "batch-report.json")  # the output folder is writable, before any job starts
    report = run_plan(plan, outdir, scheduler=scheduler, n_workers=n_workers, force=force)
    for r in report.failed:
        click.echo(f"failed: {r.name} (input {r.input}): {r.error}", err=True)
    echo_info(ctx, report.summary())
    if not report.ok:
        sys.exit(1)
