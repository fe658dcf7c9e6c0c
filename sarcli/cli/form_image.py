"""``sar form-image PH.h5 -o IMG.h5 --method ...``."""

from __future__ import annotations

import click

from ._common import echo_info, export_options, grid_options, handle_errors, parse_pair, write_side_outputs


def window_options(func):
    """``--window`` and the Taylor parameters, shared by commands that weight the data."""
    func = click.option("--taylor-sll-db", type=float, default=-35.0, show_default=True,
                        help="Taylor window peak sidelobe level (dB, negative).")(func)
    func = click.option("--taylor-nbar", type=int, default=4, show_default=True,
                        help="Taylor window number of nearly constant sidelobes.")(func)
    func = click.option("--window", type=click.Choice(["none", "hann", "hamming", "taylor"]), default="none",
                        show_default=True, help="Window in range and cross-range (peak of a unit point stays 1).")(func)
    return func


@click.command("form-image")
@click.argument("input_path", metavar="PH.h5|KGRID.h5", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Image file to write (.h5).")
@click.option("--method", type=click.Choice(["direct", "nufft", "pfa", "backprojection"]), default="nufft",
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
    import h5py

    from ..formation import form_image
    from ..io import read_phase_history, write_image

    src = _read_input(input_path, h5py, read_phase_history)
    img = form_image(src, method, center=parse_pair(center, "--center"), extent=parse_pair(extent, "--extent"),
                     pixel_size=pixel_size, window=window, taylor_nbar=taylor_nbar, taylor_sll_db=taylor_sll_db,
                     eps=eps, kernel=kernel, oversample=oversample, width=width, upsample=upsample,
                     interp=interp, precision=precision, nthreads=nthreads)
    write_image(output, img)
    write_side_outputs(img, png_path, tif_path)
    echo_info(ctx, f"wrote {output}: {method}, {img.image.shape[1]} x {img.image.shape[0]} pixels, "
                   f"{img.runtime_s:.3g} s")


def _read_input(path, h5py, read_phase_history):
    """A phase-history file, or a k-grid file written by ``sar regrid``."""
    try:
        with h5py.File(path, "r") as f:
            fmt = f.attrs.get("format")
            fmt = fmt.decode() if isinstance(fmt, bytes) else fmt
    except OSError:
        fmt = None
    if fmt == "sarcli-kgrid":
        from ..formers.pfa import KGrid

        return KGrid.from_hdf5(path)
    return read_phase_history(path)
