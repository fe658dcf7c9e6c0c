"""GeoTIFF export of an image: float32 magnitude or dB, or complex64, north-up, georeferenced.

Frames (see ``docs/formats.md``):

* Rows are flipped so file row 0 is the northern edge; ImageDescription records the flip.
* Raster type ``RasterPixelIsArea``: the tie point (ModelTiepointTag) is the upper-left CORNER of the
  upper-left (north-west) pixel, ``(x_min - dx/2, y_max + dy/2)``; ModelPixelScaleTag is ``(dx, dy, 0)``.
* With ``scene_center_lat_deg`` / ``scene_center_lon_deg`` in the image's attrs or parameters the
  CRS is the ellipsoidal orthographic projection centred on the scene (EPSG method 9840, GeoTIFF
  ``CT_Orthographic`` on WGS 84): its easting / northing of a ground point are the point's east /
  north coordinates in the scene's tangent plane, so our grid is exact in it, north-up and
  unrotated, anywhere on Earth. A scene above the ellipsoid (``scene_center_height_m`` h) is
  scaled by ``N/(N+h)`` east and ``M/(M+h)`` north (prime-vertical and meridian radii), the
  projection of the raised plane onto the ellipsoid. Every pixel lies within micrometres of where
  the CRS says over a kilometre (``tests/test_geotiff_georef.py``). Otherwise the CRS is a
  user-defined local frame in metres (GTModelTypeGeoKey = 32767 user-defined, which GDAL reads as
  an engineering LOCAL_CS) named "sarcli local ENU frame, origin at scene centre, metres".
"""

from __future__ import annotations

import json
import math

import numpy as np
import tifffile

from .._util.atomic import atomic_path, open_held
from .._version import __version__
from ..core.types import Image
from . import pixels
from .georef import DEFAULT_REFERENCE, reference_point, utm_epsg

_WGS84_A, _WGS84_E2 = 6378137.0, 6.69437999014e-3

__all__ = ["write_geotiff", "read_geotiff", "LOCAL_CITATION", "geotiff_frame", "ortho_proj4", "height_scale",
           "map_info"]

LOCAL_CITATION = "sarcli local ENU frame, origin at scene centre, metres"

# GeoKey ids and values (GeoTIFF 1.1, OGC 19-008r4)
_GT_MODEL_TYPE, _GT_RASTER_TYPE, _GT_CITATION = 1024, 1025, 1026
_PROJECTED_CS_TYPE, _PROJ_CITATION, _PROJ_LINEAR_UNITS = 3072, 3073, 3076
_GEOGRAPHIC_TYPE, _PROJECTION, _PROJ_COORD_TRANS = 2048, 3074, 3075
_NAT_ORIGIN_LON, _NAT_ORIGIN_LAT, _FALSE_E, _FALSE_N, _CENTER_LON, _CENTER_LAT = 3080, 3081, 3082, 3083, 3088, 3089
_GCS_WGS84, _CT_ORTHOGRAPHIC = 4326, 21
_MODEL_PROJECTED, _USER_DEFINED = 1, 32767
_PIXEL_IS_AREA = 1
_LINEAR_METER = 9001
_TAG_PIXEL_SCALE, _TAG_TIEPOINT, _TAG_GEOKEYS, _TAG_GEODOUBLE, _TAG_GEOASCII = 33550, 33922, 34735, 34736, 34737


def ortho_proj4(lat_deg: float, lon_deg: float) -> str:
    """PROJ string of the orthographic projection centred on ``(lat_deg, lon_deg)`` (WGS 84)."""
    return (f"+proj=ortho +lat_0={lat_deg!r} +lon_0={lon_deg!r} +x_0=0 +y_0=0 +ellps=WGS84 "
            "+units=m +no_defs")


def height_scale(lat_deg: float, hae_m: float) -> tuple[float, float]:
    """East and north scale from the scene plane at height ``hae_m`` to the ellipsoid:
    ``(N/(N+h), M/(M+h))`` with N, M the prime-vertical and meridian radii of curvature."""
    w = math.sqrt(1.0 - _WGS84_E2 * math.sin(math.radians(lat_deg)) ** 2)
    n_rad, m_rad = _WGS84_A / w, _WGS84_A * (1.0 - _WGS84_E2) / w ** 3
    return n_rad / (n_rad + hae_m), m_rad / (m_rad + hae_m)


