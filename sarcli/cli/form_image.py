"""``sar form-image PH.h5 -o IMG.h5 --method ...``."""

from __future__ import annotations

import click

from ..autofocus import METHODS as AUTOFOCUS_METHODS
from ..formers.formation import METHODS
from ..formers.options import KNOB_NAMES
from .options import (cphd_arguments, cphd_options, echo_notes, export_options, grid_options,
                      handle_errors, knob_options, method_options, parse_pair, prepare_outputs, threads_option,
                      window_options, write_side_outputs, wrote)


@click.command("form-image")
@click.argument("input_path", metavar="PH.h5|KGRID.h5", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Image file to write: .h5, or .sicd/.nitf (SICD with the collection's geometry).")
@click.option("--method", type=click.Choice(METHODS), default="auto", show_default=True,
              help="Image formation method; auto: the cheapest predicted to meet --tolerance (see sar plan).")
@window_options
@grid_options
@knob_options
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
@handle_errors
def command(input_path, output, method, **options):
    """Form the matched-filter image of a phase history (or of a k-grid file with --method pfa)."""
    from pathlib import Path

    import numpy as np

    from ..core.grid import resolve_grid
    from ..formers.formation import check_form_image, form_image
    from ..io import open_input
    from ..io.export import SICD_SUFFIXES
    from ..io.hdf5 import stored_image_dtype, write_image

    o = options
    knobs = method_options(method, {k: o.pop(k) for k in KNOB_NAMES})
    given = knobs.given()
    prepare_outputs([("input", input_path), ("--dem", o["dem_path"])],
                    [("output", output), ("--png", o["png_path"]), ("--geotiff", o["tif_path"])])
    dem = _dem(method, output, o["autofocus_method"], o["dem_path"], o["dem_datum"], o["crs"])
    # the samples stay on disk until a former reads them (by blocks of pulses where it can);
    # autofocus rewrites them, so it reads them whole
    _, src = open_input(input_path, expect=("phase-history", "kgrid", "gotcha", "cphd"), truth=False,
                        lazy=o["autofocus_method"] is None,
                        cphd=cphd_arguments(o["channel"], o["sgn"], o["troposphere"]))
    echo_notes(src)
    acq = getattr(src, "acquisition", None)
    center, extent = parse_pair(o["center"], "--center"), parse_pair(o["extent"], "--extent")
    if o["autofocus_method"] is not None and acq is not None:
        grid = resolve_grid(acq.grid, center=center, extent=extent, pixel_size=o["pixel_size"])
        check_form_image(src, method, grid, nthreads=o["nthreads"], **given)   # before autofocus runs
        src = _autofocused(src, o["autofocus_method"], grid)
    img = form_image(src, method, center=center, extent=extent, pixel_size=o["pixel_size"], window=o["window"],
                     taylor_nbar=o["taylor_nbar"], taylor_sll_db=o["taylor_sll_db"], nthreads=o["nthreads"],
                     dem=dem, crs=o["crs"], **given)
    if Path(output).suffix.lower() in SICD_SUFFIXES:
        from ..io.sicd import write_sicd

        if acq is None:
            raise click.BadParameter("SICD output needs a phase history (the collection geometry); "
                                     "a k-grid file has none", param_hint="--output")
        write_sicd(img, output, phase_history=src)
    else:   # the samples' type (a k-grid's are complex128) and the accuracy asked set the stored image's
        samples = getattr(getattr(src, "data", None), "dtype", np.complex128)
        write_image(output, img, stored_image_dtype(samples, tolerance=_accuracy(method, knobs, given),
                                                    complex128=o["complex128"]))
    write_side_outputs(img, o["png_path"], o["tif_path"])
    wrote(output, f"{img.method}, {img.image.shape[1]} x {img.image.shape[0]} pixels, {img.runtime_s:.3g} s")


def _accuracy(method, knobs, given):
    """The relative error the image is asked to meet: ``--tolerance`` given; else nufft's ``--eps``,
    0 for the exact ``direct`` and for float64 backprojection; else None (the former's defaults,
    whose errors exceed complex64's rounding)."""
    if given.get("tolerance") is not None:
        return given["tolerance"]
    if method == "nufft":
        return knobs.eps
    if method == "direct" or getattr(knobs, "precision", None) == "float64":
        return 0.0
    return None


def _dem(method, output, autofocus_method, dem_path, dem_datum, crs):
    """The DEM of a map image (``--dem``), its companions checked; None without one."""
    if dem_path is None and dem_datum is None and crs is None:
        return None
    from pathlib import Path

    from ..errors import SarcliInputError
    from ..formers.points import HEIGHT_METHODS
    from ..io.dem import parse_crs, read_dem
    from ..io.export import SICD_SUFFIXES

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
    return read_dem(dem_path, dem_datum)


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
