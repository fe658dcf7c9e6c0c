"""``sar form-image PH.h5 -o IMG.h5 --method ...``."""

from __future__ import annotations

import click
from click.core import ParameterSource

from ..autofocus import METHODS as AUTOFOCUS_METHODS
from ..formers import cost
from ..formers.formation import METHODS
from .options import (cphd_arguments, cphd_options, echo_notes, export_options, grid_options, handle_errors,
                      parse_pair, prepare_outputs, threads_option, window_options, write_side_outputs, wrote)

#: Options that set a knob of one method (auto chooses them itself).
_METHOD_KNOBS = ("eps", "kernel", "oversample", "width", "upsample", "interp", "precision", "base", "merge",
                 "os_range", "os_angle", "tile")


@click.command("form-image")
@click.argument("input_path", metavar="PH.h5|KGRID.h5", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Image file to write: .h5, or .sicd/.nitf (SICD with the collection's geometry).")
@click.option("--method", type=click.Choice(METHODS), default="auto", show_default=True,
              help="Image formation method; auto: the cheapest predicted to meet --tolerance (see sar plan).")
@window_options
@grid_options
@click.option("--eps", type=click.FloatRange(*cost.EPS_RANGE), default=1e-9, show_default=True,
              help="NUFFT accuracy (nufft).")
@click.option("--kernel", type=click.Choice(["kaiser", "linear"]), default="kaiser", show_default=True,
              help="PFA gridding kernel.")
@click.option("--oversample", type=click.FloatRange(*cost.OVERSAMPLE_RANGE), default=2.0, show_default=True,
              help="PFA k-grid oversampling.")
@click.option("--width", type=click.IntRange(*cost.WIDTH_RANGE), default=6, show_default=True,
              help="PFA Kaiser-Bessel kernel width (cells).")
@click.option("--upsample", type=click.FloatRange(*cost.UPSAMPLE_RANGE), default=None,
              help="Range-profile upsampling (default: backprojection 8; ffbp os-range with optimal (at least 1.5), else 4).")
@click.option("--interp", type=click.Choice(["linear", "cubic", "lanczos", "optimal"]), default=None,
              help="Backprojection / ffbp interpolator (default cubic / optimal; 'optimal' is ffbp only).")
@click.option("--precision", type=click.Choice(["float64", "float32"]), default=None,
              help="Backprojection's profiles and sums (default float32; the ranges are float64 per tile of pixels either way).")
@click.option("--base", type=click.IntRange(min=1), default=None, help="ffbp: pulses per base sub-aperture (default 16). With no ffbp knob given, ffbp takes auto's ffbp pick at --tolerance.")
@click.option("--merge", type=click.IntRange(min=2), default=None, help="ffbp: sub-apertures merged per stage (default 4).")
@click.option("--os-range", type=click.FloatRange(min=1), default=None, help="ffbp: polar-grid range oversampling (default 1.5 where its kernel can be deapodized, else 2).")
@click.option("--os-angle", type=click.FloatRange(min=1), default=None, help="ffbp: polar-grid angular oversampling (default 1.5 where its kernel can be deapodized, else 2).")
@click.option("--tile", type=click.IntRange(min=1), default=None,
              help="subimage: tile side in pixels (default: the largest predicted to meet --tolerance).")
@click.option("--tolerance", type=click.FloatRange(min=1e-12, max=0.5), default=None,
              help="Target relative error against the exact matched filter (auto, and ffbp given no ffbp knob: default 1e-3; subimage: 1e-2).")
@click.option("--autofocus", "autofocus_method", type=click.Choice(AUTOFOCUS_METHODS), default=None,
              help="First estimate and remove per-pulse phase errors on the image grid (see sar autofocus).")
@click.option("--dem", "dem_path", type=click.Path(dir_okay=False), default=None,
              help="A GeoTIFF of heights: form a map image, each pixel of a map grid at its DEM height "
                   "(backprojection or direct; auto takes backprojection).")
@click.option("--dem-datum", type=click.Choice(["ellipsoid", "geoid"]), default=None,
              help="The DEM's heights: above the WGS-84 ellipsoid or the EGM96/EGM2008 geoid (default: its metadata, else ellipsoid).")
@click.option("--crs", default=None, metavar="EPSG:NNNN",
              help="The map grid's CRS with --dem (default: the UTM zone of the scene centre).")
@click.option("--complex128", "complex128", is_flag=True,
              help="Store the image complex128 (default: complex64 where the samples are complex64, unless "
                   "the accuracy asked (--tolerance, nufft's --eps, direct, float64 precision) is finer "
                   "than complex64's rounding; else complex128).")
@threads_option
@cphd_options
@export_options
@click.pass_context
@handle_errors
def command(ctx, input_path, output, method, autofocus_method, window, taylor_nbar, taylor_sll_db, center, extent,
            pixel_size,
            eps, kernel, oversample, width, upsample, interp, precision, base, merge, os_range, os_angle, tile,
            tolerance, dem_path, dem_datum, crs, complex128, nthreads, channel, sgn, troposphere, png_path, tif_path):
    """Form the matched-filter image of a phase history (or of a k-grid file with --method pfa)."""
    from ..formers.formation import form_image
    from pathlib import Path

    from ..io import open_input
    from ..io.export import SICD_SUFFIXES
    import numpy as np

    from ..io.hdf5 import stored_image_dtype, write_image
    from ..core.grid import resolve_grid
    from ..formers.cost import check_form_image

    if method == "auto":   # auto picks every knob itself: a knob given by hand belongs to one method
        given = [p for p in _METHOD_KNOBS if ctx.get_parameter_source(p) is not ParameterSource.DEFAULT]
        if given:
            raise click.UsageError(f"--{given[0].replace('_', '-')} sets a knob of one method; give --method too "
                                   "(auto picks its own knobs: see `sar plan`)")
    prepare_outputs([("input", input_path), ("--dem", dem_path)],
                    [("output", output), ("--png", png_path), ("--geotiff", tif_path)])
    dem = None
    if dem_path is not None or dem_datum is not None or crs is not None:
        from ..errors import SarcliInputError
        from ..formers.points import HEIGHT_METHODS
        from ..io.dem import parse_crs, read_dem

        if dem_path is None:
            raise SarcliInputError(f"{'--crs' if crs else '--dem-datum'} belongs to a map image: give --dem DEM.tif too")
        if method not in HEIGHT_METHODS + ("auto",):
            raise SarcliInputError(f"--dem: method {method} forms the plane z = 0 only; use backprojection, "
                                   "direct or auto")
        if autofocus_method is not None:
            raise SarcliInputError("--dem and --autofocus: autofocus on a map grid is not available; "
                                   "autofocus a plane image first (sar autofocus)")
        if crs is not None:
            parse_crs(crs)
        if Path(output).suffix.lower() in SICD_SUFFIXES:
            raise click.BadParameter("a map image on a DEM is not a SICD (a slant or ground plane); write .h5 "
                                     "or --geotiff, or sar export it to .sidd", param_hint="--output")
        dem = read_dem(dem_path, dem_datum)
    # the samples stay on disk until a former reads them (by blocks of pulses where it can);
    # autofocus rewrites them, so it reads them whole
    _, src = open_input(input_path, expect=("phase-history", "kgrid", "gotcha", "cphd"), truth=False,
                        lazy=autofocus_method is None, cphd=cphd_arguments(channel, sgn, troposphere))
    echo_notes(src)
    acq = getattr(src, "acquisition", None)
    if acq is not None:
        grid = resolve_grid(acq.grid, center=parse_pair(center, "--center"), extent=parse_pair(extent, "--extent"),
                            pixel_size=pixel_size)
        if autofocus_method is not None:  # form_image checks memory and time itself; autofocus runs first
            check_form_image(src, method, grid, oversample=oversample, upsample=upsample, eps=eps, width=width,
                             precision=precision, nthreads=nthreads)
    if autofocus_method is not None and acq is not None:
        src = _autofocused(src, autofocus_method, grid)
    img = form_image(src, method, center=parse_pair(center, "--center"), extent=parse_pair(extent, "--extent"),
                     pixel_size=pixel_size, window=window, taylor_nbar=taylor_nbar, taylor_sll_db=taylor_sll_db,
                     eps=eps, kernel=kernel, oversample=oversample, width=width, upsample=upsample,
                     interp=interp, precision=precision, nthreads=nthreads, base=base, merge=merge,
                     os_range=os_range, os_angle=os_angle, tile=tile, tolerance=tolerance, dem=dem, crs=crs)
    if Path(output).suffix.lower() in SICD_SUFFIXES:
        from ..io.sicd import write_sicd

        if acq is None:
            raise click.BadParameter("SICD output needs a phase history (the collection geometry); "
                                     "a k-grid file has none", param_hint="--output")
        write_sicd(img, output, phase_history=src)
    else:   # the samples' type (a k-grid's are complex128) and the accuracy asked set the stored image's
        samples = getattr(getattr(src, "data", None), "dtype", np.complex128)
        write_image(output, img, stored_image_dtype(samples, tolerance=_accuracy(method, tolerance, eps, precision),
                                                    complex128=complex128))
    write_side_outputs(img, png_path, tif_path)
    wrote(output, f"{img.method}, {img.image.shape[1]} x {img.image.shape[0]} pixels, {img.runtime_s:.3g} s")


def _accuracy(method, tolerance, eps, precision):
    """The relative error the image is asked to meet: ``--tolerance``; else nufft's ``--eps``, 0 for
    the exact ``direct`` and for float64 backprojection; else None (the former's defaults, whose
    errors exceed complex64's rounding)."""
    if tolerance is not None:
        return tolerance
    if method == "nufft":
        return eps
    if method == "direct" or precision == "float64":
        return 0.0
    return None


def _autofocused(src, method, grid):
    """``src`` with its per-pulse phase errors removed (:func:`sarcli.autofocus.autofocus`)."""
    import numpy as np

    from ..autofocus import autofocus
    from ..core.types import PhaseHistory

    ph = PhaseHistory(np.asarray(src.data), src.acquisition, None, dict(src.attrs))
    out, res = autofocus(ph, method, grid=grid)
    wrote_note = (f"autofocus {method}: {float(np.sqrt(np.mean(res.phase_rad ** 2))):.3g} rad rms removed, "
                  f"entropy {res.entropy_before:.4f} -> {res.entropy_after:.4f}")
    ctx = click.get_current_context(silent=True)
    if ctx is not None and not (ctx.find_root().obj or {}).get("quiet"):
        click.echo(wrote_note)
    return out
