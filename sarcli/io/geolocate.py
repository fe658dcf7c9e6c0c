"""Geolocation of image pixels: pixel -> (latitude, longitude, height) and back.

Every sarcli image is a ground-plane grid: its pixels lie in the plane z = 0 of the local frame
(docs/conventions.md "Units and frames"), which :mod:`.georef` puts on the Earth as the tangent plane
of the scene-centre reference point (``scene_center_lat_deg`` / ``_lon_deg`` / ``_height_m``).
A pixel ``(row, col)`` (row 0 the southern edge, fractional values allowed) is the plane point

    x = x_0 + col·Δx,   y = y_0 + row·Δy,   z = 0      (local ENU, metres)

and :func:`.georef.enu_to_ecf` / WGS-84 give its latitude, longitude and height above the
ellipsoid. That is :func:`geolocate` with ``height=None``; SICD export writes the same plane
(``Grid/ImagePlane = GROUND``, ``Grid/Type = PLANE``, :mod:`.sicd`).

A scatterer off the plane does not image where it stands: it images at the plane point with the
same range R and range rate Ṙ to the aperture reference point (ARP) at the centre of aperture
(SICD Volume 3, Image Projections Description Document, "R/Rdot contour"):

    R = |ARP - P|,   Ṙ = VARP · (ARP - P) / R

with ARP and its velocity VARP from the polynomial that SICD export writes
(:func:`.sicd.arp_polynomial`, evaluated at the COA time). So, with a ``height`` h,
:func:`geolocate` returns the point at height h on the R/Ṙ contour of the pixel's plane point
(layover), and :func:`pixel_of` maps a point at height h to the plane point on its contour. The
contour projections are sarkit's (``sarkit.sicd.projection.r_rdot_to_constant_hae_surface`` and
``r_rdot_to_ground_plane_mono``), the single home of those formulas; only the frame and the
collection come from sarcli. For an exported SICD the results agree with sarkit's projection of
the file (``tests/test_geolocate.py``).

:func:`pixel_of` with ``height=None`` is the exact inverse of :func:`geolocate` with
``height=None``: the plane point straight below or above (along the ellipsoid normal) the given
latitude and longitude.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sarkit import wgs84

from ..errors import SarcliInputError
from .georef import ReferencePoint, ecf_to_enu, enu_basis, enu_to_ecf, reference_point

__all__ = ["ImageGeometry", "image_geometry", "geolocate", "pixel_of"]

#: pixels (and projected points) may lie this many image sizes beyond each edge
OUTSIDE_MARGIN = 1.0
#: height tolerance (m) of the constant-height projection's iterations
_HAE_TOL_M = 1e-6


@dataclass(frozen=True)
class ImageGeometry:
    """What places an image's pixels on the Earth.

    Attributes
    ----------
    ref : ReferencePoint
        Origin of the local frame; the image plane is its tangent plane.
    x0, y0, dx, dy : float
        Centre of pixel (0, 0) and the spacings in the local frame, metres.
    ny, nx : int
        Image shape.
    arp, varp : ndarray (3,) or None
        ARP position (m) and velocity (m/s) in ECF at the centre of aperture; None without a
        collection (then only ``height=None`` is possible).
    look : int
        +1 left-looking, -1 right-looking (SICD ``SCPCOA/SideOfTrack``), 0 without a collection.
    """

    ref: ReferencePoint
    x0: float
    y0: float
    dx: float
    dy: float
    ny: int
    nx: int
    arp: np.ndarray | None = None
    varp: np.ndarray | None = None
    look: int = 0

    @property
    def scp_ecf(self) -> np.ndarray:
        """ECF of the grid's centre pixel ``(ny//2, nx//2)``: SICD's scene centre point."""
        return self.plane_ecf(self.ny // 2, self.nx // 2)

    def plane_ecf(self, row, col) -> np.ndarray:
        """ECF (m) of fractional pixels in the image plane; shape ``row.shape + (3,)``."""
        row, col = np.broadcast_arrays(np.asarray(row, np.float64), np.asarray(col, np.float64))
        enu = np.stack([self.x0 + col * self.dx, self.y0 + row * self.dy, np.zeros_like(row)], axis=-1)
        return enu_to_ecf(enu, self.ref)

    def pixel_of_ecf(self, ecf) -> tuple[np.ndarray, np.ndarray]:
        """Fractional (row, col) of ECF points of the image plane (the off-plane part is dropped)."""
        enu = ecf_to_enu(ecf, self.ref)
        return (enu[..., 1] - self.y0) / self.dy, (enu[..., 0] - self.x0) / self.dx


def image_geometry(image, phase_history=None) -> ImageGeometry:
    """The :class:`ImageGeometry` of an image, with its collection when one is given.

    Parameters
    ----------
    image : Image or str or Path
        A sarcli image, or a file :func:`sarcli.io.load_image` reads (HDF5, SICD, GeoTIFF). It must
        carry ``scene_center_lat_deg`` / ``scene_center_lon_deg`` (attrs or parameters).
    phase_history : PhaseHistory or Acquisition, optional
        The collection the image was formed from (antenna positions needed); required only to
        project to or from a height off the image plane.

    Raises
    ------
    SarcliInputError
        No georeference, or a collection without antenna positions.
    """
    from .arp import arp_polynomial

    if not hasattr(image, "image") or not hasattr(image, "x_m"):
        from .export import load_image

        image = load_image(image)
    acq = getattr(phase_history, "acquisition", phase_history)
    mp = (image.parameters or {}).get("map")
    if isinstance(mp, dict):
        raise SarcliInputError(f"a map image on a DEM ({mp.get('crs')}) is georeferenced by its map CRS: each pixel "
                               "is at its easting, northing and DEM height, not on the scene's plane")
    ref = reference_point(image.attrs, image.parameters, getattr(phase_history, "attrs", None))
    if ref.is_default:
        raise SarcliInputError("image has no georeference: scene_center_lat_deg / scene_center_lon_deg are "
                               "missing from its attrs (set them, e.g. in the config's location)")
    grid = image.grid
    x0, y0 = float(image.x_m[0]), float(image.y_m[0])
    if acq is None:
        return ImageGeometry(ref, x0, y0, grid.dx, grid.dy, grid.ny, grid.nx)
    if not acq.has_positions:
        raise SarcliInputError("geolocation off the image plane needs antenna positions in the phase "
                               "history (a far-field-only collection has no flight path)")
    _, coefs, t_coa, _ = arp_polynomial(acq, ref)
    arp = np.array([np.polynomial.polynomial.polyval(t_coa, c) for c in coefs])
    varp = np.array([np.polynomial.polynomial.polyval(t_coa, np.polynomial.polynomial.polyder(c)) for c in coefs])
    geo = ImageGeometry(ref, x0, y0, grid.dx, grid.dy, grid.ny, grid.nx, arp, varp)
    # SICD's side of track: left when the line of sight points along (ARP/|ARP|) x VARP
    left = np.cross(arp / np.linalg.norm(arp), varp)
    look = 1 if float(left @ (geo.scp_ecf - arp)) > 0 else -1
    return ImageGeometry(ref, x0, y0, grid.dx, grid.dy, grid.ny, grid.nx, arp, varp, look)


def _finite(name, value) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    bad = ~np.isfinite(a)
    if bad.any():
        where = f" at index {tuple(np.argwhere(bad)[0].tolist())}" if a.ndim else ""
        raise SarcliInputError(f"{name} must be finite numbers, got {a[bad].flat[0]}{where}")
    return a


def _check_inside(geo: ImageGeometry, row, col, label) -> None:
    """Refuse pixels more than OUTSIDE_MARGIN image sizes beyond an edge; ``label(index)`` names
    the offending input in the message."""
    for name, v, n in (("row", row, geo.ny), ("col", col, geo.nx)):
        lo, hi = -OUTSIDE_MARGIN * n - 0.5, (1 + OUTSIDE_MARGIN) * n - 0.5
        out = (v < lo) | (v > hi)
        if np.any(out):
            i = tuple(np.argwhere(out)[0])
            raise SarcliInputError(f"{label(i)} is far outside the {geo.ny} x {geo.nx} image: {name} "
                                   f"{float(v[i]):.6g} (expected {lo:g} .. {hi:g})")


def _sets(geo: ImageGeometry, points_ecf):
    """sarkit's COA projection sets (R, Ṙ to the ARP) of ECF points, shape (..., 3)."""
    from sarkit.sicd import projection

    los = geo.arp - points_ecf
    r = np.linalg.norm(los, axis=-1)
    rdot = (los @ geo.varp) / r
    return projection.ProjectionSetsMono(t_COA=np.zeros_like(r), ARP_COA=geo.arp, VARP_COA=geo.varp,
                                         R_COA=r, Rdot_COA=rdot)


