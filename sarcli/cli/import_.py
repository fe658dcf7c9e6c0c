"""``sar import``: real phase history into a sarcli phase-history file.

Subcommands: ``gotcha`` (AFRL GOTCHA ``.mat``, defined here) and ``cphd`` (module
``sarcli.cli.import_cphd``, loaded lazily and only listed when that module exists).
"""

from __future__ import annotations

import importlib
import importlib.util

import click

from .options import grid_options, handle_errors, parse_pair, prepare_outputs, wrote

#: subcommand name -> module under sarcli.cli exposing a click command ``command``
_LAZY = {"cphd": "import_cphd"}


def _lazy_available(name: str) -> bool:
    try:
        return importlib.util.find_spec(f"sarcli.cli.{_LAZY[name]}") is not None
    except (ImportError, ValueError):
        return False


class _ImportGroup(click.Group):
    """Own subcommands plus lazily imported ones that exist in this installation."""

    def list_commands(self, ctx):
        return sorted(set(super().list_commands(ctx)) | {n for n in _LAZY if _lazy_available(n)})

    def get_command(self, ctx, name):
        cmd = super().get_command(ctx, name)
        if cmd is not None or name not in _LAZY or not _lazy_available(name):
            return cmd
        return importlib.import_module(f"sarcli.cli.{_LAZY[name]}").command


@click.group("import", cls=_ImportGroup)
def command():
    """Import real phase history (GOTCHA .mat, CPHD) as a sarcli phase-history file."""


@command.command("gotcha")
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Phase-history file to write (HDF5).")
@click.option("--autofocus", is_flag=True,
              help="Apply the files' autofocus solution (r0 + af.r_correct, data · exp(i af.ph_correct)).")
@grid_options
@click.pass_context
@handle_errors
def gotcha(ctx, files, output, autofocus, center, extent, pixel_size):
    """Import AFRL GOTCHA FILES (one pass, one polarisation; joined in azimuth order).

    The default image grid stored with the data is 100 m x 100 m with 0.25 m pixels, centred
    on the scene centre, unless --center/--extent/--pixel-size say otherwise.
    """
    from ..io.gotcha import default_gotcha_grid, read_gotcha
    from ..core.grid import resolve_grid
    from ..io.hdf5 import write_phase_history

    prepare_outputs([("input", f) for f in files], [("output", output)])
    try:
        grid = resolve_grid(default_gotcha_grid(), center=parse_pair(center, "--center"),
                            extent=parse_pair(extent, "--extent"), pixel_size=pixel_size)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None
    ph = read_gotcha(files, autofocus=autofocus, grid=grid)
    write_phase_history(output, ph)
    P, M = ph.data.shape
    wrote(output, f"{P} pulses x {M} frequencies, spherical model, AFRL autofocus "
                  f"{'applied' if autofocus else 'not applied'}, grid {grid.ny} x {grid.nx} of {grid.dx:g} m")
