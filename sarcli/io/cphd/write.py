"""CPHD 1.1.0 out, through sarkit: a phase history as a one-channel FX-domain file.

Mapping (``docs/formats.md`` has the table):

* ``SGN = -1``: a scatterer whose time of arrival exceeds the SRP's by
  ``ΔTOA = 2 (|a - x| - |a - SRP|) / c`` contributes ``exp(-i 2π f ΔTOA)``, which is our
  spherical model ``exp(-i (4π α / c)(|a_p - x| - r0_p))`` with ``r0_p = |a_p - SRP_p|``.
* Vector p = pulse p: ``TxPos = RcvPos = a_p`` (monostatic, stop-and-hop) or, when the phase
  history has separate transmit and receive positions, ``TxPos = t_p``, ``RcvPos = q_p``
  (attr ``collect_type`` says ``BISTATIC``); ``SRPPos`` = the scene centre, ``SC0``/``SCSS`` =
  first frequency and spacing (``FX1``/``FX2`` the band edges), so the frequencies of every pulse
  must be equally spaced (:func:`sarcli.core.sampling.equally_spaced`). A phase history whose
  ``r0_p`` differs from ``|a_p|`` (motion-compensated data) has the phase
  ``exp(+i (4π α/c)(|a_p| - r0_p))`` folded into the signal so that the file is referenced to the
  SRP, as CPHD requires.
* Signal format ``CF8`` (complex64; CPHD has no complex128 format, so complex128 data is rounded).
* Our local ENU frame is anchored on the Earth at ``scene_center_lat_deg`` /
  ``scene_center_lon_deg`` (/ ``scene_center_height_m``) from the phase history's attrs, or at the
  placeholder :data:`sarcli.io.georef.DEFAULT_REFERENCE` (said in ``CollectionID/Parameter``).
  The planar image area is spanned by East (IAX) and North (IAY), so image-area coordinates equal
  our x, y; ``SceneCoordinates/ImageGrid`` holds our grid.
* Times are synthetic (CPHD needs them, our files have none): pulses are spaced so the platform
  moves at :data:`NOMINAL_SPEED_M_S`; velocities are finite differences of the positions.
"""

from __future__ import annotations

from pathlib import Path

import lxml.builder
import lxml.etree
import numpy as np

from ...core import geometry, sampling
from ..._util.atomic import atomic_path, open_held
from ..._version import __version__
from ...errors import SarcliInputError
from ..georef import ReferencePoint, enu_basis, enu_to_ecf, reference_point
from ...core.types import PhaseHistory

__all__ = ["write_cphd", "pulse_times", "NOMINAL_SPEED_M_S", "CPHD_NS"]

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
    E = lxml.builder.ElementMaker(namespace=CPHD_NS, nsmap={None: CPHD_NS})
    acq = ph.acquisition
    P, M = ph.data.shape
    fx1, fx2 = pvp["FX1"], pvp["FX2"]
    t0, t1 = float(pvp["TxTime"][0]), float(pvp["TxTime"][-1])
    note = "sarcli " + __version__ + (
        "; scene centre at a PLACEHOLDER location (0N 0E): no scene_center_lat_deg/lon_deg given"
        if ref.is_default else "")
    return E.CPHD(
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
        _scene_coordinates(E, ref, acq.grid),
        E.Data(
            E.SignalArrayFormat(signal_format),
            E.NumBytesPVP(str(pvp.dtype.itemsize)),
            E.NumCPHDChannels("1"),
            E.Channel(E.Identifier(CHANNEL_ID), E.NumVectors(str(P)), E.NumSamples(str(M)),
                      E.SignalArrayByteOffset("0"), E.PVPArrayByteOffset("0")),
            E.NumSupportArrays("0"),
        ),
        _channel(E, pvp, acq.grid, str(ph.attrs.get("polarization", ""))),
        E.PVP(*_pvp_xml(E)),
        _dwell(E, pvp),
    )


def _area_bounds(grid):
    """The grid's area (pixel edges) in the scene's plane: x low, x high, y low, y high."""
    return grid.x[0] - grid.dx / 2, grid.x[-1] + grid.dx / 2, grid.y[0] - grid.dy / 2, grid.y[-1] + grid.dy / 2


