"""CPHD (NGA.STND.0068, version 1.1.0) in and out, through sarkit.

Mapping (``docs/formats.md`` has the table):

* One channel, FX domain, ``SGN = -1``: a scatterer whose time of arrival exceeds the SRP's by
  ``ΔTOA = 2 (|a - x| - |a - SRP|) / c`` contributes ``exp(-i 2π f ΔTOA)``, which is our
  spherical model ``exp(-i (4π α / c)(|a_p - x| - r0_p))`` with ``r0_p = |a_p - SRP_p|``.
* Vector p = pulse p: ``TxPos = RcvPos = a_p`` (monostatic, stop-and-hop) or, when the phase
  history has separate transmit and receive positions, ``TxPos = t_p``, ``RcvPos = q_p`` (the
  platform moves while the echo travels, or a ``BISTATIC`` collection: attr ``collect_type``);
  reading keeps them (CONVENTIONS.md two-way model, ``r0_p = (|t_p - SRP| + |q_p - SRP|)/2``);
  ``SRPPos`` = the scene
  centre, ``SC0``/``SCSS`` = first frequency and spacing (``FX1``/``FX2`` the band edges), so the
  frequencies of every pulse must be equally spaced
  (:func:`sarcli.core.sampling.equally_spaced`). A phase history whose ``r0_p`` differs from ``|a_p|``
  (motion-compensated data) has the phase ``exp(+i (4π α/c)(|a_p| - r0_p))`` folded into
  the signal so that the file is referenced to the SRP, as CPHD requires.
* Signal format ``CF8`` (complex64; CPHD has no complex128 format, so complex128 data is rounded).
* Our local ENU frame (x east, y north, z up, origin at the scene centre) is anchored on the Earth
  at ``scene_center_lat_deg`` / ``scene_center_lon_deg`` (/ ``scene_center_height_m``) from the
  phase history's attrs, or at the placeholder :data:`sarcli.io.georef.DEFAULT_REFERENCE`
  (0° N, 0° E, 0 m; written into the file's ``CollectionID/CoreName`` note). The conversion is
  :func:`sarcli.io.georef.enu_to_ecf`. The planar image area is spanned by East (IAX) and
  North (IAY), so image-area coordinates equal our x, y; ``SceneCoordinates/ImageGrid`` holds our grid.
* Times are synthetic (CPHD needs them, our files have none): pulses are spaced so the platform
  moves at :data:`NOMINAL_SPEED_M_S`; velocities are finite differences of the positions.

Public API
----------
read_cphd(path, lazy=False) -> PhaseHistory
write_cphd(ph, path) -> Path
"""

from __future__ import annotations

from pathlib import Path

import lxml.builder
import lxml.etree
import numpy as np

from ..core import geometry, sampling
from .._util.atomic import atomic_path
from .._version import __version__
from ..core.acquisition import Acquisition
from ..errors import InputFileError, SarcliInputError
from ._cphd_parts import AXES_TOLERANCE_RAD, READ_BLOCK  # noqa: F401  (re-exported)
from ._cphd_parts import grid_from_xml as _grid_from_xml
from ._cphd_parts import read_signal_blocks as _read_signal_blocks
from .georef import ReferencePoint, ecf_to_enu, enu_basis, enu_to_ecf, reference_point
from ..core.types import PhaseHistory

__all__ = ["read_cphd", "write_cphd", "pulse_times", "NOMINAL_SPEED_M_S", "CPHD_NS"]

CPHD_NS = "http://api.nsgreg.nga.mil/schema/cphd/1.1.0"
#: Platform speed (m/s) used to invent pulse times for files that carry none.
NOMINAL_SPEED_M_S = 100.0
#: CollectionStart written when the phase history gives none (attr ``collection_start``).
PLACEHOLDER_START = "2000-01-01T00:00:00.000000Z"
CHANNEL_ID = "1"
_FX_OSR = 1.2

# PVP layout: name, words (8-byte), format
_PVP_LAYOUT = [
    ("TxTime", 1, "F8"), ("TxPos", 3, "X=F8;Y=F8;Z=F8;"), ("TxVel", 3, "X=F8;Y=F8;Z=F8;"),
    ("RcvTime", 1, "F8"), ("RcvPos", 3, "X=F8;Y=F8;Z=F8;"), ("RcvVel", 3, "X=F8;Y=F8;Z=F8;"),
    ("SRPPos", 3, "X=F8;Y=F8;Z=F8;"), ("aFDOP", 1, "F8"), ("aFRR1", 1, "F8"), ("aFRR2", 1, "F8"),
    ("FX1", 1, "F8"), ("FX2", 1, "F8"), ("TOA1", 1, "F8"), ("TOA2", 1, "F8"),
    ("TDTropoSRP", 1, "F8"), ("SC0", 1, "F8"), ("SCSS", 1, "F8"), ("SIGNAL", 1, "I8"),
]


