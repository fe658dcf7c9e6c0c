"""SICD (NGA.STND.0024, version 1.4.0) export of a complex image, through sarkit (NITF container).

Mapping (``docs/formats.md`` has the table):

* Image plane = ground plane (``Grid/ImagePlane = GROUND``, ``Grid/Type = PLANE``), uniformly
  sampled at our pixel spacing. The SICD row direction is the cardinal ground direction (south,
  north, east or west) closest to the look direction at the centre of the aperture, so that
  shadows fall "down" the image as SICD requires; the column direction is ``up × row``. For the
  common case of an antenna north of the scene the row direction is ``-y`` (south) and the column
  direction ``+x`` (east): SICD row 0 is the northern edge, i.e. our array flipped north-up.
  :func:`sicd_orientation` returns the chosen axes and the array transform.
* SCP = the grid's centre pixel ``(cx, cy, 0)`` in our local ENU frame, whose origin is put on the
  Earth at ``scene_center_lat_deg`` / ``scene_center_lon_deg`` (image attrs or parameters, else the
  phase history's attrs) or, failing those, at the placeholder 0° N 0° E (stated in
  ``CollectionInfo/Parameter[@name='sarcli']``).
* Spatial-frequency support (``Grid/Row|Col``): the k-space samples ``k ξ_θ / 2π`` (cycles/m) of
  the collection, projected on the row / column directions: ``KCtr`` at the centre of their extent,
  ``ImpRespBW`` the extent (at most ``1/SS``), ``DeltaK1/2 = ∓ ImpRespBW / 2``, ``Sgn = -1``
  (our matched filter synthesises with ``exp(+i k ξ·x)``; docs/conventions.md eq. ``mf``).
* Collection geometry (``Position/ARPPoly``, ``Timeline``, ``SCPCOA``) from the phase history's
  antenna positions, timed as in :mod:`sarcli.io.cphd` (synthetic times at a nominal platform speed);
  ``SCPCOA`` is computed by sarkit. Without a phase history a NOMINAL collection is written
  (10 GHz, 30° elevation, 10 km, looking south, band and aperture matched to the pixel size at an
  oversampling of 1.5) and stated in the file.
"""

from __future__ import annotations

import datetime
import json
import math

import lxml.builder
import lxml.etree
import numpy as np

from ..core import geometry
from .._util.atomic import atomic_path, open_held
from .._version import __version__
from ..core.acquisition import Acquisition
from ..errors import SarcliInputError
from ..core.types import Image
from .arp import arp_polynomial
from .georef import enu_basis, enu_to_ecf, plane_reference, reference_point

__all__ = ["write_sicd", "read_sicd", "sicd_orientation", "nominal_acquisition", "arp_polynomial", "SICD_NS"]

SICD_NS = "urn:SICD:1.4.0"
_UP = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------------------------
# orientation
# --------------------------------------------------------------------------------------------
#: ``CollectionInfo/Parameter`` holding the sarcli image's method, runtime and parameters (JSON).
IMAGE_PARAMETER = "sarcli-image"


def _image_metadata(xml) -> tuple[str, float, dict]:
    """``(method, runtime_s, parameters)`` of a SICD: from sarcli's own parameter when present;
    otherwise the method from ``ImageFormation/Processing/Type`` ("sarcli <method>") or
    ``ImageFormAlgo`` (another tool's file), the run time unknown (NaN)."""
    for node in xml.findall("{*}CollectionInfo/{*}Parameter"):
        if node.get("name") == IMAGE_PARAMETER:
            try:
                meta = json.loads(node.text or "")
                return (str(meta.get("method") or "sicd"), float(meta.get("runtime_s", math.nan)),
                        dict(meta.get("parameters") or {}))
            except (TypeError, ValueError, AttributeError):
                break
    ptype = str(xml.findtext("{*}ImageFormation/{*}Processing/{*}Type") or "")
    if ptype.startswith("sarcli "):
        return ptype.split(" ", 1)[1], math.nan, {}
    algo = str(xml.findtext("{*}ImageFormation/{*}ImageFormAlgo") or "").strip()
    return (algo.lower() or "sicd"), math.nan, {}


