"""Digital elevation models and map grids: the heights a map product's pixels are formed at.

A DEM is a single-band GeoTIFF of heights in metres on a geographic (EPSG:4326 and the like) or
projected (UTM, any EPSG code) CRS, read with its GeoKeys; a DEM in another CRS than the map is
sampled in its own CRS through pyproj. Heights are above the WGS-84 ellipsoid, or above the
EGM96 / EGM2008 geoid when the file's VerticalCSTypeGeoKey says so (5773, 3855) or the caller
does (``datum='geoid'``); geoid heights are converted to ellipsoid heights by pyproj's geoid
grids, and refused in one line where the grid is not installed. Heights are interpolated
bilinearly between the DEM's posts.

A map grid (:class:`MapGrid`) is a north-up grid of pixel centres in a projected CRS (by default
the UTM zone of the scene centre, :func:`sarcli.io.georef.utm_epsg`). :func:`map_points` places
each pixel centre at its DEM height and returns it in the local frame of the scene
(:mod:`.georef`), where the formers of :mod:`sarcli.formers.points` form it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputFileError, SarcliInputError
from .georef import ReferencePoint, ecf_to_enu, enu_to_ecf, utm_epsg

__all__ = ["Dem", "read_dem", "MapGrid", "map_grid", "map_points", "parse_crs", "DATUMS"]

#: vertical datums a DEM may be given in
DATUMS = ("ellipsoid", "geoid")
#: EPSG vertical CRS codes of the geoids, and the compound CRS pyproj converts them with
_GEOIDS = {5773: "EGM96", 3855: "EGM2008"}
_TAG_PIXEL_SCALE, _TAG_TIEPOINT, _TAG_GEOKEYS, _TAG_NODATA = 33550, 33922, 34735, 42113
_KEY_RASTER, _KEY_GEOGRAPHIC, _KEY_PROJECTED, _KEY_VERTICAL = 1025, 2048, 3072, 4096


def parse_crs(text) -> int:
    """The EPSG code of ``'EPSG:NNNN'`` (or ``NNNN``); one line naming the value when it is not a
    projected CRS in metres that pyproj knows."""
    from pyproj import CRS

    s = str(text).strip().upper()
    code = s[5:] if s.startswith("EPSG:") else s
    try:
        epsg = int(code)
        crs = CRS.from_epsg(epsg)
    except Exception:  # noqa: BLE001 - pyproj raises CRSError, ValueError, ...
        raise SarcliInputError(f"--crs {text!r}: expected EPSG:NNNN, a projected CRS pyproj knows "
                               "(e.g. EPSG:32632 for UTM zone 32 N)") from None
    if not crs.is_projected or crs.axis_info[0].unit_name not in ("metre", "meter"):
        raise SarcliInputError(f"--crs {text!r}: a map grid needs a projected CRS in metres, "
                               f"not {crs.name}")
    return epsg


@dataclass(frozen=True)
class Dem:
    """A DEM read by :func:`read_dem`.

    Attributes
    ----------
    path : str
    heights : ndarray (ny, nx) float64
        As stored (row 0 the file's first row); NaN where the file has no data.
    epsg : int
        Horizontal CRS.
    x0, y0, dx, dy : float
        CRS coordinates of the centre of post (0, 0) and the spacings (y decreasing down the rows).
    datum : {'ellipsoid', 'geoid'}
    geoid : str or None
        'EGM96' or 'EGM2008' for geoid heights.
    """

    path: str
    heights: np.ndarray
    epsg: int
    x0: float
    y0: float
    dx: float
    dy: float
    datum: str
    geoid: str | None = None

    def ellipsoid_heights(self, lat_deg, lon_deg) -> np.ndarray:
        """Heights above the WGS-84 ellipsoid at geodetic points (bilinear between posts).

        Raises
        ------
        SarcliInputError
            A point outside the DEM or next to a post without data (one line naming the file and
            the extent), or geoid heights without pyproj's geoid grid.
        """
        from pyproj import Transformer
        from scipy.ndimage import map_coordinates

        lat, lon = np.asarray(lat_deg, dtype=np.float64), np.asarray(lon_deg, dtype=np.float64)
        tr = Transformer.from_crs("EPSG:4326", f"EPSG:{self.epsg}", always_xy=True)
        x, y = tr.transform(lon, lat)
        col = (np.asarray(x) - self.x0) / self.dx
        row = (self.y0 - np.asarray(y)) / self.dy
        ny, nx = self.heights.shape
        outside = (col < 0) | (col > nx - 1) | (row < 0) | (row > ny - 1) | ~np.isfinite(col + row)
        if np.any(outside):
            k = np.flatnonzero(outside.ravel())[0]
            raise SarcliInputError(
                f"{self.path}: the DEM does not cover the scene: it spans lat {self._span()} but the map grid "
                f"needs {lat.ravel()[k]:.6f}, {lon.ravel()[k]:.6f} (give a DEM over the whole grid)")
        h = map_coordinates(self.heights, [row.ravel(), col.ravel()], order=1, mode="nearest").reshape(lat.shape)
        if not np.all(np.isfinite(h)):
            k = np.flatnonzero(~np.isfinite(h.ravel()))[0]
            raise SarcliInputError(f"{self.path}: the DEM has no data at {lat.ravel()[k]:.6f}, {lon.ravel()[k]:.6f}, "
                                   "inside the map grid")
        if self.datum == "geoid":
            h = h + geoid_undulation(lat, lon, self.geoid or "EGM96", self.path)
        return h

    def _span(self) -> str:
        from pyproj import Transformer

        ny, nx = self.heights.shape
        tr = Transformer.from_crs(f"EPSG:{self.epsg}", "EPSG:4326", always_xy=True)
        xs = self.x0 + self.dx * np.array([0, nx - 1, 0, nx - 1])
        ys = self.y0 - self.dy * np.array([0, 0, ny - 1, ny - 1])
        lon, lat = tr.transform(xs, ys)
        return f"{min(lat):.6f}..{max(lat):.6f}, lon {min(lon):.6f}..{max(lon):.6f}"


def geoid_undulation(lat_deg, lon_deg, geoid: str, path) -> np.ndarray:
    """Geoid height N above the ellipsoid (m) by pyproj's grid; one line where it is missing
    (pyproj then leaves heights unchanged, which is checked)."""
    from pyproj import Transformer

    code = {"EGM96": 5773, "EGM2008": 3855}[geoid]
    tr = Transformer.from_crs(f"EPSG:4326+{code}", "EPSG:4979", always_xy=True)
    lat, lon = np.asarray(lat_deg, dtype=np.float64), np.asarray(lon_deg, dtype=np.float64)
    _, _, h = tr.transform(lon, lat, np.zeros_like(lat))
    h = np.asarray(h, dtype=np.float64)
    if not np.all(np.isfinite(h)) or np.all(h == 0.0):
        raise SarcliInputError(f"{path}: {geoid} geoid heights need pyproj's {geoid} grid, which is not installed "
                               "(pyproj sync, or PROJ_NETWORK=ON); or give ellipsoid heights (--dem-datum ellipsoid)")
    return h


def read_dem(path, datum: str | None = None) -> Dem:
    """Read a GeoTIFF DEM (see the module docstring).

    Parameters
    ----------
    path : str or Path
    datum : {'ellipsoid', 'geoid'}, optional
        Overrides the file's vertical datum; default what its VerticalCSTypeGeoKey says
        (EGM96 5773 / EGM2008 3855: geoid), else the ellipsoid.

    Raises
    ------
    InputFileError
        Not a GeoTIFF, no georeferencing, a CRS pyproj does not know or a rotated raster.
    """
    import tifffile

    if datum is not None and datum not in DATUMS:
        raise SarcliInputError(f"--dem-datum {datum!r}: choose one of {', '.join(DATUMS)}")
    try:
        with tifffile.TiffFile(path) as tif:
            page = tif.pages[0]
            data = page.asarray()
            tags = {t.code: t.value for t in page.tags.values()}
    except FileNotFoundError:
        raise InputFileError(path, "no such file (expected a GeoTIFF of heights)") from None
    except Exception as exc:  # noqa: BLE001 - tifffile raises many kinds on a foreign file
        msg = str(exc).splitlines()[0][:80] if str(exc) else type(exc).__name__
        raise InputFileError(path, f"not a GeoTIFF DEM ({msg}); expected a single-band GeoTIFF of heights") from None
    if data.ndim != 2 or np.iscomplexobj(data) or data.shape[0] < 2 or data.shape[1] < 2:
        raise InputFileError(path, f"a DEM is a single-band real raster of at least 2 x 2 posts, got shape {data.shape}")
    if _TAG_GEOKEYS not in tags or _TAG_PIXEL_SCALE not in tags or _TAG_TIEPOINT not in tags:
        raise InputFileError(path, "a TIFF without GeoTIFF georeferencing (GeoKeys, ModelPixelScale, "
                                   "ModelTiepoint); expected a GeoTIFF DEM")
    keys = np.asarray(tags[_TAG_GEOKEYS], dtype=np.int64)
    n_keys = min(int(keys[3]) if keys.size >= 4 else 0, (keys.size - 4) // 4)
    geokeys = {int(keys[i]): int(keys[i + 3]) for i in range(4, 4 + 4 * n_keys, 4) if keys[i + 1] == 0}
    epsg = geokeys.get(_KEY_PROJECTED) or geokeys.get(_KEY_GEOGRAPHIC)
    if not epsg or epsg == 32767:
        raise InputFileError(path, "the DEM's CRS is not an EPSG code (user-defined GeoKeys); "
                                   "reproject it to EPSG:4326 or a UTM zone (e.g. gdalwarp -t_srs EPSG:4326)")
    try:
        from pyproj import CRS

        CRS.from_epsg(epsg)
    except Exception:  # noqa: BLE001
        raise InputFileError(path, f"the DEM's CRS EPSG:{epsg} is unknown to pyproj") from None
    heights = np.asarray(data, dtype=np.float64).copy()
    if _TAG_NODATA in tags:
        try:
            heights[heights == float(str(tags[_TAG_NODATA]).strip("\x00 "))] = np.nan
        except ValueError:
            pass
    dx, dy = (float(v) for v in tags[_TAG_PIXEL_SCALE][:2])
    tp = [float(v) for v in tags[_TAG_TIEPOINT][:6]]
    if not (dx > 0 and dy > 0):
        raise InputFileError(path, f"ModelPixelScale ({dx}, {dy}) must be positive")
    # the tie point is the corner of post (0, 0) for PixelIsArea (1, the default), its centre for PixelIsPoint
    half = 0.5 if geokeys.get(_KEY_RASTER, 1) == 1 else 0.0
    x0 = tp[3] + (half - tp[0]) * dx
    y0 = tp[4] - (half - tp[1]) * dy
    vertical = geokeys.get(_KEY_VERTICAL)
    geoid = _GEOIDS.get(vertical)
    chosen = datum or ("geoid" if geoid else "ellipsoid")
    return Dem(str(path), heights, int(epsg), x0, y0, dx, dy, chosen, (geoid or "EGM96") if chosen == "geoid" else None)


@dataclass(frozen=True)
class MapGrid:
    """North-up pixel centres of a map grid in a projected CRS: ``easting`` (nx,), ``northing``
    (ny,) increasing (row 0 the southern edge, as every sarcli image), metres."""

    epsg: int
    easting: np.ndarray
    northing: np.ndarray

    @property
    def shape(self):
        return (self.northing.size, self.easting.size)


def map_grid(ref: ReferencePoint, x_m, y_m, pixel_m: float, epsg: int | None = None) -> MapGrid:
    """The map grid covering a local-frame rectangle: the bounding box in the map CRS of the
    rectangle spanned by pixel centres ``x_m``, ``y_m``, on pixel edges at multiples of ``pixel_m``.

    ``epsg`` default: the UTM zone of ``ref``.
    """
    from pyproj import Transformer
    from sarkit import wgs84

    if ref.is_default:
        raise SarcliInputError("a map grid needs the scene centre's latitude and longitude "
                               "(scene_center_lat_deg / scene_center_lon_deg in the data)")
    epsg = epsg or utm_epsg(ref.lat_deg, ref.lon_deg)
    xs = np.array([x_m[0], x_m[-1]])
    ys = np.array([y_m[0], y_m[-1]])
    corners = np.array([[x, y, 0.0] for x in xs for y in ys])
    llh = wgs84.cartesian_to_geodetic(enu_to_ecf(corners, ref))
    e, n = Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True).transform(llh[:, 1], llh[:, 0])
    h = float(pixel_m)
    e0, e1 = np.floor(np.min(e) / h) * h, np.ceil(np.max(e) / h) * h
    n0, n1 = np.floor(np.min(n) / h) * h, np.ceil(np.max(n) / h) * h
    nx, ny = max(1, int(round((e1 - e0) / h))), max(1, int(round((n1 - n0) / h)))
    return MapGrid(int(epsg), e0 + h / 2 + h * np.arange(nx), n0 + h / 2 + h * np.arange(ny))


def map_points(grid: MapGrid, dem: Dem, ref: ReferencePoint):
    """Pixel centres of ``grid`` at their DEM heights, in the local frame of ``ref``.

    Returns
    -------
    points : ndarray (ny, nx, 3)
        Local east, north, up (m).
    hae : ndarray (ny, nx)
        Heights above the ellipsoid (m).
    """
    from pyproj import Transformer
    from sarkit import wgs84

    ee, nn = np.meshgrid(grid.easting, grid.northing)
    lon, lat = Transformer.from_crs(f"EPSG:{grid.epsg}", "EPSG:4326", always_xy=True).transform(ee, nn)
    hae = dem.ellipsoid_heights(lat, lon)
    ecf = wgs84.geodetic_to_cartesian(np.stack([lat, lon, hae], axis=-1))
    return ecf_to_enu(ecf, ref), hae
