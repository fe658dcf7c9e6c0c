"""PNG export of an image: 8-bit dB (or linear magnitude) display, north-up, grey or a colormap.

Mapping (``kind='db'``, the default): ``20 log10(|f| / max|f|)`` clipped to ``[-DR, 0]`` and mapped
linearly onto 0..255, so the peak is exactly 255 and ``-DR`` dB (and below) is 0. ``kind='magnitude'``
maps ``|f| / max|f|`` linearly onto 0..255. Rows are flipped so the top of the picture is north;
the PNG's ``Description`` text chunk records the flip and the mapping. Grey pictures are 8-bit
single-channel; a named matplotlib colormap gives 8-bit RGB. The same display values drawn as a
figure with metre axes and a colour bar: :func:`sarcli.viz.image_figure`, whose PNG carries the
same kind of ``Description`` (:func:`png_text`).
"""

from __future__ import annotations

import numpy as np

from .._util.atomic import atomic_path, open_held
from .._version import __version__
from ..errors import SarcliInputError
from ..core.types import Image
from . import pixels

__all__ = ["write_png", "display_values", "colormap", "png_text"]


def display_values(img: Image, *, kind: str = "db", dynamic_range_db: float = 50.0) -> np.ndarray:
    """The 8-bit picture (our row order, row 0 south) before colouring and flipping."""
    pixels.check_kind(kind, ("db", "magnitude"), "PNG")
    dr = pixels.check_dynamic_range(dynamic_range_db)
    if kind == "db":
        return pixels.db_to_uint8(img.image, dr)
    mag = np.abs(np.asarray(img.image)).astype(np.float64)
    peak = float(mag.max()) if mag.size else 0.0
    scaled = mag / peak if peak > 0 else mag
    return np.clip(np.rint(255.0 * scaled), 0, 255).astype(np.uint8)


def colormap(name):
    """The matplotlib colormap ``name`` (SarcliInputError naming it when unknown)."""
    import matplotlib

    try:
        return matplotlib.colormaps[name]
    except KeyError:
        raise SarcliInputError(f"unknown matplotlib colormap {name!r} (try gray, viridis, magma)") from None


def png_text(*, kind: str = "db", dynamic_range_db: float = 50.0, cmap: str = "gray",
             figure: bool = False) -> dict:
    """The PNG text chunks (``Description``, ``Software``) of a raster or of a figure.

    ``Description`` says how the picture is oriented, how ``|f|`` maps onto 0..255 and which
    colormap shows it; a figure (``figure=True``) says it has metre axes instead of the flip.
    """
    mapping = (f"20log10(|f|/max|f|) clipped to [-{dynamic_range_db:g}, 0] dB -> 0..255" if kind == "db"
               else "|f|/max|f| -> 0..255")
    layout = ("sarcli image figure: north-up, axes x east and y north in metres, colour bar"
              if figure else pixels.FLIP_NOTE)
    return {"Description": f"{layout}; {mapping}; colormap {cmap}", "Software": f"sarcli {__version__}"}


def write_png(img: Image, path, *, kind: str = "db", dynamic_range_db: float = 50.0,
              cmap: str = "gray"):
    """Write ``img`` as a PNG picture (north-up).

    Parameters
    ----------
    img : Image
    path : str or Path
    kind : {'db', 'magnitude'}
    dynamic_range_db : float
        Displayed dynamic range DR (dB) of the dB mapping.
    cmap : str
        'gray' (8-bit grey) or any matplotlib colormap name (8-bit RGB).
    """
    values = display_values(img, kind=kind, dynamic_range_db=dynamic_range_db)
    cm = colormap(cmap)
    from PIL import Image as PILImage
    from PIL.PngImagePlugin import PngInfo

    up = pixels.north_up(values)
    if cmap in ("gray", "grey", "Greys_r"):
        pic = PILImage.fromarray(up, mode="L")
    else:
        rgb = (cm(up.astype(np.float64) / 255.0)[..., :3] * 255.0 + 0.5).astype(np.uint8)
        pic = PILImage.fromarray(rgb, mode="RGB")
    info = PngInfo()
    for key, value in png_text(kind=kind, dynamic_range_db=dynamic_range_db, cmap=cmap).items():
        info.add_text(key, value)
    with atomic_path(path) as tmp, open_held(tmp) as fh:
        pic.save(fh, format="PNG", pnginfo=info)

