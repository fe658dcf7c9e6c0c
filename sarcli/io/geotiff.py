"""GeoTIFF export of an image: float32 magnitude or dB, or complex64, north-up, georeferenced.

Frames (see ``docs/formats.md``):

* Rows are flipped so file row 0 is the northern edge; ImageDescription records the flip.
* Raster type ``RasterPixelIsArea``: the tie point (ModelTiepointTag) is the upper-left CORNER of the
  upper-left (north-west) pixel, ``(x_min - dx/2, y_max + dy/2)``; ModelPixelScaleTag is ``(dx, dy, 0)``.
* With ``scene_center_lat_deg`` / ``scene_center_lon_deg`` in the image's attrs or parameters the
  CRS is the local WGS-84 UTM zone (EPSG 326zz/327zz): our x east / y north are added to the
  centre's easting / northing (a tangent-plane approximation; it ignores the grid convergence
  and scale factor, negligible over a scene of a few km). Otherwise the CRS is a user-defined local
  frame in metres (GTModelTypeGeoKey = 32767 user-defined, which GDAL reads as an engineering
  LOCAL_CS) named "sarcli local ENU frame, origin at scene centre, metres".
"""

from __future__ import annotations

import json

import numpy as np
import tifffile

from .._util.atomic import atomic_path
from .._version import __version__
from ..core.types import Image
from . import pixels as _common
from .georef import DEFAULT_REFERENCE, reference_point, utm_epsg

__all__ = ["write_geotiff", "read_geotiff", "LOCAL_CITATION", "geotiff_frame"]

LOCAL_CITATION = "sarcli local ENU frame, origin at scene centre, metres"

# GeoKey ids and values (GeoTIFF 1.1, OGC 19-008r4)
_GT_MODEL_TYPE, _GT_RASTER_TYPE, _GT_CITATION = 1024, 1025, 1026
_PROJECTED_CS_TYPE, _PROJ_CITATION, _PROJ_LINEAR_UNITS = 3072, 3073, 3076
_MODEL_PROJECTED, _USER_DEFINED = 1, 32767
_PIXEL_IS_AREA = 1
_LINEAR_METER = 9001
_TAG_PIXEL_SCALE, _TAG_TIEPOINT, _TAG_GEOKEYS, _TAG_GEOASCII = 33550, 33922, 34735, 34737


def geotiff_frame(img: Image) -> dict:
    """Georeferencing we write for ``img``: origin (upper-left corner), pixel size, CRS.

    Returns
    -------
    dict
        ``epsg`` (int or None for the local frame), ``origin`` (x, y of the north-west corner in
        CRS units), ``pixel`` (dx, dy), ``offset`` (easting, northing added to our x, y).
    """
    grid = img.grid
    ref = reference_point(img.attrs, img.parameters)
    if ref is DEFAULT_REFERENCE:
        epsg, (e0, n0) = None, (0.0, 0.0)
    else:
        from pyproj import Transformer

        epsg = utm_epsg(ref.lat_deg, ref.lon_deg)
        tr = Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True)
        e0, n0 = tr.transform(ref.lon_deg, ref.lat_deg)
    x0 = float(img.x_m[0]) - grid.dx / 2 + e0
    y0 = float(img.y_m[-1]) + grid.dy / 2 + n0
    return {"epsg": epsg, "origin": (x0, y0), "pixel": (grid.dx, grid.dy), "offset": (e0, n0),
            "reference": ref}


def _geokeys(epsg):
    """GeoKeyDirectoryTag entries and GeoAsciiParamsTag text."""
    if epsg is None:
        ascii_ = LOCAL_CITATION + "|"
        keys = [
            (_GT_MODEL_TYPE, 0, 1, _USER_DEFINED),
            (_GT_RASTER_TYPE, 0, 1, _PIXEL_IS_AREA),
            (_GT_CITATION, _TAG_GEOASCII, len(ascii_), 0),
            (_PROJ_LINEAR_UNITS, 0, 1, _LINEAR_METER),
        ]
    else:
        ascii_ = f"WGS 84 / UTM zone {epsg % 100}{'N' if epsg < 32700 else 'S'}|"
        keys = [
            (_GT_MODEL_TYPE, 0, 1, _MODEL_PROJECTED),
            (_GT_RASTER_TYPE, 0, 1, _PIXEL_IS_AREA),
            (_GT_CITATION, _TAG_GEOASCII, len(ascii_), 0),
            (_PROJECTED_CS_TYPE, 0, 1, epsg),
            (_PROJ_LINEAR_UNITS, 0, 1, _LINEAR_METER),
        ]
    directory = [1, 1, 1, len(keys)]
    for k in keys:
        directory.extend(k)
    return directory, ascii_


