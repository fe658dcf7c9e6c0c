"""Export images to other formats: GeoTIFF, PNG, SICD and SIDD (NITF).

Public API
----------
load_image(path) -> Image   (a sarcli image, a SICD or a GeoTIFF, recognised by its content)
export_image(img, path, *, kind=None, dynamic_range_db=50, cmap='gray', fmt=None,
             phase_history=None)
format_from_suffix(path) -> str  (the export format an output name asks for)

The format written is chosen from the output's suffix (:data:`EXPORT_FORMATS`: ``.tif``/``.tiff``
GeoTIFF, ``.png`` PNG, :data:`SICD_SUFFIXES` SICD, ``.sidd`` SIDD) unless ``fmt`` names it; a file read is
recognised by its content (:func:`sarcli.io.open_input`). ``docs/formats.md`` gives every mapping. The annotated PNG figure (metre axes,
colour bar) is a figure: :func:`sarcli.viz.image_figure`.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import SarcliInputError
from ..core.types import Image

__all__ = ["export_image", "load_image", "format_from_suffix", "EXPORT_FORMATS", "SICD_SUFFIXES", "SIDD_SUFFIXES",
           "IMAGE_FORMATS"]

#: output names that ask for a SICD (NITF) file, here and in ``sar form-image -o``
SICD_SUFFIXES = (".sicd", ".nitf", ".ntf")
#: output names that ask for a SIDD (NITF) file, a detected product
SIDD_SUFFIXES = (".sidd",)
#: export format name -> the output suffixes that choose it (what is *written*; the formats sarcli
#: *reads* are :data:`sarcli.io.FORMATS`, recognised by content)
EXPORT_FORMATS = {"geotiff": (".tif", ".tiff"), "png": (".png",), "sicd": SICD_SUFFIXES, "sidd": SIDD_SUFFIXES}

#: kind used when none is given
DEFAULT_KIND = {"geotiff": "magnitude", "png": "db", "sicd": "complex", "sidd": "db"}


def format_from_suffix(path) -> str:
    """The export format an output name asks for (a key of :data:`EXPORT_FORMATS`);
    SarcliInputError for an unknown suffix."""
    suffix = Path(path).suffix.lower()
    for name, suffixes in EXPORT_FORMATS.items():
        if suffix in suffixes:
            return name
    known = ", ".join(s for ss in EXPORT_FORMATS.values() for s in ss)
    raise SarcliInputError(f"{path}: cannot tell the export format from suffix {suffix!r}; use one of {known}")


def export_image(img: Image, path, *, kind: str | None = None, dynamic_range_db: float = 50.0,
                 cmap: str = "gray", fmt: str | None = None,
                 phase_history=None):
    """Write an image to GeoTIFF, PNG, SICD or SIDD.

    Parameters
    ----------
    img : sarcli.core.types.Image
    path : str or Path
    kind : {'magnitude', 'db', 'complex'}, optional
        What is written; default per format: GeoTIFF 'magnitude', PNG 'db', SICD 'complex'
        (the only kind SICD takes; PNG and SIDD take 'db' or 'magnitude').
    dynamic_range_db : float
        Displayed range of dB pictures (PNG) and the floor of dB GeoTIFFs.
    cmap : str
        PNG colormap ('gray' or a matplotlib name).
    fmt : {'geotiff', 'png', 'sicd', 'sidd'}, optional
        Overrides the suffix.
    phase_history : sarcli.core.types.PhaseHistory or Acquisition, optional
        SICD and SIDD: the collection the image came from (antenna positions, frequencies).

    Returns
    -------
    Path
    """
    name = fmt.lower() if fmt else format_from_suffix(path)
    if name not in EXPORT_FORMATS:
        raise SarcliInputError(f"unknown export format {fmt!r}; choose one of {', '.join(EXPORT_FORMATS)}")
    kind = kind or DEFAULT_KIND[name]
    if name == "geotiff":
        from .geotiff import write_geotiff

        write_geotiff(img, path, kind=kind, dynamic_range_db=dynamic_range_db)
    elif name == "png":
        from .png import write_png

        write_png(img, path, kind=kind, dynamic_range_db=dynamic_range_db, cmap=cmap)
    elif name == "sidd":
        from .sidd import write_sidd

        write_sidd(img, path, phase_history=phase_history, kind=kind, dynamic_range_db=dynamic_range_db)
    else:
        if kind != "complex":
            raise SarcliInputError(f"SICD holds complex pixels only; kind {kind!r} is not available")
        from .sicd import write_sicd

        write_sicd(img, path, phase_history=phase_history)
    return Path(path)


#: the formats :func:`load_image` reads (keys of :data:`sarcli.io.FORMATS`)
IMAGE_FORMATS = ("image", "sicd", "geotiff")


def load_image(path) -> Image:
    """Read an image: a sarcli image file, a SICD (:func:`sarcli.io.sicd.read_sicd`) or a GeoTIFF
    (:func:`sarcli.io.geotiff.read_geotiff`), recognised by its content (:func:`sarcli.io.open_input`).

    Raises
    ------
    InputFileError
        Any other file: one line naming the file, the format found and those expected.
    """
    from . import open_input

    return open_input(path, expect=IMAGE_FORMATS)[1]
