"""``sar plot WHAT INPUT -o OUT.png``: psf-cuts | kspace | image-fft diagnostic figures."""

from __future__ import annotations

import click

from .options import grid_options, handle_errors, parse_pair, prepare_outputs, wrote

WHATS = ("psf-cuts", "kspace", "image-fft")


@click.command("plot")
@click.argument("what", type=click.Choice(WHATS))
@click.argument("input_path", metavar="INPUT", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="PNG to write.")
@click.option("--at", default=None, help="psf-cuts: X,Y (m) near which to take the peak.")
@click.option("--dynamic-range-db", type=click.FloatRange(1, 400), default=60.0, show_default=True,
              help="Lower limit of dB scales.")
@grid_options
@handle_errors
def command(what, input_path, output, at, dynamic_range_db, center, extent, pixel_size):
    """Draw WHAT from INPUT.

    \b
    psf-cuts   INPUT an image (.h5, SICD or GeoTIFF): x and y cuts through the peak, -3 dB width marked
    kspace     INPUT a YAML acquisition or a phase history (.h5, GOTCHA .mat, CPHD): samples
               in dimensionless frequencies (k1, k2) = k h ξ with their aliased copies (grid
               options set h)
    image-fft  INPUT an image: the image beside log|2-D FFT|
    """
    from .. import viz as plots

    prepare_outputs([("input", input_path)], [("output", output)])

    if what == "kspace":
        from ..core.grid import resolve_grid
        from ..io import open_input

        # a phase history's samples stay on disk: only its geometry is drawn
        fmt, src = open_input(input_path, expect=("config", "phase-history", "gotcha", "cphd"), truth=False,
                              lazy=True)
        acq = src if fmt == "config" else src.acquisition
        try:
            grid = resolve_grid(acq.grid, center=parse_pair(center, "--center"),
                                extent=parse_pair(extent, "--extent"), pixel_size=pixel_size)
        except ValueError as exc:
            raise click.BadParameter(str(exc)) from None
        plots.plot_kspace(acq, grid, output)
        wrote(output, "k-space samples")
        return
    from ..io.export import load_image

    img = load_image(input_path)
    if what == "psf-cuts":
        plots.plot_psf_cuts(img, output, at=parse_pair(at, "--at"), dynamic_range_db=dynamic_range_db)
    else:
        plots.plot_image_fft(img, output, dynamic_range_db=dynamic_range_db)
    wrote(output, what)
