"""``sar export IMG.h5 -o OUT.{tif,png,sicd,nitf}``: write an image in another format."""

from __future__ import annotations

import click

from .options import handle_errors, prepare_outputs, wrote


@click.command("export")
@click.argument("image", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Output file; the suffix picks the format (.tif/.tiff, .png, .sicd/.nitf, .sidd).")
@click.option("--kind", type=click.Choice(["magnitude", "db", "complex"]), default=None,
              help="What to write (default: GeoTIFF magnitude, PNG db, SICD complex, SIDD db).")
@click.option("--dynamic-range-db", type=click.FloatRange(1, 400), default=50.0, show_default=True,
              help="Displayed dynamic range of dB output.")
@click.option("--cmap", default="gray", show_default=True, help="PNG colormap (matplotlib name).")
@click.option("--bare", is_flag=True,
              help="PNG: the raw raster (one pixel per image pixel) instead of the annotated figure.")
# deprecated and hidden: the annotated figure is the default; accepted so that scripts keep running
@click.option("--annotate", is_flag=True, hidden=True, help="Deprecated: the annotated figure is the default.")
@click.option("--phase-history", "phase_history", type=click.Path(dir_okay=False), default=None,
              help="SICD, SIDD: the phase-history file the image was formed from (collection geometry).")
@click.option("--crs", default=None, metavar="EPSG:NNNN",
              help="GeoTIFF of a map image (sar form-image --dem): the CRS to write, which must be the one it was "
                   "formed in (default that one, the scene's UTM zone unless chosen); a plane image is written in "
                   "the scene's tangent-plane orthographic CRS.")
@handle_errors
def command(image, output, kind, dynamic_range_db, cmap, bare, annotate, phase_history, crs):
    """Export IMAGE (a sarcli image file, a SICD or a GeoTIFF) to GeoTIFF, PNG, SICD or SIDD."""
    from ..errors import SarcliInputError
    from ..io import open_input
    from ..io.export import IMAGE_FORMATS, export_image, format_from_suffix

    if annotate and bare:
        raise SarcliInputError("--annotate and --bare contradict each other: give --bare for the raw raster, "
                               "nothing for the annotated figure")
    if annotate:
        click.echo("warning: --annotate is deprecated and has no effect: the annotated figure is the PNG "
                   "default (--bare gives the raw raster)", err=True)
    prepare_outputs([("image", image), ("--phase-history", phase_history)], [("output", output)])
    fmt = format_from_suffix(output)
    annotate = fmt == "png" and not bare
    source, img = open_input(image, expect=IMAGE_FORMATS)
    ph = open_input(phase_history, expect="phase-history", truth=False)[1] if phase_history else None
    from ..io.geotiff import map_info

    mp = map_info(img)
    if crs is not None:
        from ..io.dem import parse_crs

        epsg = parse_crs(crs)
        if fmt != "geotiff":
            raise SarcliInputError(f"--crs applies to GeoTIFF output, not {fmt}")
        if mp is None:
            raise SarcliInputError(f"--crs EPSG:{epsg}: {image} is a plane image (the scene's tangent plane); a map "
                                   "image in a CRS comes from sar form-image --dem DEM.tif --crs EPSG:NNNN")
        if mp["crs"] != f"EPSG:{epsg}":
            raise SarcliInputError(f"--crs EPSG:{epsg}: {image} is a map grid in {mp['crs']}; form it in EPSG:{epsg} "
                                   f"(sar form-image --dem DEM.tif --crs EPSG:{epsg}) rather than resample it")
    if mp is not None and fmt == "sicd":
        raise SarcliInputError(f"{image} is a map image on a DEM ({mp['crs']}), not a SICD's slant or ground plane; "
                               "export it as GeoTIFF or PNG")
    if fmt in ("sicd", "sidd") and ph is None and source != "sicd":
        import warnings

        from ..io.georef import GeometryWarning

        warnings.warn(f"{fmt.upper()} without --phase-history: the collection geometry (Position, Timeline, SCPCOA, "
                      "RadarCollection; SIDD's ARPPoly) is NOMINAL, not the collection's; give --phase-history "
                      "PH.h5, or form the SICD straight from the data (sar form-image FILE.cphd -o IMG.sicd)",
                      GeometryWarning, stacklevel=2)
    if annotate:
        from ..viz import image_figure

        image_figure(img, output, kind=kind or "db", dynamic_range_db=dynamic_range_db, cmap=cmap)
    else:
        export_image(img, output, kind=kind, dynamic_range_db=dynamic_range_db, cmap=cmap, phase_history=ph)
    what = {"png": "annotated dB figure" if annotate else f"{kind or 'db'} raster", "geotiff": f"GeoTIFF, {kind or 'magnitude'}",
            "sicd": "SICD, complex", "sidd": f"SIDD, 8-bit {kind or 'db'}"}[fmt]
    wrote(output, f"{what}, {img.image.shape[1]} x {img.image.shape[0]} pixels")
