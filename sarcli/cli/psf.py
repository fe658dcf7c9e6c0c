"""``sar psf CONFIG.yaml|PH.h5 -o PSF.h5``: the matched filter's point spread function
(docs/conventions.md "Image formation and its normalisation")."""

from __future__ import annotations

import click

from .options import (echo_info, grid_options, handle_errors, parse_pair, prepare_outputs, window_options,
                      wrote)


@click.command("psf")
@click.argument("source", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Image file to write (.h5), method 'psf'.")
@window_options(nbar_dest="nbar", sll_dest="sll_db")
@click.option("--method", type=click.Choice(["auto", "theorem", "direct", "nufft"]), default="auto",
              show_default=True, help="theorem: the closed-form kernel K; direct: the exact sum; nufft: the sum by FINUFFT "
                   "(windows need a sum).")
@click.option("--png", type=click.Path(dir_okay=False), default=None, help="Also write a PNG of 20 log10|K|.")
@click.option("--dynamic-range-db", type=click.FloatRange(1, 400), default=60.0, show_default=True, help="PNG colour range.")
@grid_options
@click.pass_context
@handle_errors
def command(ctx, source, output, **options):
    """Write the PSF of a unit point at the grid centre for SOURCE's sampling (a YAML or a phase history).

    Prints the predicted -3 dB widths, PSLR and ISLR (also stored in the file's attributes).
    """
    from ..core.grid import resolve_grid
    from ..io.hdf5 import write_image
    from ..viz import plot_psf
    from ..analysis.psf import psf_image
    from ..analysis.quality import load_reference

    from .._util.resources import check_memory

    o = options
    png, window = o["png"], o["window"]
    prepare_outputs([("input", source)], [("output", output), ("--png", png)])
    acq, _ = load_reference(source)
    try:
        grid = resolve_grid(acq.grid, center=parse_pair(o["center"], "--center"),
                            extent=parse_pair(o["extent"], "--extent"), pixel_size=o["pixel_size"])
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None
    check_memory(8.0 * grid.nx * grid.ny * 16 + 3.0 * acq.azimuth_rad.size * acq.frequency_hz.shape[-1] * 16,
                 f"a {grid.nx} x {grid.ny} PSF")
    img = psf_image(acq, grid, window=window, nbar=o["nbar"], sll_db=o["sll_db"], method=o["method"])
    write_image(output, img)
    if png:
        plot_psf(img, png, dynamic_range_db=o["dynamic_range_db"])
    wrote(output, f"{grid.ny} x {grid.nx} PSF, {img.parameters['evaluation']}, window {window}")
    if png:
        wrote(png, "PSF figure")
    echo_info(ctx, _summary(img.attrs["predicted_ipr"]))


def _summary(pred: dict) -> str:
    """The predicted impulse response's figures, a line per direction and the window's textbook."""
    lines = ["predicted impulse response:"]
    for d in ("range", "cross_range"):
        p = pred[d]
        if p.get("irw_m") is not None:
            lines.append(f"  {d:<11s} IRW {p['irw_m']:.4g} m  PSLR {p['pslr_db']:.2f} dB  "
                         f"ISLR {p['islr_db']:.2f} dB  (resolution {p['resolution_m']:.4g} m)")
    tb = pred.get("textbook")
    if tb:
        lines.append(f"  textbook (1-D window): IRW {tb['irw_factor']:.3f} x resolution, "
                     f"PSLR {tb['pslr_db']:.2f} dB, ISLR {tb['islr_db']:.2f} dB (infinite extent)")
    return "\n".join(lines)