def geotiff_frame(img: Image) -> dict:
    """Georeferencing we write for ``img``: origin (upper-left corner), pixel size, CRS.

    Returns
    -------
    dict
        ``crs`` ('ortho' or 'local'), ``proj4`` (the orthographic projection, None for the local
        frame), ``origin`` (x, y of the north-west corner in CRS units), ``pixel`` (dx, dy in CRS
        units), ``scale`` (east, north: CRS units per local metre), ``reference``.
    """
    grid = img.grid
    ref = reference_point(img.attrs, img.parameters)
    mp = map_info(img)
    if mp is not None:   # a map image: its axes are the map CRS's eastings and northings
        x0, y0 = float(img.x_m[0]) - grid.dx / 2, float(img.y_m[-1]) + grid.dy / 2
        return {"crs": "epsg", "proj4": mp["crs"], "epsg": int(str(mp["crs"]).split(":")[1]), "origin": (x0, y0),
                "pixel": (grid.dx, grid.dy), "scale": (1.0, 1.0), "reference": ref}
    if ref is DEFAULT_REFERENCE:
        crs, proj4, (se, sn) = "local", None, (1.0, 1.0)
    else:
        crs, proj4 = "ortho", ortho_proj4(ref.lat_deg, ref.lon_deg)
        se, sn = height_scale(ref.lat_deg, ref.hae_m)
    x0 = (float(img.x_m[0]) - grid.dx / 2) * se
    y0 = (float(img.y_m[-1]) + grid.dy / 2) * sn
    return {"crs": crs, "proj4": proj4, "origin": (x0, y0), "pixel": (grid.dx * se, grid.dy * sn),
            "scale": (se, sn), "reference": ref}


def map_info(img: Image):
    """``parameters['map']`` of a map image on terrain (pixels in a map CRS), else None."""
    mp = (img.parameters or {}).get("map")
    return mp if isinstance(mp, dict) and str(mp.get("crs", "")).startswith("EPSG:") else None


