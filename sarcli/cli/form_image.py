"""``sar form-image PH.h5 -o IMG.h5 --method ...``."""

from __future__ import annotations

import click

from ..formers.formation import METHODS
from .options import (export_options, grid_options, handle_errors, parse_pair, window_options,
                      write_side_outputs, wrote)


@click.command("form-image")
@click.argument("input_path", metavar="PH.h5|KGRID.h5", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Image file to write (.h5).")
@click.option("--method", type=click.Choice(METHODS), default="nufft",
              show_default=True, help="Image formation method.")
@window_options
@grid_options
@click.option("--eps", type=float, default=1e-9, show_default=True, help="NUFFT accuracy (nufft).")
@click.option("--kernel", type=click.Choice(["kaiser", "linear"]), default="kaiser", show_default=True,
              help="PFA gridding kernel.")
@click.option("--oversample", type=float, default=2.0, show_default=True, help="PFA k-grid oversampling.")
@click.option("--width", type=int, default=6, show_default=True, help="PFA Kaiser-Bessel kernel width (cells).")
@click.option("--upsample", type=float, default=None, help="Backprojection range-profile upsampling (default 8).")
@click.option("--interp", type=click.Choice(["linear", "cubic", "lanczos"]), default=None,
              help="Backprojection interpolator (default cubic).")
@click.option("--precision", type=click.Choice(["float64", "float32"]), default="float64", show_default=True,
              help="Backprojection arithmetic.")
@click.option("--threads", "nthreads", type=int, default=None, help="Threads (default: all cores).")
@export_options
@click.pass_context
@handle_errors
def command(ctx, input_path, output, method, window, taylor_nbar, taylor_sll_db, center, extent, pixel_size,
            eps, kernel, oversample, width, upsample, interp, precision, nthreads, png_path, tif_path):
    """Form the matched-filter image of a phase history (or of a k-grid file with --method pfa)."""
    from ..formers.formation import form_image
    from ..io import open_input
    from ..io.hdf5 import write_image

    _, src = open_input(input_path, expect=("phase-history", "kgrid", "gotcha", "cphd"), truth=False)
    img = form_image(src, method, center=parse_pair(center, "--center"), extent=parse_pair(extent, "--extent"),
                     pixel_size=pixel_size, window=window, taylor_nbar=taylor_nbar, taylor_sll_db=taylor_sll_db,
                     eps=eps, kernel=kernel, oversample=oversample, width=width, upsample=upsample,
                     interp=interp, precision=precision, nthreads=nthreads)
    write_image(output, img)
    write_side_outputs(img, png_path, tif_path)
    wrote(output, f"{img.method}, {img.image.shape[1]} x {img.image.shape[0]} pixels, {img.runtime_s:.3g} s")