# --------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------
def _uniform_frequencies(freq_pm: np.ndarray):
    """First frequency ``SC0`` and spacing ``SCSS`` per pulse: the least-squares line of
    :func:`sarcli.core.sampling.equally_spaced` (SarcliInputError unless equally spaced and
    increasing), which bounds the phase error of replacing the frequencies by ``SC0 + n SCSS``."""
    f = np.asarray(freq_pm, dtype=np.float64)
    ref, scss = sampling.equally_spaced(f, "CPHD export", remedy="CPHD stores SC0 + n SCSS per pulse",
                                        increasing=True)
    return ref - scss * (f.shape[-1] // 2), scss


def pulse_times(pos: np.ndarray):
    """Synthetic transmit times (s) and velocities (m/s) from positions at NOMINAL_SPEED_M_S."""
    P = pos.shape[0]
    if P < 2:
        return np.zeros(1), np.array([[NOMINAL_SPEED_M_S, 0.0, 0.0]])
    step = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    med = float(np.median(step))
    dt = med / NOMINAL_SPEED_M_S if med > 0 else 1e-3
    t = np.arange(P) * dt
    vel = np.gradient(pos, t, axis=0)
    if not np.all(np.linalg.norm(vel, axis=1) > 0):
        vel = vel + np.array([1e-3, 0.0, 0.0])  # a hovering antenna: CPHD needs a direction
    return t, vel


def _xyz(E, tag, v):
    return getattr(E, tag)(E.X(repr(float(v[0]))), E.Y(repr(float(v[1]))), E.Z(repr(float(v[2]))))


def _xy(E, tag, x, y):
    return getattr(E, tag)(E.X(repr(float(x))), E.Y(repr(float(y))))


def _pvp_dtype():
    import sarkit.cphd as skcphd

    names, formats, offsets, off = [], [], [], 0
    for name, words, fmt in _PVP_LAYOUT:
        names.append(name)
        formats.append(skcphd.binary_format_string_to_dtype(fmt))
        offsets.append(8 * off)
        off += words
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": 8 * off})


def _build_xml(ph: PhaseHistory, ref: ReferencePoint, pvp: np.ndarray, signal_format: str):
    """The CPHD XML (without ReferenceGeometry) for a phase history and its PVPs."""
    from sarkit import wgs84

    E = lxml.builder.ElementMaker(namespace=CPHD_NS, nsmap={None: CPHD_NS})
    acq = ph.acquisition
    P, M = ph.data.shape
    grid = acq.grid
    fx1, fx2 = pvp["FX1"], pvp["FX2"]
    x_lo, x_hi = grid.x[0] - grid.dx / 2, grid.x[-1] + grid.dx / 2
    y_lo, y_hi = grid.y[0] - grid.dy / 2, grid.y[-1] + grid.dy / 2
    corners_enu = np.array([[x_lo, y_lo, 0], [x_lo, y_hi, 0], [x_hi, y_hi, 0], [x_hi, y_lo, 0]], float)
    corners_llh = wgs84.cartesian_to_geodetic(enu_to_ecf(corners_enu, ref))
    basis = enu_basis(ref)
    fixed_fx = bool(np.all(fx1 == fx1[0]) and np.all(fx2 == fx2[0]) and np.all(pvp["SCSS"] == pvp["SCSS"][0]))
    fixed_toa = bool(np.all(pvp["TOA1"] == pvp["TOA1"][0]) and np.all(pvp["TOA2"] == pvp["TOA2"][0]))
    fixed_srp = bool(np.all(pvp["SRPPos"] == pvp["SRPPos"][0]))
    t0, t1 = float(pvp["TxTime"][0]), float(pvp["TxTime"][-1])
    # dwell in reference time: when each pulse meets the SRP (TxTime + |Tx - SRP| / c); at
    # spaceborne ranges that differs from TxTime by milliseconds
    tref = pvp["TxTime"] + np.linalg.norm(pvp["TxPos"] - pvp["SRPPos"], axis=1) / geometry.C
    r0_t, r1_t = float(tref.min()), float(tref.max())
    toa_saved = float(np.max(pvp["TOA2"] - pvp["TOA1"]))
    note = "sarcli " + __version__ + (
        "; scene centre at a PLACEHOLDER location (0N 0E): no scene_center_lat_deg/lon_deg given"
        if ref.is_default else "")
    pol = str(ph.attrs.get("polarization", "")).upper()
    tx_pol, rcv_pol = (pol[0], pol[1]) if len(pol) == 2 and set(pol) <= set("HV") else ("UNSPECIFIED",) * 2

    def area(tag):
        return getattr(E, tag)(_xy(E, "X1Y1", x_lo, y_lo), _xy(E, "X2Y2", x_hi, y_hi))

    root = E.CPHD(
        E.CollectionID(
            E.CollectorName(str(ph.attrs.get("collector_name", "sarcli"))[:60] or "sarcli"),
            E.CoreName((acq.name or "sarcli-phase-history")[:60]),
            E.CollectType("BISTATIC" if str(ph.attrs.get("collect_type", "")).upper() == "BISTATIC"
                          else "MONOSTATIC"),
            E.RadarMode(E.ModeType("SPOTLIGHT")),
            E.Classification("UNCLASSIFIED"),
            E.ReleaseInfo("UNRESTRICTED"),
            E.Parameter(note, name="sarcli"),
        ),
        E.Global(
            E.DomainType("FX"),
            E.SGN("-1"),
            E.Timeline(E.CollectionStart(str(ph.attrs.get("collection_start", PLACEHOLDER_START))),
                       E.TxTime1(repr(t0)), E.TxTime2(repr(t1))),
            E.FxBand(E.FxMin(repr(float(fx1.min()))), E.FxMax(repr(float(fx2.max())))),
            E.TOASwath(E.TOAMin(repr(float(pvp["TOA1"].min()))), E.TOAMax(repr(float(pvp["TOA2"].max())))),
        ),
        E.SceneCoordinates(
            E.EarthModel("WGS_84"),
            E.IARP(_xyz(E, "ECF", ref.ecf),
                   E.LLH(E.Lat(repr(ref.lat_deg)), E.Lon(repr(ref.lon_deg)), E.HAE(repr(ref.hae_m)))),
            E.ReferenceSurface(E.Planar(_xyz(E, "uIAX", basis[0]), _xyz(E, "uIAY", basis[1]))),
            area("ImageArea"),
            E.ImageAreaCornerPoints(*[
                E.IACP(E.Lat(repr(float(c[0]))), E.Lon(repr(float(c[1]))), index=str(i + 1))
                for i, c in enumerate(corners_llh)]),
            E.ImageGrid(
                E.Identifier("sarcli-grid"),
                E.IARPLocation(E.Line(repr(grid.nx // 2 - grid.cx / grid.dx)),
                               E.Sample(repr(grid.ny // 2 - grid.cy / grid.dy))),
                E.IAXExtent(E.LineSpacing(repr(float(grid.dx))), E.FirstLine("0"), E.NumLines(str(grid.nx))),
                E.IAYExtent(E.SampleSpacing(repr(float(grid.dy))), E.FirstSample("0"), E.NumSamples(str(grid.ny))),
            ),
        ),
        E.Data(
            E.SignalArrayFormat(signal_format),
            E.NumBytesPVP(str(pvp.dtype.itemsize)),
            E.NumCPHDChannels("1"),
            E.Channel(E.Identifier(CHANNEL_ID), E.NumVectors(str(P)), E.NumSamples(str(M)),
                      E.SignalArrayByteOffset("0"), E.PVPArrayByteOffset("0")),
            E.NumSupportArrays("0"),
        ),
        E.Channel(
            E.RefChId(CHANNEL_ID),
            E.FXFixedCPHD(str(fixed_fx).lower()),
            E.TOAFixedCPHD(str(fixed_toa).lower()),
            E.SRPFixedCPHD(str(fixed_srp).lower()),
            E.Parameters(
                E.Identifier(CHANNEL_ID),
                E.RefVectorIndex(str(P // 2)),
                E.FXFixed(str(fixed_fx).lower()),
                E.TOAFixed(str(fixed_toa).lower()),
                E.SRPFixed(str(fixed_srp).lower()),
                E.Polarization(E.TxPol(tx_pol), E.RcvPol(rcv_pol)),
                E.FxC(repr(0.5 * float(fx1.min() + fx2.max()))),
                E.FxBW(repr(float(fx2.max() - fx1.min()))),
                E.TOASaved(repr(toa_saved)),
                E.DwellTimes(E.CODId("1"), E.DwellId("1")),
                area("ImageArea"),
            ),
        ),
        E.PVP(*_pvp_xml(E)),
        E.Dwell(
            E.NumCODTimes("1"),
            E.CODTime(E.Identifier("1"), _poly0(E, "CODTimePoly", 0.5 * (r0_t + r1_t))),
            E.NumDwellTimes("1"),
            E.DwellTime(E.Identifier("1"), _poly0(E, "DwellTimePoly", r1_t - r0_t)),
        ),
    )
    return root


def _poly0(E, tag, value):
    return getattr(E, tag)(E.Coef(repr(float(value)), exponent1="0", exponent2="0"), order1="0", order2="0")


def _pvp_xml(E):
    out, off = [], 0
    for name, words, fmt in _PVP_LAYOUT:
        out.append(getattr(E, name)(E.Offset(str(off)), E.Size(str(words)), E.Format(fmt)))
        off += words
    return out


def write_cphd(ph: PhaseHistory, path) -> Path:
    """Write a phase history as a monostatic, single-channel, FX-domain CPHD 1.1.0 file.

    Parameters
    ----------
    ph : PhaseHistory
        Needs antenna positions (any model; the file always states the spherical signal model
        referenced to the scene centre) and equally spaced frequencies per pulse.
    path : str or Path

    Returns
    -------
    Path

    Raises
    ------
    SarcliInputError
        No antenna positions, or frequencies that are not equally spaced.
    """
    import sarkit.cphd as skcphd

    acq = ph.acquisition
    if not acq.has_positions:
        raise SarcliInputError("CPHD export needs antenna positions (a flight path); this phase "
                               "history is far-field only")
    data = np.asarray(ph.data)
    P, M = data.shape
    sc0, scss = _uniform_frequencies(acq.frequencies_2d)
    ref = reference_point(ph.attrs)
    pos = np.asarray(acq.antenna_position_m, np.float64)
    tx_pos, rcv_pos, r0 = (np.asarray(v, np.float64) for v in acq.range_geometry())
    half_path = geometry.bistatic_reference_range(tx_pos, rcv_pos)
    if np.max(np.abs(half_path - r0)) > 0:
        # fold exp(+i 4πα/c (R - r0)) into the signal (R half the two-way path to the scene
        # centre): the file is referenced to the SRP
        corr = np.exp(1j * sampling.range_wavenumbers(acq.frequencies_2d) * (half_path - r0)[:, None])
        data = data * corr
    t, vel = pulse_times(pos)
    pvp = np.zeros(P, dtype=_pvp_dtype())
    basis = enu_basis(ref)
    tx_ecf = enu_to_ecf(tx_pos, ref)
    rcv_ecf = enu_to_ecf(rcv_pos, ref)
    tx_vel = (pulse_times(tx_pos)[1] if acq.is_bistatic else vel) @ basis
    rcv_vel = (pulse_times(rcv_pos)[1] if acq.is_bistatic else vel) @ basis
    srp_ecf = np.broadcast_to(ref.ecf, (P, 3))
    pvp["TxTime"] = t
    pvp["TxPos"] = tx_ecf
    pvp["TxVel"] = tx_vel
    pvp["RcvTime"] = t + 2 * half_path / geometry.C
    pvp["RcvPos"] = rcv_ecf
    pvp["RcvVel"] = rcv_vel
    pvp["SRPPos"] = srp_ecf
    ut = (tx_ecf - srp_ecf) / np.linalg.norm(tx_ecf - srp_ecf, axis=1)[:, None]
    ur = (rcv_ecf - srp_ecf) / np.linalg.norm(rcv_ecf - srp_ecf, axis=1)[:, None]
    pvp["aFDOP"] = -1.0 / geometry.C * (np.einsum("ij,ij->i", tx_vel, ut) + np.einsum("ij,ij->i", rcv_vel, ur))
    pvp["aFRR1"] = 0.0  # CPHD: may be zero for all vectors
    pvp["aFRR2"] = 0.0
    pvp["SC0"] = sc0
    pvp["SCSS"] = scss
    pvp["FX1"] = sc0
    pvp["FX2"] = sc0 + (M - 1) * scss
    # saved TOA swath: the grid's corners (2 R / c), within the unambiguous 1/SCSS at an
    # oversampling ratio of 1.2 (what CPHD checkers ask for)
    toa_half = np.minimum(2.0 * acq.grid.half_diagonal / geometry.C, 0.5 / (_FX_OSR * scss))
    pvp["TOA1"] = -toa_half
    pvp["TOA2"] = toa_half
    pvp["TDTropoSRP"] = 0.0
    pvp["SIGNAL"] = 1
    signal_format = "CF8"  # CPHD's only float format: complex128 data is rounded to complex64
    sig = data.astype(np.complex64)
    root = _build_xml(ph, ref, pvp, signal_format)
    tree = root.getroottree()
    refgeom = skcphd.compute_reference_geometry(tree, pvp)
    root.append(refgeom)
    meta = skcphd.Metadata(xmltree=tree)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f, skcphd.Writer(f, meta) as w:
            w.write_signal(CHANNEL_ID, sig)
            w.write_pvp(CHANNEL_ID, pvp)
    return Path(path)


# --------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------
def read_cphd(path, *, lazy: bool = False) -> PhaseHistory:
    """Read the first channel of an FX-domain CPHD file (monostatic or bistatic) as a phase history.

    Positions are converted to the local ENU frame of the image-area reference point (IARP) at
    any latitude and longitude (:func:`sarcli.io.georef.ecf_to_enu`). Where ``TxPos`` and
    ``RcvPos`` differ they are kept as transmit/receive positions (the two-way range model), the
    antenna position is their midpoint (for angles only) and ``r0_p = (|t_p - SRP_p| +
    |q_p - SRP_p|)/2``; azimuth and elevation come from
    :func:`sarcli.core.geometry.angles_from_positions`; frequencies are ``SC0 + n SCSS``. A file with
    ``SGN = +1`` is conjugated into our sign convention; an ``AmpSF`` PVP scales its vector;
    vectors with ``SIGNAL = 0`` are dropped. The samples are complex64 whatever the storage
    format (CI2, CI4, CI8, CF8; CF16 is rounded) and are checked for NaN/Inf.

    Parameters
    ----------
    path : str or Path
    lazy : bool
        Leave the signal on disk: ``data`` is a :class:`sarcli.io._cphd_parts.CphdSignal` read by
        blocks of pulses as a former asks for them (the PVPs are read now), so formers that work
        pulse by pulse (backprojection, ffbp, the spherical matched filter) hold one block at a time.

    Raises
    ------
    InputFileError
        Missing, truncated or foreign file, a TOA-domain collection, a compressed signal array,
        NaN/Inf samples (with ``lazy``, when the block holding them is read).
    """
    p = Path(path)
    if not p.is_file():
        raise InputFileError(path, "no such file (expected a CPHD file)")
    try:
        return _read_cphd(p, lazy=lazy)
    except InputFileError:
        raise
    except (OSError, ValueError, KeyError, TypeError, IndexError, AttributeError,
            lxml.etree.LxmlError, AssertionError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputFileError(path, f"not a readable CPHD file ({msg})") from None


def _read_cphd(p: Path, lazy: bool = False) -> PhaseHistory:
    import sarkit.cphd as skcphd
    from sarkit import wgs84

    with open(p, "rb") as f:
        head = f.read(5)
        if head != b"CPHD/":
            raise InputFileError(p, "not a CPHD file (it does not start with 'CPHD/')")
        f.seek(0)
        try:
            _, kvp = skcphd.read_file_header(f)
            f.seek(0)
            reader = skcphd.Reader(f)
        except (ValueError, KeyError, OSError, lxml.etree.LxmlError) as exc:
            raise InputFileError(p, "truncated or corrupt CPHD file: its header or XML block cannot be "
                                    f"read ({type(exc).__name__}: {str(exc)[:80]})") from None
        with reader as r:
            size = p.stat().st_size
            need = int(kvp["SIGNAL_BLOCK_BYTE_OFFSET"]) + int(kvp["SIGNAL_BLOCK_SIZE"])
            if size < need:
                raise InputFileError(p, f"truncated CPHD file: {size} bytes, the header promises {need}")
            xml = r.metadata.xmltree
            ch = xml.findtext("{*}Data/{*}Channel/{*}Identifier")
            if xml.findtext("{*}Global/{*}DomainType") != "FX":
                raise InputFileError(p, "only FX-domain CPHD files are supported (DomainType is "
                                        f"{xml.findtext('{*}Global/{*}DomainType')})")
            node = xml.find(f"{{*}}Data/{{*}}Channel[{{*}}Identifier='{ch}']")
            if node.findtext("{*}CompressedSignalSize") is not None:
                raise InputFileError(p, f"compressed CPHD signal arrays are not supported (channel '{ch}' is "
                                        f"compressed with {xml.findtext('{*}Data/{*}SignalCompressionID')!r}; "
                                        "decompress it first)")
            pvp = r.read_pvps(ch)
    sgn = int(xml.findtext("{*}Global/{*}SGN"))
    # the one reader of the samples: by rows, on demand (lazy) or all now, in blocks
    data = _read_signal_blocks(p, ch, int(node.findtext("{*}NumVectors")), int(node.findtext("{*}NumSamples")),
                               pvp, conjugate=sgn == 1, lazy=lazy)
    if "SIGNAL" in pvp.dtype.names and np.any(pvp["SIGNAL"] == 0):
        pvp = pvp[pvp["SIGNAL"] != 0]
    iarp = np.array([float(xml.findtext(f"{{*}}SceneCoordinates/{{*}}IARP/{{*}}ECF/{{*}}{c}")) for c in "XYZ"])
    lat, lon, hae = wgs84.cartesian_to_geodetic(iarp)
    ref = ReferencePoint(float(lat), float(lon), float(hae))
    tx = ecf_to_enu(np.asarray(pvp["TxPos"], np.float64), ref)
    rcv = ecf_to_enu(np.asarray(pvp["RcvPos"], np.float64), ref)
    srp = ecf_to_enu(np.asarray(pvp["SRPPos"], np.float64), ref)
    # the signal is referenced to the SRP: r0_p is half the two-way path to it (CONVENTIONS.md)
    r0 = geometry.bistatic_reference_range(tx - srp, rcv - srp)
    bistatic = not np.array_equal(tx, rcv)
    pos = 0.5 * (tx + rcv) if bistatic else tx
    M = data.shape[1]
    sc0, scss = np.asarray(pvp["SC0"], np.float64), np.asarray(pvp["SCSS"], np.float64)
    if np.all(sc0 == sc0[0]) and np.all(scss == scss[0]):
        # one band for all pulses: never build the [P, M] table (as large as the signal)
        freq = sc0[0] + np.arange(M) * scss[0]
    else:
        freq = sc0[:, None] + np.arange(M)[None, :] * scss[:, None]
        if np.all(freq == freq[0]):
            freq = freq[0].copy()
    az, el, _ = geometry.angles_from_positions(pos)
    grid = _grid_from_xml(xml, ref)
    if grid is None:
        from ..core.grid import derive_grid

        grid = derive_grid(freq, az, el)
    name = xml.findtext("{*}CollectionID/{*}CoreName") or ""
    acq = Acquisition(frequency_hz=freq, azimuth_rad=az, elevation_rad=el, grid=grid,
                      antenna_position_m=pos, range_to_center_m=r0, model="spherical",
                      name=name, source=str(p),
                      transmit_position_m=tx if bistatic else None,
                      receive_position_m=rcv if bistatic else None,
                      extra={"tx_time_s": np.asarray(pvp["TxTime"], np.float64).copy(),
                             "rcv_time_s": np.asarray(pvp["RcvTime"], np.float64).copy()})
    attrs = {**ref.as_attrs(), "source_format": "CPHD",
             "cphd_version": lxml.etree.QName(xml.getroot()).namespace.rsplit("/", 1)[-1],
             "collect_type": xml.findtext("{*}CollectionID/{*}CollectType") or "MONOSTATIC",
             "collection_start": xml.findtext("{*}Global/{*}Timeline/{*}CollectionStart") or "",
             "collector_name": xml.findtext("{*}CollectionID/{*}CollectorName") or ""}
    tx_pol = xml.findtext("{*}Channel/{*}Parameters/{*}Polarization/{*}TxPol")
    rcv_pol = xml.findtext("{*}Channel/{*}Parameters/{*}Polarization/{*}RcvPol")
    if tx_pol in ("H", "V") and rcv_pol in ("H", "V"):
        attrs["polarization"] = tx_pol + rcv_pol
    return PhaseHistory(data=data, acquisition=acq, truth=None, attrs=attrs)