def _image_area(E, tag, grid):
    x_lo, x_hi, y_lo, y_hi = _area_bounds(grid)
    return getattr(E, tag)(_xy(E, "X1Y1", x_lo, y_lo), _xy(E, "X2Y2", x_hi, y_hi))


def _scene_coordinates(E, ref: ReferencePoint, grid):
    """``SceneCoordinates``: the IARP on the Earth, its tangent plane, and the grid on it."""
    from sarkit import wgs84

    x_lo, x_hi, y_lo, y_hi = _area_bounds(grid)
    corners_enu = np.array([[x_lo, y_lo, 0], [x_lo, y_hi, 0], [x_hi, y_hi, 0], [x_hi, y_lo, 0]], float)
    corners_llh = wgs84.cartesian_to_geodetic(enu_to_ecf(corners_enu, ref))
    basis = enu_basis(ref)
    return E.SceneCoordinates(
        E.EarthModel("WGS_84"),
        E.IARP(_xyz(E, "ECF", ref.ecf),
               E.LLH(E.Lat(repr(ref.lat_deg)), E.Lon(repr(ref.lon_deg)), E.HAE(repr(ref.hae_m)))),
        E.ReferenceSurface(E.Planar(_xyz(E, "uIAX", basis[0]), _xyz(E, "uIAY", basis[1]))),
        _image_area(E, "ImageArea", grid),
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
    )


def _channel(E, pvp: np.ndarray, grid, polarization: str):
    """``Channel``: what is fixed over the pulses, the band and the polarisation."""
    fx1, fx2 = pvp["FX1"], pvp["FX2"]
    fixed_fx = bool(np.all(fx1 == fx1[0]) and np.all(fx2 == fx2[0]) and np.all(pvp["SCSS"] == pvp["SCSS"][0]))
    fixed_toa = bool(np.all(pvp["TOA1"] == pvp["TOA1"][0]) and np.all(pvp["TOA2"] == pvp["TOA2"][0]))
    fixed_srp = bool(np.all(pvp["SRPPos"] == pvp["SRPPos"][0]))
    toa_saved = float(np.max(pvp["TOA2"] - pvp["TOA1"]))
    pol = polarization.upper()
    tx_pol, rcv_pol = (pol[0], pol[1]) if len(pol) == 2 and set(pol) <= set("HV") else ("UNSPECIFIED",) * 2
    return E.Channel(
        E.RefChId(CHANNEL_ID),
        E.FXFixedCPHD(str(fixed_fx).lower()),
        E.TOAFixedCPHD(str(fixed_toa).lower()),
        E.SRPFixedCPHD(str(fixed_srp).lower()),
        E.Parameters(
            E.Identifier(CHANNEL_ID),
            E.RefVectorIndex(str(pvp.shape[0] // 2)),
            E.FXFixed(str(fixed_fx).lower()),
            E.TOAFixed(str(fixed_toa).lower()),
            E.SRPFixed(str(fixed_srp).lower()),
            E.Polarization(E.TxPol(tx_pol), E.RcvPol(rcv_pol)),
            E.FxC(repr(0.5 * float(fx1.min() + fx2.max()))),
            E.FxBW(repr(float(fx2.max() - fx1.min()))),
            E.TOASaved(repr(toa_saved)),
            E.DwellTimes(E.CODId("1"), E.DwellId("1")),
            _image_area(E, "ImageArea", grid),
        ),
    )


def _dwell(E, pvp: np.ndarray):
    """``Dwell`` in reference time: when each pulse meets the SRP (TxTime + |Tx - SRP| / c); at
    spaceborne ranges that differs from TxTime by milliseconds."""
    tref = pvp["TxTime"] + np.linalg.norm(pvp["TxPos"] - pvp["SRPPos"], axis=1) / geometry.C
    r0_t, r1_t = float(tref.min()), float(tref.max())
    return E.Dwell(
        E.NumCODTimes("1"),
        E.CODTime(E.Identifier("1"), _poly0(E, "CODTimePoly", 0.5 * (r0_t + r1_t))),
        E.NumDwellTimes("1"),
        E.DwellTime(E.Identifier("1"), _poly0(E, "DwellTimePoly", r1_t - r0_t)),
    )


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
        with open_held(tmp) as f, skcphd.Writer(f, meta) as w:
            w.write_signal(CHANNEL_ID, sig)
            w.write_pvp(CHANNEL_ID, pvp)
    return Path(path)
