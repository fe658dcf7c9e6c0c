"""SIDD export of an image (a detected product, SIDD 3.0.0 NITF, through sarkit).

* Pixels: ``MONO8I``, the 8-bit display values of :func:`sarcli.io.png.display_values` ('db'
  over ``dynamic_range_db``, default, or linear 'magnitude'), north-up (file row 0 the northern
  edge, as GeoTIFF and PNG).
* A plane image (the scene's tangent plane, :mod:`.georef`): ``Measurement/PlaneProjection`` with
  the product plane's row vector south and column vector east of the scene centre, the reference
  point the pixel at the grid's centre, and the sample spacings: exact, like the SICD ground plane.
* A map image on terrain (:func:`sarcli.formers.points.form_map`, pixels on a map CRS at DEM
  heights): ``Measurement/PolynomialProjection``, the map CRS's pixel -> latitude / longitude
  (and back) as cubic polynomials fitted over the grid; the largest fit error (m) is in the file
  (``ProductCreation/ProductCreationExtension[@name='sarcli-fit-error-m']``) and
  ``docs/formats.md``.
* ``Measurement/ARPPoly``, collection time and duration from the collection
  (:func:`sarcli.io.sicd.arp_polynomial`), or the nominal one of
  :func:`sarcli.io.sicd.nominal_acquisition`, said in the file, without it.
"""

from __future__ import annotations

import datetime
import json

import lxml.builder
import numpy as np

from .._util.atomic import atomic_path, open_held
from .._version import __version__
from ..core import geometry
from ..core.types import Image
from ..errors import SarcliInputError
from .georef import enu_to_ecf, reference_point

__all__ = ["write_sidd", "SIDD_NS", "map_polynomials"]

SIDD_NS = "urn:SIDD:3.0.0"
_SI = "urn:SICommon:1.0"
_ISM = "urn:us:gov:ic:ism:13"
#: order of the map image's pixel <-> latitude / longitude polynomials
POLY_ORDER = 3


def _fit2(u, v, values, order=POLY_ORDER):
    """Least-squares coefficients c[i, j] of Σ c_ij u^i v^j (i + j <= order ... all i, j <= order)."""
    cols = [(i, j) for i in range(order + 1) for j in range(order + 1)]
    a = np.stack([u ** i * v ** j for i, j in cols], axis=1)
    sol = np.linalg.lstsq(a, values, rcond=None)[0]
    c = np.zeros((order + 1, order + 1))
    for (i, j), s in zip(cols, sol):
        c[i, j] = s
    return c


def _eval2(c, u, v):
    return np.polynomial.polynomial.polyval2d(u, v, c)


def map_polynomials(img: Image, rows: int, cols: int):
    """The map image's pixel (file row, col) <-> (lat, lon) polynomials and their largest error.

    Returns
    -------
    dict
        ``lat``, ``lon`` (coefficients in row, col), ``row``, ``col`` (in lat, lon) and
        ``error_m``: the largest distance on the ground between a pixel centre's true position
        and the polynomials' (forward), over a grid of test points including the corners.
    """
    from pyproj import Transformer

    epsg = str(img.parameters["map"]["crs"])
    to_ll = Transformer.from_crs(epsg, "EPSG:4326", always_xy=True)
    e0, n_top = float(img.x_m[0]), float(img.y_m[-1])
    dx, dy = float(img.grid.dx), float(img.grid.dy)
    rr, cc = np.meshgrid(np.linspace(0, rows - 1, 17), np.linspace(0, cols - 1, 17), indexing="ij")
    r, c = rr.ravel(), cc.ravel()
    lon, lat = to_ll.transform(e0 + c * dx, n_top - r * dy)
    lat, lon = np.asarray(lat), np.asarray(lon)
    out = {"lat": _fit2(r, c, lat), "lon": _fit2(r, c, lon), "row": _fit2(lat, lon, r), "col": _fit2(lat, lon, c)}
    rt, ct = rr[:-1, :-1].ravel() + 0.5 * (rows - 1) / 16, cc[:-1, :-1].ravel() + 0.5 * (cols - 1) / 16
    lon_t, lat_t = to_ll.transform(e0 + ct * dx, n_top - rt * dy)
    dlat = _eval2(out["lat"], rt, ct) - np.asarray(lat_t)
    dlon = _eval2(out["lon"], rt, ct) - np.asarray(lon_t)
    r_earth = 6371e3
    err = np.hypot(np.radians(dlat) * r_earth, np.radians(dlon) * r_earth * np.cos(np.radians(np.asarray(lat_t))))
    out["error_m"] = float(np.max(err))
    return out


