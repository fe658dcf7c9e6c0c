"""CPHD (1.0.1 and 1.1.0) in, through sarkit: one channel as a spherical phase history.

* Any channel (``channel``: identifier or index; the first by default, said in a note when the
  file has several). FX or TOA domain (:mod:`.signal` turns TOA vectors into FX samples);
  CI2/CI4/CI8/CF8/CF16 samples scaled by ``AmpSF``; compressed arrays refused (sarkit has no
  decoder).
* The phase sign: ``sgn`` given, else the data's verdict where the saved TOA swath can tell, else
  a vendor quirk, else the file's ``SGN`` (:mod:`.corrections`); rows follow ``SGN = -1``.
* The troposphere: ``TDTropoSRP`` is trusted (the file's SRP reference includes it) unless a
  vendor quirk or ``troposphere='model'`` says the delay left in the data is
  ``model - TDTropoSRP``; that residual is removed.
* Positions in the local east-north-up frame of the IARP; where ``TxPos`` and ``RcvPos`` differ
  they are kept (the two-way range model), ``r0_p = (|t_p - SRP_p| + |q_p - SRP_p|)/2``.

What was decided and why is in ``attrs['cphd_notes']`` (one line each; the commands print them).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import lxml.etree
import numpy as np

from ...core import geometry
from ...core.acquisition import Acquisition
from ...core.grid import Grid
from ...core.types import PhaseHistory
from ...errors import InputFileError
from ..georef import GeometryWarning, ReferencePoint, ecf_to_enu, enu_basis
from . import corrections, validate
from .corrections import TROPOSPHERE_MODES
from .signal import CphdSignal, Decoding, ToaToFx

__all__ = ["read_cphd", "cphd_channels", "grid_from_xml", "AXES_TOLERANCE_RAD"]

#: Angle (rad) between the file's image-area axes (uIAX, uIAY) and local East/North above which
#: its ImageGrid cannot be used as our east/north-aligned grid (a GeometryWarning says so).
AXES_TOLERANCE_RAD = 1e-6
#: Vectors read to check the phase sign against the saved swath.
_SIGN_CHECK_VECTORS = 16


def read_cphd(path, *, lazy: bool = False, channel=None, sgn: int | None = None,
              troposphere: str = "auto") -> PhaseHistory:
    """Read one channel of a CPHD file as a spherical phase history.

    Parameters
    ----------
    path : str or Path
    lazy : bool
        Leave the signal on disk: ``data`` is a :class:`~sarcli.io.cphd.signal.CphdSignal` read by
        blocks of pulses as a former asks for them (the PVPs are read now).
    channel : str or int, optional
        Channel identifier, or 0-based index; default the first.
    sgn : {-1, +1}, optional
        The phase sign to use, whatever the file and the data say.
    troposphere : {'auto', 'file', 'model'}
        ``file``: trust ``TDTropoSRP``; ``model``: remove ``model - TDTropoSRP``
        (:func:`~sarcli.io.cphd.corrections.troposphere_delay`); ``auto``: ``file`` unless a
        vendor quirk says ``model``.

    Raises
    ------
    InputFileError
        Missing, truncated or foreign file; an unknown channel; a compressed signal array; PVP and
        signal sizes that disagree; NaN/Inf in the PVPs or (with ``lazy``, when read) the samples.
    """
    p = Path(path)
    if not p.is_file():
        raise InputFileError(path, "no such file (expected a CPHD file)")
    if sgn is not None and int(sgn) not in (-1, 1):
        raise InputFileError(path, f"sgn must be -1 or +1, not {sgn!r}")
    if troposphere not in TROPOSPHERE_MODES:
        raise InputFileError(path, f"troposphere must be one of {', '.join(TROPOSPHERE_MODES)}, not {troposphere!r}")
    try:
        return _read_cphd(p, lazy, channel, sgn, troposphere)
    except InputFileError:
        raise
    except (OSError, ValueError, KeyError, TypeError, IndexError, AttributeError,
            lxml.etree.LxmlError, AssertionError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputFileError(path, f"not a readable CPHD file ({msg})") from None


def cphd_channels(path) -> list[dict]:
    """The channels of a CPHD file (identifier, vectors, samples, polarisation)."""
    xml, _ = validate.open_header(Path(path))
    return validate.channel_table(xml)


def _read_cphd(p: Path, lazy, channel, sgn, troposphere) -> PhaseHistory:
    import sarkit.cphd as skcphd

    xml, kvp = validate.open_header(p)
    ch, notes = validate.select_channel(p, xml, channel)
    validate.check_layout(p, xml, kvp, ch)
    with open(p, "rb") as f, skcphd.Reader(f) as r:
        pvp = r.read_pvps(ch)
    node = xml.find(f"{{*}}Data/{{*}}Channel[{{*}}Identifier='{ch}']")
    nv, ns = int(node.findtext("{*}NumVectors")), int(node.findtext("{*}NumSamples"))
    kept = np.flatnonzero(pvp["SIGNAL"] != 0) if "SIGNAL" in pvp.dtype.names else None
    if kept is not None and kept.size == nv:
        kept = None
    validate.check_pvps(p, pvp, ch, kept)
    amp = np.asarray(pvp["AmpSF"], np.float64) if "AmpSF" in pvp.dtype.names else None
    sc0, scss = np.asarray(pvp["SC0"], np.float64), np.asarray(pvp["SCSS"], np.float64)
    toa = None
    if xml.findtext("{*}Global/{*}DomainType") == "TOA":
        toa = _toa_to_fx(p, ch, pvp, ns, kept)
        fx0, fx_step = np.asarray(pvp["FX1"], np.float64), 1.0 / (ns * scss)
    else:
        fx0, fx_step = sc0, scss
    base = Decoding(vectors=kept, amp_sf=amp, toa=toa)
    vendor, evidence = corrections.vendor_of(xml)
    use_sgn, sign_notes = _decide_sign(p, ch, (nv, ns), base, int(xml.findtext("{*}Global/{*}SGN")), sgn,
                                       (vendor, evidence), (fx_step, pvp))
    delay, tropo_notes = _residual_delay(xml, pvp, troposphere, vendor, evidence)
    dec = Decoding(vectors=kept, amp_sf=amp, conjugate=use_sgn == 1, toa=toa, delay_s=delay,
                   fx0_hz=fx0, fx_step_hz=fx_step)
    src = CphdSignal(p, ch, nv, ns, dec)
    data = src if lazy else np.asarray(src)
    if kept is not None:
        pvp, fx0, fx_step = pvp[kept], fx0[kept], fx_step[kept]
    ph = _phase_history(p, xml, ch, pvp, data, _frequencies(fx0, fx_step, data.shape[1]))
    ph.attrs.update({"cphd_channel": ch, "cphd_domain": xml.findtext("{*}Global/{*}DomainType"),
                     "cphd_sgn_declared": int(xml.findtext("{*}Global/{*}SGN")), "cphd_sgn_used": use_sgn,
                     "cphd_notes": notes + sign_notes + tropo_notes})
    if delay is not None:
        ph.attrs["cphd_troposphere_residual_s"] = float(np.mean(delay if kept is None else delay[kept]))
    return ph


def _toa_to_fx(p, ch, pvp, ns, kept) -> ToaToFx:
    """The TOA-to-FX conversion of a TOA-domain channel, or one line saying what is missing."""
    rows = slice(None) if kept is None else kept
    fx1, fx2, scss = (np.asarray(pvp[k], np.float64) for k in ("FX1", "FX2", "SCSS"))
    rate = 1.0 / scss[rows]
    band = (fx2 - fx1)[rows]
    if not np.all(band > 0):
        raise InputFileError(p, f"TOA-domain CPHD channel '{ch}' cannot be formed: its FX band is empty "
                                "(FX2 <= FX1), so the frequencies of its samples are missing")
    if np.any(band > rate * (1 + 1e-9)):
        i = int(np.argmax(band / rate))
        raise InputFileError(p, f"TOA-domain CPHD channel '{ch}' cannot be formed: its band FX2 - FX1 = "
                                f"{band[i]:.6g} Hz exceeds the TOA sampling rate 1/SCSS = {rate[i]:.6g} Hz, so "
                                "its FX samples alias")
    m_out = int(np.min(np.floor(band * ns * scss[rows] * (1 + 1e-9)))) + 1
    return ToaToFx(toa0_s=np.asarray(pvp["SC0"], np.float64), toa_step_s=scss, fx1_hz=fx1, m_out=min(m_out, ns))


def _decide_sign(p, ch, shape, base: Decoding, declared: int, asked, vendor_evidence, swath):
    """The phase sign to use and the notes that say why (module docstring)."""
    vendor, evidence = vendor_evidence
    fx_step, pvp = swath
    if asked is not None:
        said = [] if int(asked) == declared else [f"SGN {int(asked):+d} as asked (--sgn); the file declares {declared:+d}"]
        return int(asked), said
    quirk = corrections.VENDOR_QUIRKS.get(vendor, {}).get("sgn")
    chosen, notes = declared, []
    if quirk is not None and quirk != declared:
        chosen = quirk
        notes.append(f"{corrections.VENDOR_QUIRKS[vendor]['name']} collection ({evidence}): {corrections.VENDOR_QUIRKS[vendor]['why']}; "
                     f"using SGN {quirk:+d} (--sgn to override)")
    vec = np.arange(shape[0]) if base.vectors is None else base.vectors
    pick = np.unique(vec[np.linspace(0, vec.size - 1, min(_SIGN_CHECK_VECTORS, vec.size)).round().astype(int)])
    toa1, toa2 = np.asarray(pvp["TOA1"], np.float64), np.asarray(pvp["TOA2"], np.float64)
    if not corrections.swath_can_tell(fx_step[pick], toa1[pick], toa2[pick]):
        return chosen, notes
    probe = CphdSignal(p, ch, *shape, Decoding(vectors=pick, amp_sf=base.amp_sf, conjugate=declared == 1,
                                               toa=base.toa))
    verdict, f_own, f_mirror = corrections.sign_from_swath(np.asarray(probe), fx_step[pick], toa1[pick], toa2[pick])
    if verdict == 0:
        return chosen, notes
    data_sgn = declared * verdict
    if data_sgn != chosen:
        notes = [f"the data follow SGN {data_sgn:+d}, not {chosen:+d}: range-compressed with {chosen:+d}, "
                 f"{100 * (f_own if chosen == declared else f_mirror):.3g}% of their energy lies in the saved TOA "
                 f"swath's own part and {100 * (f_mirror if chosen == declared else f_own):.3g}% in its mirror's; "
                 f"using {data_sgn:+d} (--sgn to override)"]
    return data_sgn, notes


def _residual_delay(xml, pvp, mode: str, vendor, evidence):
    """The troposphere delay left in the data (s, per file vector) and the note, or (None, [])."""
    quirk = corrections.VENDOR_QUIRKS.get(vendor, {}).get("troposphere")
    if mode == "file" or (mode == "auto" and quirk != "model"):
        return None, []
    n0, source = corrections.tropo_n0(xml)
    model = corrections.troposphere_delay(pvp["SRPPos"], pvp["TxPos"], pvp["RcvPos"], n0)
    given = np.asarray(pvp["TDTropoSRP"], np.float64) if "TDTropoSRP" in pvp.dtype.names else np.zeros(len(pvp))
    delay = model - given
    why = (f"{corrections.VENDOR_QUIRKS[vendor]['name']} collection ({evidence}): {corrections.VENDOR_QUIRKS[vendor]['why']}"
           if mode == "auto" else "troposphere = model (--troposphere)")
    mean = float(np.mean(delay))
    return delay, [f"{why}; removing the modelled delay ({source}) less TDTropoSRP: {1e9 * mean:.3g} ns mean, "
                   f"{0.5 * geometry.C * mean:.3g} m in slant range (--troposphere file to keep the file's)"]


def _frequencies(fx0, fx_step, M):
    """``fx0 + j fx_step``: one row [M] when every vector has the same band, else [P, M]."""
    if np.all(fx0 == fx0[0]) and np.all(fx_step == fx_step[0]):
        return fx0[0] + np.arange(M) * fx_step[0]  # never build the [P, M] table (as large as the signal)
    return fx0[:, None] + np.arange(M)[None, :] * fx_step[:, None]


def _phase_history(p, xml, ch, pvp, data, freq) -> PhaseHistory:
    """Geometry of the kept vectors in the local frame of the IARP, and the file's provenance."""
    from sarkit import wgs84

    iarp = np.array([float(xml.findtext(f"{{*}}SceneCoordinates/{{*}}IARP/{{*}}ECF/{{*}}{c}")) for c in "XYZ"])
    lat, lon, hae = wgs84.cartesian_to_geodetic(iarp)
    ref = ReferencePoint(float(lat), float(lon), float(hae))
    tx, rcv, srp = (ecf_to_enu(np.asarray(pvp[k], np.float64), ref) for k in ("TxPos", "RcvPos", "SRPPos"))
    # the signal is referenced to the SRP: r0_p is half the two-way path to it (docs/conventions.md)
    r0 = geometry.bistatic_reference_range(tx - srp, rcv - srp)
    bistatic = not np.array_equal(tx, rcv)
    pos = 0.5 * (tx + rcv) if bistatic else tx
    az, el, _ = geometry.angles_from_positions(pos)
    grid = grid_from_xml(xml, ref)
    if grid is None:
        from ...core.grid import derive_grid

        grid = derive_grid(freq, az, el)
    acq = Acquisition(frequency_hz=freq, azimuth_rad=az, elevation_rad=el, grid=grid,
                      antenna_position_m=pos, range_to_center_m=r0, model="spherical",
                      name=xml.findtext("{*}CollectionID/{*}CoreName") or "", source=str(p),
                      transmit_position_m=tx if bistatic else None, receive_position_m=rcv if bistatic else None,
                      extra={"tx_time_s": np.asarray(pvp["TxTime"], np.float64).copy(),
                             "rcv_time_s": np.asarray(pvp["RcvTime"], np.float64).copy()})
    attrs = {**ref.as_attrs(), "source_format": "CPHD",
             "cphd_version": lxml.etree.QName(xml.getroot()).namespace.rsplit("/", 1)[-1],
             "collect_type": xml.findtext("{*}CollectionID/{*}CollectType") or "MONOSTATIC",
             "collection_start": xml.findtext("{*}Global/{*}Timeline/{*}CollectionStart") or "",
             "collector_name": xml.findtext("{*}CollectionID/{*}CollectorName") or ""}
    pol = next(c["polarization"] for c in validate.channel_table(xml) if c["identifier"] == ch)
    if pol != "unspecified":
        attrs["polarization"] = pol
    return PhaseHistory(data=data, acquisition=acq, truth=None, attrs=attrs)


