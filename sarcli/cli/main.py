"""The ``sar`` group: global flags, lazy loading of one module per command, error mapping.

Each command lives in its own module ``sarcli.cli.<module>`` exposing a click command named
``command``; it is imported only when invoked (heavy imports stay out of ``sar --help``).
To add a command, add one line to ``COMMANDS``.
"""

from __future__ import annotations

import importlib
import logging

import click

from .._version import __version__
from .._util.progress import set_quiet

#: command name -> (module under sarcli.cli, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "simulate": ("simulate", "Simulate a phase-history file from a YAML acquisition."),
    "info": ("info", "Describe a YAML acquisition or a phase-history/image file."),
    "form-image": ("form_image", "Form an image: direct, nufft, pfa or backprojection."),
    "regrid": ("regrid", "Regrid polar phase history onto a Cartesian k-grid (PFA's first half)."),
    "psf": ("psf", "Write the PSF (Theorem main-theorem) and its predicted IPR."),
    "quality": ("quality", "Measure IRW, PSLR, ISLR and peak position of point targets."),
    "export": ("export", "Export an image to GeoTIFF, PNG or SICD."),
    "export-cphd": ("export_cphd", "Export a phase history to a CPHD file."),
    "bench": ("bench", "Error against run time for every method and knob."),
    "plot": ("plot", "Diagnostic figures: PSF cuts, k-space samples, image spectrum."),
    "import": ("import_", "Import real phase history (GOTCHA .mat, CPHD)."),
    "regularize": ("regularize", "Regularised image: TV, higher-order TV, l1, phase-corrected TV, Tikhonov."),
    "batch": ("batch", "Run a plan of many imaging jobs on dask."),
}


class LazyGroup(click.Group):
    """A click group whose subcommands are imported on first use."""

    def list_commands(self, ctx):
        return sorted(COMMANDS)

    def get_command(self, ctx, name):
        if name not in COMMANDS:
            return None
        module = importlib.import_module(f"sarcli.cli.{COMMANDS[name][0]}")
        return module.command

    def format_commands(self, ctx, formatter):
        rows = [(name, COMMANDS[name][1]) for name in sorted(COMMANDS)]
        with formatter.section("Commands"):
            formatter.write_dl(rows)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="sar")
@click.option("-v", "--verbose", count=True, help="More log output (-vv for debug).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bars, no informational output.")
@click.pass_context
def cli(ctx, verbose, quiet):
    """sarcli: spotlight SAR image formation, regularisation and accuracy analysis."""
    ctx.ensure_object(dict)
    ctx.obj["verbose"] = verbose
    ctx.obj["quiet"] = quiet
    set_quiet(quiet)
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")


def main():  # pragma: no cover - console entry point
    cli()