def _poly2(S, C, tag, c):
    n1, n2 = c.shape
    return getattr(S, tag)(*[C.Coef(repr(float(c[i, j])), exponent1=str(i), exponent2=str(j))
                             for i in range(n1) for j in range(n2)], order1=str(n1 - 1), order2=str(n2 - 1))


def _poly1(S, tag, coefs):
    return getattr(S, tag)(*[S.Coef(repr(float(v)), exponent1=str(i)) for i, v in enumerate(coefs)],
                           order1=str(len(coefs) - 1))


def write_sidd(img: Image, path, *, phase_history=None, kind: str = "db", dynamic_range_db: float = 50.0):
    """Write ``img`` as a SIDD 3.0.0 NITF (module docstring).

    Parameters
    ----------
    img : Image
        A plane image, or a map image on terrain.
    path : str or Path
    phase_history : PhaseHistory or Acquisition, optional
        The collection (ARP polynomial, times); nominal without it.
    kind : {'db', 'magnitude'}
    dynamic_range_db : float

    Returns
    -------
    dict
        ``projection`` ('plane' or 'polynomial'), ``nominal``, and for a map image ``error_m``.
    """
    from .png import display_values
    from .arp import arp_polynomial

    if kind not in ("db", "magnitude"):
        raise SarcliInputError(f"SIDD holds a detected picture: kind 'db' or 'magnitude', not {kind!r}")
    acq, nominal, ref, mp = _collection(img, phase_history)
    pixels = np.ascontiguousarray(display_values(img, kind=kind, dynamic_range_db=dynamic_range_db)[::-1])
    x = _SiddXml(img, ref, mp, *pixels.shape)
    t, arp, t_coa, true_times = arp_polynomial(acq, ref)
    info = {"nominal": nominal}
    notes = [f"sarcli {__version__}; image method {img.method or 'unknown'}; {kind} display"]
    if mp is not None:
        info.update(projection="polynomial", error_m=x.fit["error_m"])
        notes.append(f"map image on a DEM in {mp['crs']}: PolynomialProjection fitted to the map CRS, largest error "
                     f"{x.fit['error_m']:.3g} m")
        projection = x.polynomial_projection()
    else:
        info.update(projection="plane")
        projection = x.plane_projection(t_coa)
    if nominal:
        notes.append("NOMINAL collection geometry: the image's phase history was not given")
    if not true_times:
        notes.append("pulse times synthetic: Measurement/ARPPoly times are not those of the collection")
    if ref.is_default:
        notes.append("scene centre at a PLACEHOLDER location (0N 0E)")
    corners = [x.pixel_llh(r, c) for r, c in x.corner_pixels]
    now = datetime.datetime.now(datetime.timezone.utc)
    duration = float(t[-1] - t[0]) if t.size > 1 else 0.0
    root = x.S.SIDD(x.product_creation(notes, kind, now), x.display(kind), x.geo_data(corners),
                    x.measurement(projection, arp, true_times), x.exploitation(acq, duration))
    _write_nitf(path, root.getroottree(), pixels)
    return info


def _collection(img: Image, phase_history):
    """The collection (the given one or a nominal one), whether it is nominal, the reference point
    and the map information of ``img``; what SIDD export cannot do without is an input error."""
    from .geotiff import map_info
    from .sicd import nominal_acquisition

    acq = getattr(phase_history, "acquisition", phase_history)
    nominal = acq is None
    if nominal:
        acq = nominal_acquisition(img.grid)
    elif not acq.has_positions:
        raise SarcliInputError("SIDD export needs antenna positions in the phase history")
    ref = reference_point(img.attrs, img.parameters, getattr(phase_history, "attrs", None))
    mp = map_info(img)
    if ref.is_default and mp is None:
        raise SarcliInputError("SIDD export needs the scene centre's latitude and longitude "
                               "(scene_center_lat_deg / scene_center_lon_deg)")
    return acq, nominal, ref, mp


def _write_nitf(path, tree, pixels) -> None:
    """The NITF of the SIDD ``tree`` and its 8-bit ``pixels``, written whole or not at all."""
    import sarkit.sidd as sksidd

    sec = sksidd.NitfSecurityFields(clas="U")
    meta = sksidd.NitfMetadata(
        file_header_part=sksidd.NitfFileHeaderPart(ostaid="sarcli", security=sec),
        images=[sksidd.NitfProductImageMetadata(
            xmltree=tree, im_subheader_part=sksidd.NitfImSubheaderPart(security=sec),
            de_subheader_part=sksidd.NitfDeSubheaderPart(security=sec))])
    with atomic_path(path) as tmp:
        with open_held(tmp) as f, sksidd.NitfWriter(f, meta) as w:
            w.write_image(0, pixels)


