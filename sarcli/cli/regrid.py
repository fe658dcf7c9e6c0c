"""``sar regrid PH.h5 -o KGRID.h5``: the Cartesian k-space samples of the polar format algorithm."""

from __future__ import annotations

import click

from ..formers.planning import cost
from .options import grid_options, handle_errors, parse_pair, prepare_outputs, window_options, wrote


@click.command("regrid")
@click.argument("input_path", metavar="PH.h5", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="k-grid file to write (.h5).")
@window_options
@grid_options
@click.option("--kernel", type=click.Choice(["kaiser", "linear"]), default="kaiser", show_default=True)
@click.option("--oversample", type=click.FloatRange(*cost.OVERSAMPLE_RANGE), default=2.0, show_default=True,
              help="k-grid oversampling.")
@click.option("--width", type=click.IntRange(*cost.WIDTH_RANGE), default=6, show_default=True,
              help="Kaiser-Bessel kernel width (cells).")
@click.pass_context
@handle_errors
def command(ctx, input_path, output, **options):
    """Interpolate polar phase history onto a Cartesian k-grid covering only the data's support."""
    from ..formers.formation import regrid
    from ..core.grid import resolve_grid
    from ..io import open_input
    from ..io.hdf5 import write_kgrid

    from ..formers.formation import check_form_image

    o = options
    prepare_outputs([("input", input_path)], [("output", output)])
    _, ph = open_input(input_path, expect=("phase-history", "gotcha", "cphd"), truth=False)
    grid = resolve_grid(ph.acquisition.grid, center=parse_pair(o["center"], "--center"),
                        extent=parse_pair(o["extent"], "--extent"), pixel_size=o["pixel_size"])
    check_form_image(ph, "pfa", grid, oversample=o["oversample"], width=o["width"])
    kg = regrid(ph, grid=grid, window=o["window"], taylor_nbar=o["taylor_nbar"], taylor_sll_db=o["taylor_sll_db"],
                kernel=o["kernel"], oversample=o["oversample"], width=o["width"])
    write_kgrid(output, kg)
    wrote(output, f"k-grid {kg.shape[1]} x {kg.shape[0]}")