def _need_collection(geo: ImageGeometry) -> None:
    if geo.arp is None:
        raise SarcliInputError("a height off the image plane needs the collection the image was formed "
                               "from (phase_history=...): the layover follows its range and Doppler")


def _scalar(a):
    return a[()] if a.ndim == 0 else a


def geolocate(image, row, col, height=None, *, phase_history=None):
    """Latitude, longitude and height of image pixels.

    Parameters
    ----------
    image : Image, str, Path or ImageGeometry
        The image (see :func:`image_geometry`); an :class:`ImageGeometry` (built once for many
        calls) already holds its collection, and ``phase_history`` is then not used.
    row, col : array_like
        Fractional pixel indices in sarcli's order (row 0 the southern edge, pixel centres at
        integers); broadcast together.
    height : array_like, optional
        Height above the WGS-84 ellipsoid (m) of the scatterer. None: the pixel's point in the image
        plane. Otherwise the point at that height on the pixel's R/Ṙ contour (module docstring).
    phase_history : PhaseHistory or Acquisition, optional
        The image's collection; needed with ``height``.

    Returns
    -------
    lat, lon, h : ndarray or float
        Degrees, degrees, metres above the ellipsoid, in the broadcast shape.

    Raises
    ------
    SarcliInputError
        NaN input, a pixel more than one image size outside the image, an image without
        georeference, a height without the collection, or a height the contour does not reach.

    Examples
    --------
    >>> import numpy as np
    >>> from sarcli.core.grid import Grid
    >>> from sarcli.core.types import Image
    >>> g = Grid(4, 4, 1.0, 1.0, 0.0, 0.0)
    >>> img = Image(np.zeros(g.shape, complex), g.x, g.y,
    ...             attrs={"scene_center_lat_deg": 45.0, "scene_center_lon_deg": 7.0})
    >>> lat, lon, h = geolocate(img, 2, 2)    # the centre pixel is the reference point
    >>> print(f"{lat:.6f} {lon:.6f} {h:.3f}")
    45.000000 7.000000 0.000
    """
    geo = image if isinstance(image, ImageGeometry) else image_geometry(image, phase_history)
    row, col = np.broadcast_arrays(_finite("row", row), _finite("col", col))
    _check_inside(geo, row, col, lambda i: f"pixel (row, col) = ({float(row[i]):.6g}, {float(col[i]):.6g})")
    plane = geo.plane_ecf(row, col)
    if height is None:
        llh = wgs84.cartesian_to_geodetic(plane)
    else:
        from sarkit.sicd import projection

        _need_collection(geo)
        hae = np.broadcast_to(_finite("height", height), row.shape)
        plane = np.broadcast_to(plane, hae.shape + (3,))
        spp, _, ok = projection.r_rdot_to_constant_hae_surface(
            geo.look, geo.scp_ecf, _sets(geo, plane), hae, delta_hae_max=_HAE_TOL_M, nlim=10)
        if not np.isfinite(spp).all():
            i = tuple(np.argwhere(~np.isfinite(spp).all(axis=-1))[0])
            raise SarcliInputError(f"pixel ({float(row[i]):.6g}, {float(col[i]):.6g}) has no point at height "
                                   f"{float(hae[i]):.6g} m: its range/Doppler contour does not reach it")
        llh = wgs84.cartesian_to_geodetic(spp)
        llh[..., 2] = hae
    return _scalar(llh[..., 0]), _scalar(llh[..., 1]), _scalar(llh[..., 2])