class _SiddXml:
    """The SIDD elements of one image of ``rows`` x ``cols`` file pixels: one method a top-level
    element (or the projection inside ``Measurement``)."""

    def __init__(self, img: Image, ref, mp, rows: int, cols: int):
        self.img, self.ref, self.mp, self.rows, self.cols = img, ref, mp, rows, cols
        self.S = lxml.builder.ElementMaker(namespace=SIDD_NS, nsmap={None: SIDD_NS, "sicommon": _SI, "ism": _ISM})
        self.C = lxml.builder.ElementMaker(namespace=_SI)
        self.fit = map_polynomials(img, rows, cols) if mp is not None else None
        self.corner_pixels = ((0, 0), (0, cols - 1), (rows - 1, cols - 1), (rows - 1, 0))

    def pixel_llh(self, r, c):
        """Geodetic position of a (file row, col) pixel centre."""
        from sarkit import wgs84

        if self.mp is not None:
            lat = _eval2(self.fit["lat"], r, c)
            lon = _eval2(self.fit["lon"], r, c)
            return float(lat), float(lon)
        x = float(self.img.x_m[0]) + c * self.img.grid.dx
        y = float(self.img.y_m[-1]) - r * self.img.grid.dy
        llh = wgs84.cartesian_to_geodetic(enu_to_ecf([x, y, 0.0], self.ref))
        return float(llh[0]), float(llh[1])

    def _reference_point(self, ecf, row, col):
        S, C = self.S, self.C
        return S.ReferencePoint(C.ECEF(C.X(repr(float(ecf[0]))), C.Y(repr(float(ecf[1]))), C.Z(repr(float(ecf[2])))),
                                C.Point(C.Row(repr(row)), C.Col(repr(col))))

    def polynomial_projection(self):
        """A map image's ``PolynomialProjection``: the reference point is the centre pixel at the
        middle of the DEM heights the image was formed at."""
        from sarkit import wgs84

        S, C, mp, fit = self.S, self.C, self.mp, self.fit
        rc_, cc_ = (self.rows - 1) / 2.0, (self.cols - 1) / 2.0
        la_, lo_ = self.pixel_llh(rc_, cc_)
        h_ = 0.5 * (float(mp.get("height_min_m", 0.0)) + float(mp.get("height_max_m", 0.0)))
        ecf = wgs84.geodetic_to_cartesian([la_, lo_, h_])
        return S.PolynomialProjection(
            self._reference_point(ecf, rc_, cc_),
            _poly2(S, C, "RowColToLat", fit["lat"]), _poly2(S, C, "RowColToLon", fit["lon"]),
            _poly2(S, C, "LatLonToRow", fit["row"]), _poly2(S, C, "LatLonToCol", fit["col"]))

    def plane_projection(self, t_coa):
        """A plane image's ``PlaneProjection``: rows south, columns east of the scene centre."""
        from .georef import enu_basis

        S, C, img, grid = self.S, self.C, self.img, self.img.grid
        r0, c0 = (self.rows - 1) // 2, (self.cols - 1) // 2
        ref_enu = np.array([float(img.x_m[0]) + c0 * grid.dx, float(img.y_m[-1]) - r0 * grid.dy, 0.0])
        basis = enu_basis(self.ref)
        ecf = enu_to_ecf(ref_enu, self.ref)
        row_v, col_v = -basis[1], basis[0]
        return S.PlaneProjection(
            self._reference_point(ecf, float(r0), float(c0)),
            S.SampleSpacing(C.Row(repr(float(grid.dy))), C.Col(repr(float(grid.dx)))),
            S.TimeCOAPoly(C.Coef(repr(float(t_coa)), exponent1="0", exponent2="0"), order1="0", order2="0"),
            S.ProductPlane(S.RowUnitVector(*[getattr(C, a)(repr(float(v))) for a, v in zip("XYZ", row_v)]),
                           S.ColUnitVector(*[getattr(C, a)(repr(float(v))) for a, v in zip("XYZ", col_v)])))

    def product_creation(self, notes, kind, now):
        S, img = self.S, self.img
        ext = [S.ProductCreationExtension(n, name=f"sarcli-note-{i}") for i, n in enumerate(notes)]
        ext.append(S.ProductCreationExtension(json.dumps({"method": img.method, "parameters": img.parameters or {}},
                                                         default=str), name="sarcli-image"))
        if self.mp is not None:
            ext.append(S.ProductCreationExtension(repr(self.fit["error_m"]), name="sarcli-fit-error-m"))
        ism = f"{{{_ISM}}}"
        return S.ProductCreation(
            S.ProcessorInformation(S.Application(f"sarcli {__version__}"),
                                   S.ProcessingDateTime(now.strftime("%Y-%m-%dT%H:%M:%S.%fZ")), S.Site("sarcli")),
            S.Classification(**{f"{ism}DESVersion": "13", f"{ism}resourceElement": "true",
                                f"{ism}createDate": now.strftime("%Y-%m-%d"), f"{ism}compliesWith": "USGov",
                                f"{ism}ISMCATCESVersion": "201903", f"{ism}classification": "U",
                                f"{ism}ownerProducer": "USA"}),
            S.ProductName((img.attrs or {}).get("source_name") or img.method or "sarcli image"),
            S.ProductClass("Detected Image"),
            *ext,
        )

    def display(self, kind):
        S = self.S
        return S.Display(
            S.PixelType("MONO8I"), S.NumBands("1"),
            S.NonInteractiveProcessing(
                S.ProductGenerationOptions(S.DataRemapping(S.LUTName("sarcli-" + kind), S.Predefined(
                    S.DatabaseName("DENSITY" if kind == "db" else "LINEAR")))),
                S.RRDS(S.DownsamplingMethod("DECIMATE")), band="1"),
            S.InteractiveProcessing(
                S.GeometricTransform(S.Scaling(S.AntiAlias(S.FilterName("none"), S.FilterBank(S.Predefined(
                    S.DatabaseName("BILINEAR"))), S.Operation("CONVOLUTION")), S.Interpolation(
                    S.FilterName("none"), S.FilterBank(S.Predefined(S.DatabaseName("BILINEAR"))),
                    S.Operation("CORRELATION"))), S.Orientation(S.ShadowDirection("ARBITRARY"))),
                S.SharpnessEnhancement(S.ModularTransferFunctionCompensation(S.FilterName("none"), S.FilterBank(
                    S.Predefined(S.DatabaseName("BILINEAR"))), S.Operation("CONVOLUTION"))),
                S.DynamicRangeAdjustment(S.AlgorithmType("NONE"), S.BandStatsSource("1")), band="1"),
        )

    def geo_data(self, corners):
        S, C = self.S, self.C
        return S.GeoData(
            S.EarthModel("WGS_84"),
            S.ImageCorners(*[S.ICP(C.Lat(repr(la)), C.Lon(repr(lo)), index=i)
                             for (la, lo), i in zip(corners, ("1:FRFC", "2:FRLC", "3:LRLC", "4:LRFC"))]),
            S.ValidData(*[S.Vertex(C.Lat(repr(la)), C.Lon(repr(lo)), index=str(k + 1))
                          for k, (la, lo) in enumerate(corners)], size="4"),
        )

    def measurement(self, projection, arp, true_times):
        S, C = self.S, self.C
        return S.Measurement(
            projection,
            S.PixelFootprint(C.Row(str(self.rows)), C.Col(str(self.cols))),
            S.ARPFlag("REALTIME" if true_times else "PREDICTED"),
            S.ARPPoly(*[_poly1(C, ax, arp[i]) for i, ax in enumerate("XYZ")]),
            S.ValidData(*[S.Vertex(C.Row(str(r)), C.Col(str(c)), index=str(k + 1))
                          for k, (r, c) in enumerate(self.corner_pixels)], size="4"),
        )

    def exploitation(self, acq, duration):
        """``ExploitationFeatures``: ground range and cross-range resolution along the product's
        rows (north-south) or columns (east-west), whichever is nearer the look direction."""
        S, C, attrs = self.S, self.C, self.img.attrs or {}
        rho_r, rho_cr = (float(v) for v in geometry.resolutions(acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad))
        theta = float(np.angle(np.mean(np.exp(1j * acq.azimuth_rad))))
        res_row, res_col = (rho_cr, rho_r) if abs(np.cos(theta)) >= abs(np.sin(theta)) else (rho_r, rho_cr)
        pol = str(attrs.get("polarization", "")).upper()
        tx, rcv = (pol[0], pol[1]) if len(pol) == 2 and set(pol) <= set("HV") else ("UNKNOWN", "UNKNOWN")
        start = str(attrs.get("collection_start") or "2000-01-01T00:00:00.000000Z")
        return S.ExploitationFeatures(
            S.Collection(S.Information(S.SensorName("sarcli"), S.RadarMode(C.ModeType("SPOTLIGHT")),
                                       S.CollectionDateTime(start), S.CollectionDuration(repr(duration)),
                                       S.Resolution(C.Range(repr(rho_r)), C.Azimuth(repr(rho_cr)))),
                         identifier=attrs.get("source_name") or "sarcli"),
            S.Product(S.Resolution(C.Row(repr(res_row)), C.Col(repr(res_col))),
                      S.Ellipticity(repr(max(res_row, res_col) / min(res_row, res_col))),
                      S.Polarization(S.TxPolarizationProc(tx), S.RcvPolarizationProc(rcv))),
        )
