"""Export images to other formats: GeoTIFF, PNG, SICD (NITF).

Public API
----------
load_image(path) -> Image   (a sarcli image file, or a ground-plane SICD by its suffix)
export_image(img, path, *, kind=None, dynamic_range_db=50, cmap='gray', annotate=False, fmt=None,
             phase_history=None)

The format is chosen from the suffix (``.tif``/``.tiff`` GeoTIFF, ``.png`` PNG, ``.sicd``/``.nitf``
SICD) unless ``fmt`` names it. ``docs/formats.md`` gives every mapping.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import SarcliInputError
from ..core.types import Image

__all__ = ["export_image", "load_image", "FORMATS", "format_from_suffix"]

#: format name -> suffixes it is chosen by
FORMATS = {"geotiff": (".tif", ".tiff"), "png": (".png",), "sicd": (".sicd", ".nitf", ".ntf")}

#: kind used when none is given
DEFAULT_KIND = {"geotiff": "magnitude", "png": "db", "sicd": "complex"}


def format_from_suffix(path) -> str:
    """The export format a file name asks for; SarcliInputError for an unknown suffix."""
    suffix = Path(path).suffix.lower()
    for name, suffixes in FORMATS.items():
        if suffix in suffixes:
            return name
    known = ", ".join(s for ss in FORMATS.values() for s in ss)
    raise SarcliInputError(f"{path}: cannot tell the export format from suffix {suffix!r}; use one of {known}")


def export_image(img: Image, path, *, kind: str | None = None, dynamic_range_db: float = 50.0,
                 cmap: str = "gray", annotate: bool = False, fmt: str | None = None,
                 phase_history=None):
    """Write an image to GeoTIFF, PNG or SICD.

    Parameters
    ----------
    img : sarcli.core.types.Image
    path : str or Path
    kind : {'magnitude', 'db', 'complex'}, optional
        What is written; default per format: GeoTIFF 'magnitude', PNG 'db', SICD 'complex'
        (the only kind SICD takes; PNG takes 'db' or 'magnitude').
    dynamic_range_db : float
        Displayed range of dB pictures (PNG) and the floor of dB GeoTIFFs.
    cmap : str
        PNG colormap ('gray' or a matplotlib name).
    annotate : bool
        PNG only: a figure with metre axes and a colour bar.
    fmt : {'geotiff', 'png', 'sicd'}, optional
        Overrides the suffix.
    phase_history : sarcli.core.types.PhaseHistory or Acquisition, optional
        SICD only: the collection the image came from (antenna positions, frequencies).

    Returns
    -------
    Path
    """
    name = fmt.lower() if fmt else format_from_suffix(path)
    if name not in FORMATS:
        raise SarcliInputError(f"unknown export format {fmt!r}; choose one of {', '.join(FORMATS)}")
    kind = kind or DEFAULT_KIND[name]
    if annotate and name != "png":
        raise SarcliInputError("--annotate applies to PNG output only")
    if name == "geotiff":
        from .geotiff import write_geotiff

        write_geotiff(img, path, kind=kind, dynamic_range_db=dynamic_range_db)
    elif name == "png":
        from .png import write_png

        write_png(img, path, kind=kind, dynamic_range_db=dynamic_range_db, cmap=cmap, annotate=annotate)
    else:
        if kind != "complex":
            raise SarcliInputError(f"SICD holds complex pixels only; kind {kind!r} is not available")
        from .sicd import write_sicd

        write_sicd(img, path, phase_history=phase_history)
    return Path(path)


def load_image(path) -> Image:
    """Read an image: a SICD (``.sicd``/``.nitf``/``.ntf``, see :func:`sarcli.io.sicd.read_sicd`)
    or a sarcli image file (anything else)."""
    if Path(path).suffix.lower() in FORMATS["sicd"]:
        from .sicd import read_sicd

        return read_sicd(path)
    from .hdf5 import read_image

    return read_image(path)