def pixel_of(image, lat, lon, height=None, *, phase_history=None):
    """Fractional pixel (row, col) where a point on the Earth images: the inverse of :func:`geolocate`.

    Parameters
    ----------
    image : Image, str, Path or ImageGeometry
        The image (see :func:`image_geometry`).
    lat, lon : array_like
        WGS-84 latitude and longitude, degrees; broadcast together (and with ``height``).
    height : array_like, optional
        Height above the ellipsoid (m). None: the point of the image plane at that latitude and
        longitude (the inverse of ``geolocate(..., height=None)``). Otherwise the scatterer at
        that height, mapped along its R/Ṙ contour into the image plane.
    phase_history : PhaseHistory or Acquisition, optional
        The image's collection; needed with ``height``.

    Returns
    -------
    row, col : ndarray or float
        sarcli's order (row 0 the southern edge).

    Raises
    ------
    SarcliInputError
        NaN or out-of-range latitude, a point more than one image size outside the image, an
        image without georeference, or a height without the collection.

    Examples
    --------
    >>> import numpy as np
    >>> from sarcli.core.grid import Grid
    >>> from sarcli.core.types import Image
    >>> g = Grid(4, 4, 1.0, 1.0, 0.0, 0.0)
    >>> img = Image(np.zeros(g.shape, complex), g.x, g.y,
    ...             attrs={"scene_center_lat_deg": 45.0, "scene_center_lon_deg": 7.0})
    >>> row, col = pixel_of(img, *geolocate(img, 0.25, 3.0)[:2])
    >>> print(f"{row:.9f} {col:.9f}")
    0.250000000 3.000000000
    """
    geo = image if isinstance(image, ImageGeometry) else image_geometry(image, phase_history)
    lat, lon = np.broadcast_arrays(_finite("latitude", lat), _finite("longitude", lon))
    if np.any(np.abs(lat) > 90):
        raise SarcliInputError(f"latitude {float(lat[np.abs(lat) > 90].flat[0]):.6g} is outside -90 .. 90 degrees")
    if height is None:
        # the ellipsoid normal through (lat, lon), E0 + t·u, meets the plane n·(P - ref) = 0
        llh0 = np.stack([lat, lon, np.zeros_like(lat)], axis=-1)
        e0, u = wgs84.geodetic_to_cartesian(llh0), wgs84.up(llh0)
        n = enu_basis(geo.ref)[2]
        t = ((geo.ref.ecf - e0) @ n) / (u @ n)
        points = e0 + t[..., None] * u
    else:
        from sarkit.sicd import projection

        _need_collection(geo)
        hae = _finite("height", height)
        lat, lon, hae = np.broadcast_arrays(lat, lon, hae)
        scene = wgs84.geodetic_to_cartesian(np.stack([lat, lon, hae], axis=-1))
        points = projection.r_rdot_to_ground_plane_mono(geo.look, _sets(geo, scene), geo.ref.ecf,
                                                        enu_basis(geo.ref)[2])
        if not np.isfinite(points).all():
            raise SarcliInputError("a point's range/Doppler contour does not meet the image plane "
                                   "(is the height or position beyond the collection's view?)")
    row, col = geo.pixel_of_ecf(points)
    lat, lon = np.broadcast_to(lat, row.shape), np.broadcast_to(lon, row.shape)
    _check_inside(geo, row, col, lambda i: f"point (lat, lon) = ({float(lat[i]):.9g}, {float(lon[i]):.9g})")
    return _scalar(row), _scalar(col)
