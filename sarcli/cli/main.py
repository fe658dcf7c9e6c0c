"""The ``sar`` group: global flags, lazy loading of one module per command, error mapping.

Each command lives in its own module ``sarcli.cli.<module>`` exposing a click command named
``command``; it is imported only when invoked (heavy imports stay out of ``sar --help``).
To add a command, add one line to ``COMMANDS``.
"""

from __future__ import annotations

import importlib
import logging
import os
import sys

import click

from .._version import __version__
from .._util.progress import set_quiet

#: command name -> (module under sarcli.cli, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "simulate": ("simulate", "Simulate a phase-history file from a YAML acquisition."),
    "info": ("info", "Describe any file sarcli reads (acquisition, phase history, image, k-grid)."),
    "plan": ("plan", "List formers predicted to meet --tolerance, their time and memory, and auto's pick."),
    "form-image": ("form_image", "Form an image: auto (default), direct, nufft, pfa, backprojection, ffbp or subimage."),
    "regrid": ("regrid", "Regrid polar phase history onto a Cartesian k-grid (PFA's first half)."),
    "psf": ("psf", "Write the point spread function of a sampling and its predicted IPR."),
    "quality": ("quality", "Measure IRW, PSLR, ISLR and peak position of point targets."),
    "export": ("export", "Export an image to GeoTIFF, PNG or SICD."),
    "export-cphd": ("export_cphd", "Export a phase history to a CPHD file."),
    "bench": ("bench", "Error against run time for every method and knob."),
    "plot": ("plot", "Diagnostic figures: PSF cuts, k-space samples, image spectrum."),
    "import": ("import_", "Import real phase history (GOTCHA .mat, CPHD)."),
    "regularize": ("regularize", "Regularised image: TV, higher-order TV, l1, phase-corrected TV, Tikhonov."),
    "batch": ("batch", "Run a plan of many imaging jobs on dask."),
    "autofocus": ("autofocus", "Estimate and remove per-pulse phase errors (PGA, minimum entropy)."),
}


class LazyGroup(click.Group):
    """A click group whose subcommands are imported on first use."""

    def list_commands(self, ctx):
        return sorted(COMMANDS)

    def resolve_command(self, ctx, args):
        """Resolve ``args[0]``; a mistyped command is a usage error naming the closest command."""
        name = args[0] if args else None
        if name is not None and name not in COMMANDS and not name.startswith("-"):
            import difflib

            close = difflib.get_close_matches(name, sorted(COMMANDS), n=1, cutoff=0.6)
            hint = f". Did you mean '{close[0]}'?" if close else "."
            raise click.UsageError(f"No such command '{name}'{hint}", ctx)
        return super().resolve_command(ctx, args)

    def get_command(self, ctx, name):
        if name not in COMMANDS:
            return None
        module = importlib.import_module(f"sarcli.cli.{COMMANDS[name][0]}")
        return module.command

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        """Entry point.

        Read from the real command line (``args`` None), SIGINT and SIGTERM are handled by
        :mod:`sarcli._util.interrupt` (within a second, temporary files removed, ``interrupted``,
        exit 130/143); click's test runner passes ``args`` and is left alone. A usage error
        (unknown option, value out of range) is one ``error:`` line and exit code 2, like every
        other user mistake.
        """
        if args is None:
            from .._util.interrupt import install

            install()
            no_huge_pages()
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, False, **extra)
        try:
            rv = super().main(args, prog_name, complete_var, False, **extra)
        except click.UsageError as exc:
            where = f" (see {exc.ctx.command_path} --help)" if exc.ctx is not None else ""
            message = " ".join(exc.format_message().split())
            click.echo(f"error: {message[:300]}{where}", err=True)
            sys.exit(exc.exit_code)
        except click.ClickException as exc:
            exc.show()
            sys.exit(exc.exit_code)
        except click.Abort:
            click.echo("interrupted", err=True)
            sys.exit(130)
        sys.exit(rv if isinstance(rv, int) else 0)

    def format_commands(self, ctx, formatter):
        rows = [(name, COMMANDS[name][1]) for name in sorted(COMMANDS)]
        with formatter.section("Commands"):
            formatter.write_dl(rows)


#: numpy's environment variable: whether it asks the kernel to back arrays of 4 MiB and more with
#: transparent huge pages (read once, when numpy is first imported).
HUGE_PAGE_VARIABLE = "NUMPY_MADVISE_HUGEPAGE"


def no_huge_pages() -> None:
    """Ask numpy not to advise transparent huge pages for this process and its children, unless the
    user set :data:`HUGE_PAGE_VARIABLE`; before numpy is imported (this module does not import it).

    A command's large arrays (polar grids, the image, read buffers) are touched once, so a huge
    page saves few TLB misses, while a fresh one must be found, zeroed and, on a virtual machine
    that returns free memory to its host, backed by the host first: there the first touch of a
    huge-page array costs many times that of small pages (docs/performance.md, "Huge pages").
    """
    os.environ.setdefault(HUGE_PAGE_VARIABLE, "0")


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="sar")
@click.option("-v", "--verbose", count=True, help="More log output (-vv for debug).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bars, no informational output.")
@click.option("--max-memory", "max_memory", default=None, metavar="SIZE",
              help="Largest memory a command may plan to use, e.g. 4G or 512M (default: the machine's "
                   "available memory); a larger estimate is refused before anything is allocated.")
@click.pass_context
def cli(ctx, verbose, quiet, max_memory):
    """sarcli: spotlight SAR image formation, regularisation and accuracy analysis."""
    from .._util.resources import parse_size, set_memory_limit
    from ..errors import SarcliInputError

    try:
        set_memory_limit(None if max_memory is None else parse_size(max_memory))
    except SarcliInputError as exc:
        raise click.BadParameter(str(exc), param_hint="--max-memory") from None
    ctx.ensure_object(dict)
    ctx.obj["verbose"] = verbose
    ctx.obj["quiet"] = quiet
    set_quiet(quiet)
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")


def main():  # pragma: no cover - console entry point
    cli()