def write_geotiff(img: Image, path, *, kind: str = "magnitude", dynamic_range_db: float = 50.0):
    """Write ``img`` as a single-band GeoTIFF.

    Parameters
    ----------
    img : Image
    path : str or Path
    kind : {'magnitude', 'db', 'complex'}
        float32 ``|f|``; float32 ``20 log10 |f|`` (absolute: a unit point scatterer is 0 dB,
        floored at the peak minus ``dynamic_range_db`` so no -inf is written); or complex64 ``f``.
    dynamic_range_db : float
        Floor of the dB kind below the peak.

    Returns
    -------
    dict
        The frame written (see :func:`geotiff_frame`).
    """
    _common.check_kind(kind, fmt="GeoTIFF")
    dr = _common.check_dynamic_range(dynamic_range_db)
    if kind == "magnitude":
        data = _common.magnitude(img.image)
    elif kind == "db":
        data = _common.decibels(img.image, dr, relative=False)
    else:
        data = np.asarray(img.image).astype(np.complex64)
    data = _common.north_up(data)
    frame = geotiff_frame(img)
    directory, ascii_ = _geokeys(frame["epsg"])
    (x0, y0), (dx, dy) = frame["origin"], frame["pixel"]
    ref = frame["reference"]
    description = json.dumps({
        "software": f"sarcli {__version__}",
        "kind": kind,
        "units": {"magnitude": "linear |f| (unit point scatterer = 1)", "db": "20*log10|f| dB",
                  "complex": "complex f"}[kind],
        "orientation": _common.FLIP_NOTE,
        "raster_type": "PixelIsArea; tie point = upper-left corner of the north-west pixel",
        "crs": f"EPSG:{frame['epsg']}" if frame["epsg"] else LOCAL_CITATION,
        "scene_center_lat_lon_deg": None if ref.is_default else [ref.lat_deg, ref.lon_deg],
        "method": img.method,
        "dynamic_range_db": dr if kind == "db" else None,
    })
    extratags = [
        (_TAG_PIXEL_SCALE, "d", 3, (dx, dy, 0.0), True),
        (_TAG_TIEPOINT, "d", 6, (0.0, 0.0, 0.0, x0, y0, 0.0), True),
        (_TAG_GEOKEYS, "H", len(directory), directory, True),
        (_TAG_GEOASCII, "s", 0, ascii_, True),
    ]
    with atomic_path(path) as tmp:
        tifffile.imwrite(tmp, data, photometric="minisblack", description=description,
                         metadata=None, software=f"sarcli {__version__}", extratags=extratags)
    return frame


def read_geotiff(path) -> Image:
    """Read a single-band GeoTIFF (ours or another tool's) as an :class:`Image`.

    Rows are flipped back so row 0 is the southern edge. Pixel-centre coordinates come from the
    ModelPixelScale and ModelTiepoint tags (a raster without them gets 1 m pixels centred on the
    origin); for a file sarcli wrote in a UTM frame the scene centre's easting/northing is taken
    off again, so ``x_m``/``y_m`` are local east/north metres as in the image it came from.
    A dB raster is returned as read (real values in dB); ``parameters['kind']`` says which.
    """
    from ..errors import InputFileError

    try:
        with tifffile.TiffFile(path) as tif:
            page = tif.pages[0]
            data = page.asarray()
            tags = {t.code: t.value for t in page.tags.values()}
    except (OSError, ValueError, KeyError, IndexError, tifffile.TiffFileError) as exc:
        raise InputFileError(path, f"not a readable TIFF ({str(exc).splitlines()[0] if str(exc) else exc})") from None
    if data.ndim != 2:
        raise InputFileError(path, f"expected a single-band raster, got shape {data.shape}")
    try:
        meta = json.loads(tags.get(270, "") or "{}")
        meta = meta if isinstance(meta, dict) else {}
    except (TypeError, ValueError):
        meta = {}
    dx, dy = (tuple(tags[_TAG_PIXEL_SCALE][:2]) if _TAG_PIXEL_SCALE in tags else (1.0, 1.0))
    ny, nx = data.shape
    if _TAG_TIEPOINT in tags:
        tp = tags[_TAG_TIEPOINT]
        x0, y0 = float(tp[3]) - float(tp[0]) * dx, float(tp[4]) + float(tp[1]) * dy
    else:
        x0, y0 = -nx * dx / 2, ny * dy / 2
    e0 = n0 = 0.0
    latlon = meta.get("scene_center_lat_lon_deg")
    if latlon and str(meta.get("software", "")).startswith("sarcli"):
        from pyproj import Transformer

        epsg = utm_epsg(*latlon)
        e0, n0 = Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True).transform(latlon[1], latlon[0])
    x = x0 - e0 + dx / 2 + dx * np.arange(nx)
    y = (y0 - n0 - dy / 2 - dy * np.arange(ny))[::-1]
    image = np.asarray(data[::-1])
    image = image.astype(np.complex128 if np.iscomplexobj(image) else np.float64)
    params = {"kind": meta.get("kind", "unknown"), "crs": meta.get("crs"), "source": "geotiff"}
    attrs = {}
    if latlon:
        attrs = {"scene_center_lat_deg": float(latlon[0]), "scene_center_lon_deg": float(latlon[1])}
    return Image(image=image, x_m=x, y_m=y, method=str(meta.get("method", "geotiff")), parameters=params,
                 attrs=attrs)