def grid_from_xml(xml, ref: ReferencePoint) -> Grid | None:
    """Our grid from ``SceneCoordinates/ImageGrid`` when its axes are local East and North.

    Our frame is east-north-up at the IARP (docs/conventions.md). A planar image area whose
    uIAX/uIAY are East/North (to :data:`AXES_TOLERANCE_RAD`) gives the grid exactly; other axes
    (a rotated or tilted image plane, or a HAE surface) cannot be an east/north-aligned grid, so
    a :class:`~sarcli.io.georef.GeometryWarning` says so and None is returned (the grid is then
    derived from the sampling, east/north aligned and centred on the IARP).
    """
    g = xml.find("{*}SceneCoordinates/{*}ImageGrid")
    if g is None:
        return None
    planar = xml.find("{*}SceneCoordinates/{*}ReferenceSurface/{*}Planar")
    if planar is not None:
        uiax = np.array([float(planar.findtext(f"{{*}}uIAX/{{*}}{c}")) for c in "XYZ"])
        uiay = np.array([float(planar.findtext(f"{{*}}uIAY/{{*}}{c}")) for c in "XYZ"])
        basis = enu_basis(ref)
        ang = max(float(np.arccos(np.clip(uiax @ basis[0] / np.linalg.norm(uiax), -1, 1))),
                  float(np.arccos(np.clip(uiay @ basis[1] / np.linalg.norm(uiay), -1, 1))))
    else:
        ang = np.inf
    if not ang <= AXES_TOLERANCE_RAD:
        what = ("its image area is not planar" if planar is None else
                f"its image-area axes (uIAX, uIAY) are {np.degrees(ang):.4g} deg from East/North")
        warnings.warn(f"CPHD ImageGrid not used: {what}; sarcli images on an east/north-aligned grid "
                      "at the IARP, derived from the sampling (give --extent/--pixel-size to change it)",
                      GeometryWarning, stacklevel=4)
        return None
    dx = float(g.findtext("{*}IAXExtent/{*}LineSpacing"))
    dy = float(g.findtext("{*}IAYExtent/{*}SampleSpacing"))
    nx = int(g.findtext("{*}IAXExtent/{*}NumLines"))
    ny = int(g.findtext("{*}IAYExtent/{*}NumSamples"))
    line0 = float(g.findtext("{*}IARPLocation/{*}Line")) - int(g.findtext("{*}IAXExtent/{*}FirstLine"))
    samp0 = float(g.findtext("{*}IARPLocation/{*}Sample")) - int(g.findtext("{*}IAYExtent/{*}FirstSample"))
    return Grid(nx, ny, dx, dy, (nx // 2 - line0) * dx, (ny // 2 - samp0) * dy)
