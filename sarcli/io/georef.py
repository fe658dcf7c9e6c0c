"""Where the local scene frame sits on the Earth: reference point, ENU <-> ECF, UTM zone.

sarcli works in a local frame (docs/conventions.md "Units and frames": x east, y north, z up, origin at
the scene centre). Formats that need Earth coordinates (GeoTIFF, SICD, CPHD) anchor that
frame at a reference point read from the optional attributes ``scene_center_lat_deg``,
``scene_center_lon_deg`` (and ``scene_center_height_m``, default 0) of an image or phase history.
Without them the placeholder :data:`DEFAULT_REFERENCE` is used and the writer says so in the file.

The local frame is the tangent-plane East-North-Up frame of that point on the WGS-84 ellipsoid;
:func:`enu_to_ecf` / :func:`ecf_to_enu` are the one place the conversion is written.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sarkit import wgs84

__all__ = ["GeometryWarning", "ReferencePoint", "DEFAULT_REFERENCE", "reference_point", "enu_to_ecf", "ecf_to_enu",
           "enu_basis", "utm_epsg", "plane_reference"]

from ..errors import SarcliWarning

LAT_KEY = "scene_center_lat_deg"
LON_KEY = "scene_center_lon_deg"
HAE_KEY = "scene_center_height_m"


class GeometryWarning(SarcliWarning):
    """A file's geometry cannot be represented exactly (image axes, nominal geometry); says what."""


@dataclass(frozen=True)
class ReferencePoint:
    """Geodetic position of the scene centre (origin of the local ENU frame).

    Attributes
    ----------
    lat_deg, lon_deg, hae_m : float
        WGS-84 latitude, longitude (degrees) and height above the ellipsoid (m).
    is_default : bool
        True when no position was given and the placeholder is used.
    """

    lat_deg: float
    lon_deg: float
    hae_m: float = 0.0
    is_default: bool = False

    @property
    def latlonhae(self) -> np.ndarray:
        return np.array([self.lat_deg, self.lon_deg, self.hae_m], dtype=np.float64)

    @property
    def ecf(self) -> np.ndarray:
        """ECF (ECEF) position of the point, metres."""
        return wgs84.geodetic_to_cartesian(self.latlonhae)

    def as_attrs(self) -> dict:
        return {LAT_KEY: self.lat_deg, LON_KEY: self.lon_deg, HAE_KEY: self.hae_m}


#: Placeholder reference point (0° N, 0° E, 0 m on the ellipsoid) used when a file gives none:
#: an obviously artificial place, stated in every file written with it.
DEFAULT_REFERENCE = ReferencePoint(0.0, 0.0, 0.0, is_default=True)


def reference_point(*sources) -> ReferencePoint:
    """The scene-centre reference point from the first mapping that holds lat and lon.

    Parameters
    ----------
    *sources : dict or None
        Attribute dictionaries searched in order (e.g. ``img.attrs, img.parameters``).

    Returns
    -------
    ReferencePoint
        :data:`DEFAULT_REFERENCE` when none of them holds both keys.
    """
    for src in sources:
        if not src:
            continue
        if LAT_KEY in src and LON_KEY in src:
            lat, lon = float(src[LAT_KEY]), float(src[LON_KEY])
            if not (-90.0 <= lat <= 90.0 and np.isfinite(lon)):
                raise ValueError(f"scene centre latitude {lat} / longitude {lon} out of range")
            return ReferencePoint(lat, (lon + 180.0) % 360.0 - 180.0, float(src.get(HAE_KEY, 0.0)))
    return DEFAULT_REFERENCE


def enu_basis(ref: ReferencePoint) -> np.ndarray:
    """Rows: the unit East, North and Up vectors of ``ref`` in ECF, shape (3, 3)."""
    llh = ref.latlonhae
    return np.stack([wgs84.east(llh), wgs84.north(llh), wgs84.up(llh)])


def enu_to_ecf(enu_m, ref: ReferencePoint) -> np.ndarray:
    """Local ENU coordinates (m, origin at ``ref``) to ECF (m); shape (..., 3) in and out."""
    enu = np.asarray(enu_m, dtype=np.float64)
    return ref.ecf + enu @ enu_basis(ref)


def ecf_to_enu(ecf_m, ref: ReferencePoint) -> np.ndarray:
    """ECF (m) to local ENU (m) about ``ref``: the exact inverse of :func:`enu_to_ecf`."""
    ecf = np.asarray(ecf_m, dtype=np.float64)
    return (ecf - ref.ecf) @ enu_basis(ref).T


def utm_epsg(lat_deg: float, lon_deg: float) -> int:
    """EPSG code of the WGS-84 UTM zone holding a point (326zz north, 327zz south); used to read
    GeoTIFFs an earlier sarcli wrote in UTM."""
    zone = int(np.floor((lon_deg + 180.0) / 6.0)) % 60 + 1
    return (32600 if lat_deg >= 0 else 32700) + zone


def plane_reference(scp_ecf, row_ecf, col_ecf):
    """The reference point whose tangent plane is a ground-plane SICD's image plane, and the SCP's
    east / north offset from it.

    :func:`sarcli.io.sicd.write_sicd` writes a grid of the local frame (the tangent plane of the scene-centre
    reference point, :mod:`.georef`): its row and column vectors are that point's cardinal
    directions and the SCP is the grid's centre, metres away from the reference point when the
    grid is off-centre. The plane's unit normal ``n = ±(row × col)`` is the ellipsoid normal of the
    reference point, ``n = (cos φ cos λ, cos φ sin λ, sin φ)`` for geodetic latitude φ and longitude
    λ; its height h puts the point on the plane, ``(P(φ, λ, h) - SCP)·n = 0``, i.e.
    ``h = (SCP - P(φ, λ, 0))·n``.

    Parameters
    ----------
    scp_ecf, row_ecf, col_ecf : array_like (3,)
        ``GeoData/SCP/ECF`` and the ``Grid`` row and column unit vectors (ECF).

    Returns
    -------
    (ReferencePoint, (float, float))
        The reference point and the SCP's (east, north) in its frame, metres.
    """
    scp = np.asarray(scp_ecf, dtype=np.float64)
    n = np.cross(np.asarray(row_ecf, dtype=np.float64), np.asarray(col_ecf, dtype=np.float64))
    n /= np.linalg.norm(n)
    if n @ scp < 0:   # the upward normal
        n = -n
    lat = float(np.degrees(np.arctan2(n[2], np.hypot(n[0], n[1]))))
    lon = float(np.degrees(np.arctan2(n[1], n[0])))
    hae = float((scp - wgs84.geodetic_to_cartesian([lat, lon, 0.0])) @ n)
    ref = ReferencePoint(lat, lon, hae)
    east_north = ecf_to_enu(scp, ref)[:2]
    return ref, (float(east_north[0]), float(east_north[1]))