def sicd_orientation(image: np.ndarray, look_azimuth_rad: float, grid):
    """Re-index our ``[y, x]`` image into SICD ``[row, col]`` for a look azimuth.

    Parameters
    ----------
    image : ndarray (ny, nx)
    look_azimuth_rad : float
        Look azimuth θ at the aperture centre (direction antenna → scene, docs/conventions.md).
    grid : Grid

    Returns
    -------
    dict
        ``array`` (SICD order), ``row_enu`` / ``col_enu`` (unit vectors), ``row_ss`` / ``col_ss``
        (m), ``scp_pixel`` (row, col of our centre pixel ``(ny//2, nx//2)`` in the SICD array),
        ``name`` of the row direction ('south', 'north', 'east', 'west').
    """
    xi = np.array([np.cos(look_azimuth_rad), np.sin(look_azimuth_rad), 0.0])
    candidates = {
        "south": (np.array([0.0, -1.0, 0.0]), lambda a: a[::-1, :], grid.dy, grid.dx),
        "north": (np.array([0.0, 1.0, 0.0]), lambda a: a[:, ::-1], grid.dy, grid.dx),
        "east": (np.array([1.0, 0.0, 0.0]), lambda a: a.T, grid.dx, grid.dy),
        "west": (np.array([-1.0, 0.0, 0.0]), lambda a: a.T[::-1, ::-1], grid.dx, grid.dy),
    }
    name = max(candidates, key=lambda k: float(candidates[k][0] @ xi))
    row, transform, row_ss, col_ss = candidates[name]
    col = np.cross(_UP, row)
    marker = np.zeros(grid.shape, dtype=bool)
    marker[grid.ny // 2, grid.nx // 2] = True
    r, c = np.argwhere(transform(marker))[0]
    return {"array": np.ascontiguousarray(transform(np.asarray(image))), "row_enu": row,
            "col_enu": col, "row_ss": float(row_ss), "col_ss": float(col_ss),
            "scp_pixel": (int(r), int(c)), "name": name}


def nominal_acquisition(grid) -> Acquisition:
    """The NOMINAL collection written when an image comes without its phase history.

    10 GHz centre, 30° elevation, 10 km range, looking south (antenna north of the scene: SICD rows
    run south, the array is our image flipped north-up), with
    bandwidth and aperture whose resolution is 1.5 pixels (SICD's preferred oversampling).
    """
    el = np.radians(30.0)
    fc = 10e9
    h = max(grid.dx, grid.dy)
    bw = geometry.C / (2 * 1.5 * h * np.cos(el))  # ρ_r = c / (2 B cos φ) = 1.5 h
    theta = 2 * np.arcsin(min(geometry.C / (4 * fc * np.cos(el) * 1.5 * h), 1.0))
    freq = np.linspace(fc - bw / 2, fc + bw / 2, 64)
    az = -np.pi / 2 + np.linspace(-theta / 2, theta / 2, 64)
    pos = geometry.antenna_positions_circle(az, np.full(az.size, el), 10e3)
    return Acquisition(freq, az, np.full(az.size, el), grid, antenna_position_m=pos,
                       model="spherical", name="nominal")


def _ipr_factor(parameters: dict) -> tuple[str, float]:
    """(WindowName, -3 dB width × bandwidth) of the weighting recorded in the image parameters.

    The window is the one :func:`sarcli.formers.formation.form_image` records (``window``,
    ``taylor_nbar``, ``taylor_sll_db``); its IRW factor comes from
    :func:`sarcli.core.windows.irw_factor` (uniform: ``IRW_FACTOR_UNIFORM`` = 0.8859).
    """
    from ..core.windows import IRW_FACTOR_UNIFORM, TAYLOR_NBAR, TAYLOR_SLL_DB, WINDOW_KINDS, irw_factor

    par = parameters or {}
    kind = par.get("window") or "none"
    if kind in ("none", "uniform"):
        return "UNIFORM", IRW_FACTOR_UNIFORM
    if kind not in WINDOW_KINDS:
        return str(kind).upper(), IRW_FACTOR_UNIFORM
    factor = irw_factor(kind, nbar=int(par.get("taylor_nbar", TAYLOR_NBAR)),
                        sll_db=float(par.get("taylor_sll_db", TAYLOR_SLL_DB)))
    return str(kind).upper(), float(factor)


# --------------------------------------------------------------------------------------------
# XML
# --------------------------------------------------------------------------------------------
def _xyz(E, tag, v):
    return getattr(E, tag)(E.X(repr(float(v[0]))), E.Y(repr(float(v[1]))), E.Z(repr(float(v[2]))))


def _poly1(E, tag, coefs):
    return getattr(E, tag)(*[E.Coef(repr(float(c)), exponent1=str(i)) for i, c in enumerate(coefs)],
                           order1=str(len(coefs) - 1))


def _poly2_const(E, tag, value):
    return getattr(E, tag)(E.Coef(repr(float(value)), exponent1="0", exponent2="0"), order1="0", order2="0")


def _support(acq: Acquisition, direction_enu):
    """Centre and extent (cycles/m) of the k-space samples projected on a ground direction."""
    kx, ky = acq.kspace()
    proj = (kx * direction_enu[0] + ky * direction_enu[1]) / (2 * np.pi)
    lo, hi = float(proj.min()), float(proj.max())
    return 0.5 * (lo + hi), hi - lo


def _grid_dim(E, tag, uvect_ecf, ss, kctr, extent, parameters):
    bw = min(extent, 1.0 / ss)
    win_name, factor = _ipr_factor(parameters)
    children = [
        _xyz(E, "UVectECF", uvect_ecf),
        E.SS(repr(ss)),
        E.ImpRespWid(repr(factor / bw)),
        E.Sgn("-1"),
        E.ImpRespBW(repr(bw)),
        E.KCtr(repr(kctr)),
        E.DeltaK1(repr(-bw / 2)),
        E.DeltaK2(repr(bw / 2)),
        _poly2_const(E, "DeltaKCOAPoly", 0.0),
        E.WgtType(E.WindowName(win_name)),
    ]
    return getattr(E, tag)(*children)


def _build_xml(img: Image, acq: Acquisition, ref, orient, *, nominal: bool, ph_attrs=None):
    E = lxml.builder.ElementMaker(namespace=SICD_NS, nsmap={None: SICD_NS})
    ph_attrs = ph_attrs or {}
    arr = orient["array"]
    nrows, ncols = arr.shape
    srow, scol = orient["scp_pixel"]
    scp_ecf, scp_llh, corners = _scp_and_corners(img.grid, ref, orient)
    basis = enu_basis(ref)
    row_ecf = orient["row_enu"] @ basis
    col_ecf = orient["col_enu"] @ basis
    # timing and ARP polynomial
    t, arp, t_coa, true_times = arp_polynomial(acq, ref)
    P = t.size
    duration = float(t[-1] + (t[1] - t[0]) if not true_times else t[-1] + (t[-1] - t[-2]))
    kctr_r, ext_r = _support(acq, orient["row_enu"])
    kctr_c, ext_c = _support(acq, orient["col_enu"])
    params = img.parameters or {}
    pol = str((img.attrs or {}).get("polarization", ph_attrs.get("polarization", ""))).upper()
    txrcv = f"{pol[0]}:{pol[1]}" if len(pol) == 2 and set(pol) <= set("HV") else "UNKNOWN"
    notes = _notes(img, acq, ref, orient, nominal, ph_attrs, true_times)
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    start = str((img.attrs or {}).get("collection_start") or ph_attrs.get("collection_start")
                or "2000-01-01T00:00:00.000000Z")

    def pt(tag, llh, **kw):
        return getattr(E, tag)(E.Lat(repr(float(llh[0]))), E.Lon(repr(float(llh[1]))), **kw)

    return E.SICD(
        E.CollectionInfo(
            E.CollectorName((str(ph_attrs.get("collector_name") or "") or "sarcli")[:60]),
            E.CoreName((acq.name or img.method or "sarcli-image")[:60]),
            E.CollectType("MONOSTATIC"),
            E.RadarMode(E.ModeType("SPOTLIGHT")),
            E.Classification("UNCLASSIFIED"),
            *[E.Parameter(n, name="sarcli" if i == 0 else f"sarcli-note-{i}") for i, n in enumerate(notes)],
            E.Parameter(json.dumps({"method": img.method, "runtime_s": float(img.runtime_s),
                                    "parameters": params}, default=str), name=IMAGE_PARAMETER),
        ),
        E.ImageCreation(E.Application(f"sarcli {__version__}"), E.DateTime(now)),
        E.ImageData(
            E.PixelType("RE32F_IM32F"),
            E.NumRows(str(nrows)), E.NumCols(str(ncols)),
            E.FirstRow("0"), E.FirstCol("0"),
            E.FullImage(E.NumRows(str(nrows)), E.NumCols(str(ncols))),
            E.SCPPixel(E.Row(str(srow)), E.Col(str(scol))),
        ),
        E.GeoData(
            E.EarthModel("WGS_84"),
            E.SCP(_xyz(E, "ECF", scp_ecf),
                  E.LLH(E.Lat(repr(float(scp_llh[0]))), E.Lon(repr(float(scp_llh[1]))),
                        E.HAE(repr(float(scp_llh[2]))))),
            E.ImageCorners(*[pt("ICP", c, index=i) for c, i in
                             zip(corners, ("1:FRFC", "2:FRLC", "3:LRLC", "4:LRFC"))]),
        ),
        E.Grid(
            E.ImagePlane("GROUND"),
            E.Type("PLANE"),
            _poly2_const(E, "TimeCOAPoly", t_coa),
            _grid_dim(E, "Row", row_ecf, orient["row_ss"], kctr_r, ext_r, params),
            _grid_dim(E, "Col", col_ecf, orient["col_ss"], kctr_c, ext_c, params),
        ),
        E.Timeline(
            E.CollectStart(start),
            E.CollectDuration(repr(duration)),
            E.IPP(E.Set(E.TStart("0.0"), E.TEnd(repr(duration)), E.IPPStart("0"), E.IPPEnd(str(P - 1)),
                        _poly1(E, "IPPPoly", [0.0, P / duration]), index="1"), size="1"),
        ),
        E.Position(E.ARPPoly(*[_poly1(E, ax, arp[i]) for i, ax in enumerate("XYZ")])),
        *_formation(E, img, acq.frequency_hz, t, txrcv),
    )


def _scp_and_corners(grid, ref, orient):
    """The SCP (ECF and geodetic) and the image corners (FRFC, FRLC, LRLC, LRFC, geodetic) in the
    ground plane through it."""
    from sarkit import wgs84

    nrows, ncols = orient["array"].shape
    srow, scol = orient["scp_pixel"]
    scp_enu = np.array([grid.cx, grid.cy, 0.0])
    scp_ecf = enu_to_ecf(scp_enu, ref)
    scp_llh = wgs84.cartesian_to_geodetic(scp_ecf)
    corners = []
    for r, c in ((0, 0), (0, ncols - 1), (nrows - 1, ncols - 1), (nrows - 1, 0)):
        enu = (scp_enu + (r - srow) * orient["row_ss"] * orient["row_enu"]
               + (c - scol) * orient["col_ss"] * orient["col_enu"])
        corners.append(wgs84.cartesian_to_geodetic(enu_to_ecf(enu, ref)))
    return scp_ecf, scp_llh, corners


def _notes(img: Image, acq: Acquisition, ref, orient, nominal: bool, ph_attrs: dict, true_times: bool) -> list:
    """The file's notes (``CollectionInfo/Parameter``): what wrote it, and what in it is nominal."""
    notes = [f"sarcli {__version__}; image method {img.method or 'unknown'}",
             f"ground-plane image, SICD rows run {orient['name']}"]
    if ref.is_default:
        notes.append("scene centre at a PLACEHOLDER location (0N 0E): no scene_center_lat_deg/lon_deg given")
    if nominal:
        notes.append("NOMINAL collection geometry: the image's phase history was not given")
    if acq.is_bistatic and str(ph_attrs.get("collect_type", "")).upper() == "BISTATIC":
        notes.append("BISTATIC collection written with the transmit/receive midpoint as ARP (approximate SCPCOA)")
    if not true_times:
        notes.append("pulse times synthetic (the phase history carries none): platform speed "
                     "nominal, Timeline and SCPCOA times not those of the collection")
    return notes


def _formation(E, img: Image, f, t, txrcv: str):
    """``RadarCollection`` and ``ImageFormation`` (frequencies ``f``, pulse times ``t``)."""
    fmin, fmax = float(f.min()), float(f.max())
    tx_pol = txrcv[0] if txrcv != "UNKNOWN" else "UNKNOWN"
    return (
        E.RadarCollection(
            E.TxFrequency(E.Min(repr(fmin)), E.Max(repr(fmax))),
            E.TxPolarization(tx_pol),
            E.RcvChannels(E.ChanParameters(E.TxRcvPolarization(txrcv), index="1"), size="1"),
        ),
        E.ImageFormation(
            E.RcvChanProc(E.NumChanProc("1"), E.ChanIndex("1")),
            E.TxRcvPolarizationProc(txrcv),
            E.TStartProc(repr(float(t[0]))),
            E.TEndProc(repr(float(t[-1]))),
            E.TxFrequencyProc(E.MinProc(repr(fmin)), E.MaxProc(repr(fmax))),
            E.ImageFormAlgo("OTHER"),
            E.STBeamComp("NO"), E.ImageBeamComp("NO"), E.AzAutofocus("NO"), E.RgAutofocus("NO"),
            E.Processing(E.Type(f"sarcli {img.method or 'image formation'}"), E.Applied("true")),
        ),
    )


def write_sicd(img: Image, path, *, phase_history=None):
    """Write a complex image as a SICD 1.4.0 NITF file.

    Parameters
    ----------
    img : Image
    path : str or Path
    phase_history : PhaseHistory or Acquisition, optional
        The collection the image was formed from: antenna positions (required in it) and
        frequencies give ``Position``, ``Timeline``, ``SCPCOA`` and the ``Grid`` support.
        Without it a nominal collection is written (see :func:`nominal_acquisition`).

    Returns
    -------
    dict
        The orientation used (see :func:`sicd_orientation`), without the array.
    """
    import sarkit.sicd as sksicd

    acq = getattr(phase_history, "acquisition", phase_history)
    ph_attrs = getattr(phase_history, "attrs", None)
    nominal = acq is None
    if nominal:
        acq = nominal_acquisition(img.grid)
    elif not acq.has_positions:
        raise SarcliInputError("SICD export needs antenna positions in the phase history "
                               "(a far-field-only collection has no flight path)")
    ref = reference_point(img.attrs, img.parameters, ph_attrs)
    theta_c = float(np.angle(np.mean(np.exp(1j * acq.azimuth_rad))))
    orient = sicd_orientation(np.asarray(img.image).astype(np.complex64), theta_c, img.grid)
    root = _build_xml(img, acq, ref, orient, nominal=nominal, ph_attrs=ph_attrs)
    tree = root.getroottree()
    root.insert(root.index(root.find(f"{{{SICD_NS}}}ImageFormation")) + 1, sksicd.compute_scp_coa(tree))
    sec = sksicd.NitfSecurityFields(clas="U")
    meta = sksicd.NitfMetadata(
        xmltree=tree,
        file_header_part=sksicd.NitfFileHeaderPart(ostaid="sarcli", security=sec),
        im_subheader_part=sksicd.NitfImSubheaderPart(isorce="sarcli", security=sec),
        de_subheader_part=sksicd.NitfDeSubheaderPart(security=sec),
    )
    with atomic_path(path) as tmp:
        with open_held(tmp) as f, sksicd.NitfWriter(f, meta) as w:
            w.write_image(orient["array"])
    out = {k: v for k, v in orient.items() if k != "array"}
    out["reference"] = ref
    out["nominal"] = nominal
    return out

# --------------------------------------------------------------------------------------------
# reading back (our own ground-plane SICDs)
# --------------------------------------------------------------------------------------------
_INVERSE = {  # row direction name -> SICD array back to our [y, x] order
    "south": lambda a: a[::-1, :],
    "north": lambda a: a[:, ::-1],
    "east": lambda a: a.T,
    "west": lambda a: a[::-1, ::-1].T,
}


def read_sicd(path) -> Image:
    """Read a ground-plane SICD whose rows run along a cardinal direction (as :func:`write_sicd` writes).

    The pixels are put back in our ``[y, x]`` order (row 0 south). The local origin is the point
    whose tangent plane is the image plane (:func:`.georef.plane_reference`; its latitude / longitude /
    height go to ``attrs``), so a grid :func:`write_sicd` wrote off-centre comes back with the
    coordinates and the scene centre it had.

    Raises
    ------
    InputFileError
        Missing, truncated or foreign file, or a SICD in a slant or rotated plane.
    """
    from pathlib import Path

    from ..errors import InputFileError

    p = Path(path)
    if not p.is_file():
        raise InputFileError(path, "no such file (expected a SICD NITF file)")
    try:
        return _read_sicd(p)
    except InputFileError:
        raise
    except Exception as exc:  # noqa: BLE001 - jbpy/lxml/numpy raise many kinds on a broken file
        msg = str(exc).splitlines()[0][:100] if str(exc) else ""
        raise InputFileError(path, f"truncated or corrupt SICD file ({type(exc).__name__}: {msg})") from None


def _read_sicd(p) -> Image:
    import sarkit.sicd as sksicd

    from ..errors import InputFileError

    with open(p, "rb") as f:
        if f.read(4) != b"NITF":
            raise InputFileError(p, "not a NITF file (SICD is stored in NITF 2.1)")
        f.seek(0)
        with sksicd.NitfReader(f) as r:
            xml = r.metadata.xmltree
            nrows = int(xml.findtext("{*}ImageData/{*}NumRows"))
            ncols = int(xml.findtext("{*}ImageData/{*}NumCols"))
            first = r.jbp["ImageSegments"][0]["Data"]
            need = first.get_offset() + nrows * ncols * 8
            size = p.stat().st_size
            if size < need:
                raise InputFileError(p, f"truncated SICD file: {size} bytes, the image needs {need}")
            arr = r.read_image()
    xh = sksicd.XmlHelper(xml)
    if xml.findtext("{*}Grid/{*}ImagePlane") != "GROUND":
        raise InputFileError(p, "only ground-plane SICD images can be read into a sarcli image "
                                f"(ImagePlane is {xml.findtext('{*}Grid/{*}ImagePlane')})")
    row_ecf, col_ecf = xh.load("{*}Grid/{*}Row/{*}UVectECF"), xh.load("{*}Grid/{*}Col/{*}UVectECF")
    ref, (cx, cy) = plane_reference(xh.load("{*}GeoData/{*}SCP/{*}ECF"), row_ecf, col_ecf)
    basis = enu_basis(ref)
    row = basis @ row_ecf
    names = {"south": (0, -1, 0), "north": (0, 1, 0), "east": (1, 0, 0), "west": (-1, 0, 0)}
    name = next((n for n, v in names.items() if np.allclose(row, v, atol=1e-6)), None)
    if name is None:
        raise InputFileError(p, "SICD rows do not run along a cardinal ground direction; "
                                "only sarcli's ground-plane layout can be read")
    img = np.asarray(_INVERSE[name](arr))
    srow, scol = xh.load("{*}ImageData/{*}SCPPixel")
    marker = np.zeros(arr.shape, dtype=bool)
    marker[int(srow), int(scol)] = True
    r0, c0 = np.argwhere(_INVERSE[name](marker))[0]
    row_ss, col_ss = float(xh.load("{*}Grid/{*}Row/{*}SS")), float(xh.load("{*}Grid/{*}Col/{*}SS"))
    dx, dy = (col_ss, row_ss) if name in ("south", "north") else (row_ss, col_ss)
    ny, nx = img.shape
    x = cx + (np.arange(nx) - c0) * dx
    y = cy + (np.arange(ny) - r0) * dy
    attrs = {**ref.as_attrs(), "source_format": "SICD",
             "sicd_version": lxml.etree.QName(xml.getroot()).namespace}
    method, runtime, params = _image_metadata(xml)
    core = xml.findtext("{*}CollectionInfo/{*}CoreName")
    if core:
        attrs["collection_name"] = str(core)
    return Image(image=np.ascontiguousarray(img).astype(np.complex64), x_m=x, y_m=y,
                 method=method, parameters=params, runtime_s=runtime, attrs=attrs)