def _geokeys(frame):
    """GeoKeyDirectoryTag entries, GeoDoubleParamsTag values and GeoAsciiParamsTag text."""
    doubles = []
    if frame["crs"] == "epsg":
        ascii_ = f"{frame['proj4']} map grid, pixels formed at DEM heights (sarcli)|"
        keys = [
            (_GT_MODEL_TYPE, 0, 1, _MODEL_PROJECTED),
            (_GT_RASTER_TYPE, 0, 1, _PIXEL_IS_AREA),
            (_GT_CITATION, _TAG_GEOASCII, len(ascii_), 0),
            (_PROJECTED_CS_TYPE, 0, 1, frame["epsg"]),
            (_PROJ_LINEAR_UNITS, 0, 1, _LINEAR_METER),
        ]
    elif frame["crs"] == "local":
        ascii_ = LOCAL_CITATION + "|"
        keys = [
            (_GT_MODEL_TYPE, 0, 1, _USER_DEFINED),
            (_GT_RASTER_TYPE, 0, 1, _PIXEL_IS_AREA),
            (_GT_CITATION, _TAG_GEOASCII, len(ascii_), 0),
            (_PROJ_LINEAR_UNITS, 0, 1, _LINEAR_METER),
        ]
    else:
        ref = frame["reference"]
        ascii_ = (f"sarcli orthographic projection centred on the scene, WGS 84, "
                  f"{ref.lat_deg:.9f} {ref.lon_deg:.9f}|")
        doubles = [ref.lon_deg, ref.lat_deg, 0.0, 0.0]
        keys = [
            (_GT_MODEL_TYPE, 0, 1, _MODEL_PROJECTED),
            (_GT_RASTER_TYPE, 0, 1, _PIXEL_IS_AREA),
            (_GT_CITATION, _TAG_GEOASCII, len(ascii_), 0),
            (_GEOGRAPHIC_TYPE, 0, 1, _GCS_WGS84),
            (_PROJECTED_CS_TYPE, 0, 1, _USER_DEFINED),
            (_PROJECTION, 0, 1, _USER_DEFINED),
            (_PROJ_COORD_TRANS, 0, 1, _CT_ORTHOGRAPHIC),
            (_PROJ_LINEAR_UNITS, 0, 1, _LINEAR_METER),
            (_NAT_ORIGIN_LON, _TAG_GEODOUBLE, 1, 0),
            (_NAT_ORIGIN_LAT, _TAG_GEODOUBLE, 1, 1),
            (_FALSE_E, _TAG_GEODOUBLE, 1, 2),
            (_FALSE_N, _TAG_GEODOUBLE, 1, 3),
            (_CENTER_LON, _TAG_GEODOUBLE, 1, 0),
            (_CENTER_LAT, _TAG_GEODOUBLE, 1, 1),
        ]
    directory = [1, 1, 1, len(keys)]
    for k in keys:
        directory.extend(k)
    return directory, doubles, ascii_


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
    pixels.check_kind(kind, fmt="GeoTIFF")
    dr = pixels.check_dynamic_range(dynamic_range_db)
    if kind == "magnitude":
        data = pixels.magnitude(img.image)
    elif kind == "db":
        data = pixels.decibels(img.image, dr, relative=False)
    else:
        data = np.asarray(img.image).astype(np.complex64)
    data = pixels.north_up(data)
    frame = geotiff_frame(img)
    directory, doubles, ascii_ = _geokeys(frame)
    (x0, y0), (dx, dy) = frame["origin"], frame["pixel"]
    ref = frame["reference"]
    description = json.dumps({
        "software": f"sarcli {__version__}",
        "kind": kind,
        "units": {"magnitude": "linear |f| (unit point scatterer = 1)", "db": "20*log10|f| dB",
                  "complex": "complex f"}[kind],
        "orientation": pixels.FLIP_NOTE,
        "raster_type": "PixelIsArea; tie point = upper-left corner of the north-west pixel",
        "crs": frame["proj4"] or LOCAL_CITATION,
        "scene_center_lat_lon_deg": None if ref.is_default else [ref.lat_deg, ref.lon_deg],
        "scene_center_height_m": None if ref.is_default else ref.hae_m,
        "scale_east_north": list(frame["scale"]),
        "method": img.method,
        "dynamic_range_db": dr if kind == "db" else None,
        **({"map": map_info(img)} if map_info(img) else {}),
    })
    extratags = [
        (_TAG_PIXEL_SCALE, "d", 3, (dx, dy, 0.0), True),
        (_TAG_TIEPOINT, "d", 6, (0.0, 0.0, 0.0, x0, y0, 0.0), True),
        (_TAG_GEOKEYS, "H", len(directory), directory, True),
        *([(_TAG_GEODOUBLE, "d", len(doubles), doubles, True)] if doubles else []),
        (_TAG_GEOASCII, "s", 0, ascii_, True),
    ]
    with atomic_path(path) as tmp, open_held(tmp) as fh:
        tifffile.imwrite(fh, data, photometric="minisblack", description=description,
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
    se, sn = 1.0, 1.0
    latlon = meta.get("scene_center_lat_lon_deg")
    ours = str(meta.get("software", "")).startswith("sarcli")
    mp = meta.get("map") if ours and isinstance(meta.get("map"), dict) else None   # map image: eastings, northings
    if latlon and ours and not mp and str(meta.get("crs", "")).startswith("EPSG:"):
        from pyproj import Transformer  # an earlier sarcli's file: UTM, our x, y added to the centre's

        epsg = utm_epsg(*latlon)
        e0, n0 = Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True).transform(latlon[1], latlon[0])
    elif latlon and ours and not mp:
        se, sn = (float(v) for v in meta.get("scale_east_north") or (1.0, 1.0))
    x = (x0 - e0 + dx / 2 + dx * np.arange(nx)) / se
    y = ((y0 - n0 - dy / 2 - dy * np.arange(ny))[::-1]) / sn
    image = np.asarray(data[::-1])
    image = image.astype(np.complex128 if np.iscomplexobj(image) else np.float64)
    params = {"kind": meta.get("kind", "unknown"), "crs": meta.get("crs"), "source": "geotiff",
              **({"map": mp} if mp else {})}
    attrs = {}
    if latlon:
        attrs = {"scene_center_lat_deg": float(latlon[0]), "scene_center_lon_deg": float(latlon[1])}
        if meta.get("scene_center_height_m") is not None:
            attrs["scene_center_height_m"] = float(meta["scene_center_height_m"])
    return Image(image=image, x_m=x, y_m=y, method=str(meta.get("method", "geotiff")), parameters=params,
                 attrs=attrs)
