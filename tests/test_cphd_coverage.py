"""CPHD files as the satellites ship them: several channels, TOA domain, scaled integer samples,
vendor quirks, a phase sign checked against the data, the troposphere, and bad input.

Every file is built here with sarkit from the standard's example metadata (spaceborne, ECEF:
tests/data/example-cphd-1.1.0-small.xml), its signal computed in ECF from point targets; every
image is measured against the exact matched filter written out in ECF in the test
(:func:`tests.test_cphd_sicd.independent_matched_filter`) after the reader's corrections.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import lxml.builder
import lxml.etree
import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.cli.main import cli
from sarcli.core import geometry
from sarcli.core.grid import Grid
from sarcli.errors import InputFileError
from sarcli.formers.formation import form_image
from sarcli.io.cphd import read_cphd

from .conftest import spy_rows
from .test_cphd_sicd import EXAMPLE_XML, _enu_rows, _two_way, independent_matched_filter

pytestmark = pytest.mark.filterwarnings("ignore:.*is deprecated. Use files\\(\\) instead:DeprecationWarning")

GRID = Grid(40, 40, 0.5, 0.5, 0.0, 0.0)
TOL = 1e-3
# refractivity model of the troposphere, written out here: ITU-R P.453 scale height
H0 = 7350.0


@dataclass
class Channel:
    """One channel of a test file: its identifier, polarisation and point targets (local east,
    north, m; amplitudes); ``downrange`` moves the points along the ground range away from the radar."""

    name: str = "1"
    pol: str = "VV"
    points: np.ndarray = field(default_factory=lambda: np.array([[0.0, 0.0], [4.0, -3.0], [-6.0, 5.0], [7.5, 6.5]]))
    amps: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.8j, 0.6, -0.5]))
    downrange: bool = False


@dataclass
class Case:
    """A test file: geometry from the example XML at 60° N, the channels, and how it is stored."""

    channels: tuple = (Channel(),)
    P: int = 48
    M: int = 48
    domain: str = "FX"
    toa_samples: int = 0          # TOA domain: samples per vector (default M)
    fmt: str = "CF8"
    amp_sf: bool = False
    declared_sgn: int = -1        # what the XML says
    data_sgn: int = -1            # what the samples follow
    collector: str = "Synthetic"
    delay_in_data: bool = False   # the troposphere's delay (this test's model) left in the samples
    td_tropo_srp: str = "zero"    # "zero" or "model": the PVP TDTropoSRP
    swath: tuple | None = None    # (TOA1, TOA2) in s; default the example's


def _geometry(tree, P):
    """The example's orbit moved to 60° N 25° E (see test_cphd_sicd.make_cphd_fixture), monostatic
    with the receive position solved at the echo's time."""
    from sarkit import wgs84

    x = tree.find
    vec = lambda p: np.array([float(x(f"{p}/{{*}}{c}").text) for c in "XYZ"])  # noqa: E731
    iarp0 = vec("{*}SceneCoordinates/{*}IARP/{*}ECF")
    b0 = _enu_rows(0.0, 0.0)
    arp_l = b0 @ (vec("{*}ReferenceGeometry/{*}Monostatic/{*}ARPPos") - iarp0)
    vel_l = b0 @ vec("{*}ReferenceGeometry/{*}Monostatic/{*}ARPVel")
    tref = float(x("{*}ReferenceGeometry/{*}ReferenceTime").text)
    iarp, basis = wgs84.geodetic_to_cartesian([60.0, 25.0, 0.0]), _enu_rows(60.0, 25.0)
    pos = lambda t: iarp + (arp_l + np.multiply.outer(t - tref, vel_l)) @ basis  # noqa: E731
    t_tx = np.linspace(0.0, float(x("{*}Global/{*}Timeline/{*}TxTime2").text), P)
    tx = pos(t_tx)
    t_rcv = t_tx + 2 * np.linalg.norm(tx - iarp, axis=1) / geometry.C
    for _ in range(5):
        t_rcv = t_tx + (np.linalg.norm(tx - iarp, axis=1) + np.linalg.norm(pos(t_rcv) - iarp, axis=1)) / geometry.C
    ground = -arp_l[:2] / np.linalg.norm(arp_l[:2])  # away from the radar, on the ground
    return {"iarp": iarp, "basis": basis, "tx": tx, "rcv": pos(t_rcv), "t_tx": t_tx, "t_rcv": t_rcv,
            "vel": vel_l @ basis, "ground": ground}


def model_tropo_delay(g, n0):
    """Two-way troposphere delay at the SRP (s): 1e-6 N0 H0 / sin(graze) each way."""
    up = g["basis"][2]
    total = 0.0
    for apc in (g["tx"], g["rcv"]):
        los = apc - g["iarp"]
        total = total + 1e-6 * n0 * H0 / ((los @ up) / np.linalg.norm(los, axis=1))
    return total / geometry.C


def _signal(g, ch: Channel, freq, delay):
    """[P, M] samples, SGN = -1: Σ a exp(-i 2π f (ΔTOA + delay))."""
    xy = ch.points.copy()
    if ch.downrange:
        perp = np.array([-g["ground"][1], g["ground"][0]])
        xy = 8.0 * g["ground"] + np.outer(np.abs(xy[:, 0]) / 4, g["ground"]) + np.outer(xy[:, 1], perp)
    pts = g["iarp"] + np.column_stack([xy, np.zeros(len(xy))]) @ g["basis"]
    dt = (_two_way(g["tx"], g["rcv"], pts) - _two_way(g["tx"], g["rcv"], g["iarp"][None])) / geometry.C
    dt = dt + np.asarray(delay)[..., None]
    return np.einsum("pjs,s->pj", np.exp(-2j * np.pi * freq[None, :, None] * dt[:, None, :]), ch.amps), xy


def _store(sig, case: Case, freq, toa_t):
    """What goes in the file for ideal samples ``sig`` (SGN = -1, FX): TOA transform, sign,
    storage format and AmpSF; returns (stored array, AmpSF or None)."""
    if case.domain == "TOA":  # s(τ_n) = Σ_k d_k exp(+i 2π f_k τ_n): range compression
        sig = sig @ np.exp(2j * np.pi * np.outer(freq, toa_t))
    if case.data_sgn == 1:
        sig = np.conj(sig)
    import sarkit.cphd as skcphd

    dtype = skcphd.binary_format_string_to_dtype(case.fmt)
    top = {"CI2": 127, "CI4": 32767, "CI8": 2 ** 31 - 1}.get(case.fmt)
    amp = None
    if case.amp_sf:
        peak = np.max(np.abs(np.column_stack([sig.real, sig.imag])), axis=1)
        amp = peak / top if top else np.linspace(0.5, 2.0, len(sig))
        sig = sig / amp[:, None]
    elif top:  # integers without AmpSF: one scale to full range (the image scales with it)
        sig = sig * (0.9 * top / np.max(np.abs(np.column_stack([sig.real, sig.imag]))))
    if not top:
        return sig.astype(dtype), amp
    stored = np.zeros(sig.shape, dtype=dtype)
    stored["real"], stored["imag"] = np.round(sig.real), np.round(sig.imag)
    return stored, amp


def _held(data, amp, case: Case):
    """The FX samples (SGN = -1) an FX file holds, decoded here: I/Q integers or floats, times AmpSF."""
    if case.domain != "FX":
        return None
    held = (data["real"] + 1j * data["imag"]) if data.dtype.names else data.astype(np.complex128)
    held = held * (1.0 if amp is None else amp[:, None])
    return np.conj(held) if case.data_sgn == 1 else held


def build_cphd(path, case: Case = Case()):
    """Write ``case`` with sarkit; returns per channel the ECF geometry and the ideal samples
    (what :func:`independent_matched_filter` images)."""
    import sarkit.cphd as skcphd

    tree = lxml.etree.parse(str(EXAMPLE_XML))
    x = tree.find
    g = _geometry(tree, case.P)
    P, M = case.P, case.M
    fx_min, fx_max = float(x("{*}Global/{*}FxBand/{*}FxMin").text), float(x("{*}Global/{*}FxBand/{*}FxMax").text)
    df = (fx_max - fx_min) / (M - 1)
    freq = fx_min + df * np.arange(M)
    N = case.toa_samples or M
    toa_t = (np.arange(N) - N // 2) / (N * df)
    n0 = float(x("{*}Global/{*}TropoParameters/{*}N0").text)
    td = model_tropo_delay(g, n0)
    _edit_xml(tree, g, case, N)
    pvp = np.zeros(P, dtype=skcphd.get_pvp_dtype(tree))
    pvp["TxTime"], pvp["TxPos"], pvp["TxVel"] = g["t_tx"], g["tx"], g["vel"]
    pvp["RcvTime"], pvp["RcvPos"], pvp["RcvVel"] = g["t_rcv"], g["rcv"], g["vel"]
    pvp["SRPPos"], pvp["FX1"], pvp["FX2"], pvp["SIGNAL"] = g["iarp"], fx_min, fx_max, 1
    pvp["SC0"], pvp["SCSS"] = (toa_t[0], toa_t[1] - toa_t[0]) if case.domain == "TOA" else (fx_min, df)
    swath = case.swath or tuple(float(x(f"{{*}}Global/{{*}}TOASwath/{{*}}TOA{m}").text) for m in ("Min", "Max"))
    pvp["TOA1"], pvp["TOA2"] = swath
    pvp["TDTropoSRP"] = td if case.td_tropo_srp == "model" else 0.0
    out, stored = {}, []
    for ch in case.channels:
        ideal, xy = _signal(g, ch, freq, 0.0)
        in_file, _ = _signal(g, ch, freq, td if case.delay_in_data else 0.0)
        data, amp = _store(in_file, case, freq, toa_t)
        if amp is not None:
            pvp = pvp.copy()
            pvp["AmpSF"] = amp
        stored.append((ch.name, data, pvp.copy()))
        out[ch.name] = {"tx": g["tx"], "rcv": g["rcv"], "srp": g["iarp"], "basis": g["basis"], "freq": freq,
                        "signal": ideal, "xy": xy, "td": td, "held": _held(data, amp, case)}
    with open(path, "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=tree)) as w:
        for name, data, pv in stored:
            w.write_signal(name, data)
            w.write_pvp(name, pv)
    return out


def _edit_xml(tree, g, case: Case, N):
    """The example XML moved to the site, resized, with the case's channels, domain, format, sign."""
    x = tree.find
    E = lxml.builder.ElementMaker(namespace=lxml.etree.QName(tree.getroot()).namespace)
    for c, v in zip("XYZ", g["iarp"]):
        x(f"{{*}}SceneCoordinates/{{*}}IARP/{{*}}ECF/{{*}}{c}").text = repr(float(v))
    for tag, v in zip(("Lat", "Lon", "HAE"), (60.0, 25.0, 0.0)):
        x(f"{{*}}SceneCoordinates/{{*}}IARP/{{*}}LLH/{{*}}{tag}").text = repr(v)
    for ax, row in (("uIAX", g["basis"][0]), ("uIAY", g["basis"][1])):
        for c, v in zip("XYZ", row):
            x(f"{{*}}SceneCoordinates/{{*}}ReferenceSurface/{{*}}Planar/{{*}}{ax}/{{*}}{c}").text = repr(float(v))
    gp = "{*}SceneCoordinates/{*}ImageGrid/"
    for tag, v in (("IARPLocation/{*}Line", GRID.nx // 2), ("IARPLocation/{*}Sample", GRID.ny // 2),
                   ("IAXExtent/{*}LineSpacing", GRID.dx), ("IAXExtent/{*}NumLines", GRID.nx),
                   ("IAYExtent/{*}SampleSpacing", GRID.dy), ("IAYExtent/{*}NumSamples", GRID.ny)):
        x(gp + "{*}" + tag).text = str(v)
    x("{*}Global/{*}DomainType").text = case.domain
    x("{*}Global/{*}SGN").text = str(case.declared_sgn)
    x("{*}CollectionID/{*}CollectorName").text = case.collector
    x("{*}Data/{*}SignalArrayFormat").text = case.fmt
    if case.amp_sf:
        node = x("{*}PVP")
        words = int(x("{*}Data/{*}NumBytesPVP").text) // 8
        node.find("{*}SRPPos").addnext(E.AmpSF(E.Offset(str(words)), E.Size("1"), E.Format("F8")))
        x("{*}Data/{*}NumBytesPVP").text = str(8 * (words + 1))
    import sarkit.cphd as skcphd

    item = skcphd.binary_format_string_to_dtype(case.fmt).itemsize
    nbytes = int(x("{*}Data/{*}NumBytesPVP").text)
    data_ch, par = x("{*}Data/{*}Channel"), x("{*}Channel/{*}Parameters")
    for i, ch in enumerate(case.channels):
        d = data_ch if i == 0 else copy.deepcopy(data_ch)
        d.find("{*}Identifier").text = ch.name
        d.find("{*}NumVectors").text = str(case.P)
        d.find("{*}NumSamples").text = str(N if case.domain == "TOA" else case.M)
        d.find("{*}SignalArrayByteOffset").text = str(i * case.P * int(d.findtext("{*}NumSamples")) * item)
        d.find("{*}PVPArrayByteOffset").text = str(i * case.P * nbytes)
        q = par if i == 0 else copy.deepcopy(par)
        q.find("{*}Identifier").text = ch.name
        q.find("{*}RefVectorIndex").text = str(case.P // 2)
        q.find("{*}Polarization/{*}TxPol").text, q.find("{*}Polarization/{*}RcvPol").text = ch.pol
        if i:
            data_ch.getparent().find("{*}NumSupportArrays").addprevious(d)
            par.getparent().append(q)
    x("{*}Data/{*}NumCPHDChannels").text = str(len(case.channels))


def _rel(a, b):
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def _error(path, fx, **kw):
    """Relative error of ``direct`` on the file read with ``kw`` against the exact matched filter."""
    ph = read_cphd(path, **kw)
    assert ph.acquisition.grid == GRID
    return _rel(form_image(ph, method="direct").image, independent_matched_filter(fx, GRID)), ph


# --------------------------------------------------------------------------------------------
# channels, formats, domains
# --------------------------------------------------------------------------------------------
TWO = (Channel("HH", "HH"), Channel("VV", "VV", points=np.array([[-3.0, -4.0], [5.0, 2.0]]), amps=np.array([0.9, 1j])))


def test_two_channels_from_the_example_metadata(tmp_path):
    """The standard's example (spaceborne, ECEF) with two channels: each forms at <= 1e-3, by
    name or index; the first is the default and a note says so."""
    fx = build_cphd(tmp_path / "two.cphd", Case(channels=TWO))
    err, ph = _error(tmp_path / "two.cphd", fx["HH"])
    assert err <= TOL and ph.attrs["cphd_channel"] == "HH" and ph.attrs["polarization"] == "HH"
    assert len(ph.attrs["cphd_notes"]) == 1 and "2 channels ('HH', 'VV'): reading the first, 'HH'" in ph.attrs["cphd_notes"][0]
    for sel in ("VV", 1, "1"):
        err, ph = _error(tmp_path / "two.cphd", fx["VV"], channel=sel)
        assert err <= TOL and ph.attrs["cphd_channel"] == "VV" and not ph.attrs["cphd_notes"], sel
    # the two channels differ: reading one for the other would fail
    assert _rel(form_image(read_cphd(tmp_path / "two.cphd"), method="direct").image,
                independent_matched_filter(fx["VV"], GRID)) > 0.5
    with pytest.raises(InputFileError, match="no CPHD channel 'XX': the file has 'HH', 'VV'"):
        read_cphd(tmp_path / "two.cphd", channel="XX")


def test_channels_on_the_command_line(tmp_path):
    from sarcli.io.hdf5 import read_image, read_phase_history

    fx = build_cphd(tmp_path / "two.cphd", Case(channels=TWO))
    runner = CliRunner()
    res = runner.invoke(cli, ["info", str(tmp_path / "two.cphd")])
    assert res.exit_code == 0, res.output
    assert "HH (48 x 48, HH), VV (48 x 48, VV)" in res.output and "note: CPHD file with 2 channels" in res.output
    res = runner.invoke(cli, ["import", "cphd", str(tmp_path / "two.cphd"), "-o", str(tmp_path / "vv.h5"),
                              "--channel", "VV"])
    assert res.exit_code == 0 and "note:" not in res.output, res.output
    ph = read_phase_history(tmp_path / "vv.h5")
    assert _rel(form_image(ph, method="direct", grid=GRID).image, independent_matched_filter(fx["VV"], GRID)) <= TOL
    res = runner.invoke(cli, ["form-image", str(tmp_path / "two.cphd"), "-o", str(tmp_path / "hh.h5"),
                              "--method", "direct"])
    assert res.exit_code == 0 and res.output.count("note: CPHD file with 2 channels") == 1, res.output
    assert _rel(read_image(tmp_path / "hh.h5").image, independent_matched_filter(fx["HH"], GRID)) <= TOL
    res = runner.invoke(cli, ["form-image", str(tmp_path / "two.cphd"), "-o", str(tmp_path / "x.h5"),
                              "--channel", "7"])
    assert res.exit_code == 2 and res.output.count("\n") == 1 and "index 0-1" in res.output, res.output
    assert not (tmp_path / "x.h5").exists()
    res = runner.invoke(cli, ["form-image", str(tmp_path / "vv.h5"), "-o", str(tmp_path / "x.h5"), "--sgn", "-1"])
    assert res.exit_code == 2 and "apply to CPHD input only" in res.output, res.output


@pytest.mark.parametrize("fmt, amp_sf", [("CI2", True), ("CI4", True), ("CI4", False), ("CF8", True),
                                         ("CI8", False), ("CF16", True)])
def test_sample_formats_with_amp_sf(tmp_path, fmt, amp_sf):
    """Integer and float samples scaled by AmpSF: the image of what the file holds (decoded in the
    test) at <= 1e-3; the quantisation itself, against the ideal samples, is the data's."""
    fx = build_cphd(tmp_path / "f.cphd", Case(fmt=fmt, amp_sf=amp_sf))
    err, ph = _error(tmp_path / "f.cphd", {**fx["1"], "signal": fx["1"]["held"]})
    assert err <= TOL, err
    # 8-bit I/Q quantisation costs 2e-3 of the image; 16-bit and floats nothing visible
    img = form_image(ph, method="direct").image
    ref = independent_matched_filter(fx["1"], GRID)
    quantisation = _rel(img * (np.vdot(img, ref) / np.vdot(img, img)), ref)  # the scale of an integer file aside
    assert quantisation <= (3e-3 if fmt == "CI2" else TOL), quantisation


@pytest.mark.parametrize("n, sgn", [(48, -1), (64, -1), (64, 1)])
def test_toa_domain_is_formed(tmp_path, n, sgn):
    """Range-compressed vectors (N TOA samples, N >= M) become the band's FX samples again."""
    fx = build_cphd(tmp_path / "t.cphd", Case(domain="TOA", toa_samples=n, declared_sgn=sgn, data_sgn=sgn,
                                              fmt="CF8"))
    err, ph = _error(tmp_path / "t.cphd", fx["1"])
    assert err <= TOL and ph.data.shape == (48, 48) and ph.attrs["cphd_domain"] == "TOA", err
    np.testing.assert_allclose(ph.acquisition.frequency_hz, fx["1"]["freq"], rtol=1e-12)


def test_toa_domain_without_the_band_is_refused(tmp_path):
    """Fewer TOA samples than the band needs: its FX samples alias; one line says so."""
    build_cphd(tmp_path / "t.cphd", Case(domain="TOA", toa_samples=32))
    with pytest.raises(InputFileError, match="TOA-domain CPHD channel '1' cannot be formed: its band FX2 - FX1"):
        read_cphd(tmp_path / "t.cphd")


def test_toa_domain_streams(tmp_path, monkeypatch):
    """`sar form-image X.cphd --channel 1` on a TOA-domain, two-channel file reads by blocks."""
    from sarcli.formers.backprojection._setup import BLOCK

    P = 2 * BLOCK + 40
    build_cphd(tmp_path / "t.cphd", Case(channels=TWO, P=P, domain="TOA", toa_samples=64))
    asked = spy_rows(monkeypatch)
    res = CliRunner().invoke(cli, ["form-image", str(tmp_path / "t.cphd"), "-o", str(tmp_path / "img.h5"),
                                   "--method", "backprojection", "--extent", "8", "--channel", "1"])
    assert res.exit_code == 0, res.output
    assert asked and sum(asked) == P and max(asked) <= BLOCK, asked


# --------------------------------------------------------------------------------------------
# the phase sign: vendor quirk, checked against the data, overridden
# --------------------------------------------------------------------------------------------
DOWNRANGE = (Channel(points=np.array([[0.0, 0.0], [4.0, -3.0], [-6.0, 5.0], [7.5, 6.5]]), downrange=True),)
#: an asymmetric saved swath (the period 1/SCSS is 352 ns): the points lie 29-40 ns downrange
ASYMMETRIC = (-10e-9, 150e-9)


def test_capella_sign_quirk(tmp_path):
    """A Capella file declares +1 with -1 data: the quirk applies, said in one line; forcing the
    declared sign gives the mirror image (the data cannot be imaged both ways to decide)."""
    fx = build_cphd(tmp_path / "c.cphd", Case(collector="capella-14", declared_sgn=1, data_sgn=-1))
    err, ph = _error(tmp_path / "c.cphd", fx["1"])
    assert err <= TOL and ph.attrs["cphd_sgn_used"] == -1, err
    note, = ph.attrs["cphd_notes"]
    assert note.startswith("Capella collection (CollectorName 'capella-14')") and "using SGN -1" in note
    err, ph = _error(tmp_path / "c.cphd", fx["1"], sgn=1)
    assert err > 0.5 and ph.attrs["cphd_notes"] == []
    mirror = np.abs(form_image(ph, method="direct").image)
    assert abs(mirror[GRID.index_of(-4.0, 3.0)]) == pytest.approx(0.8, abs=0.1)  # the point at (4, -3), mirrored


@pytest.mark.parametrize("declared, data, collector, note", [
    (1, -1, "Synthetic", "the data follow SGN -1, not +1"),   # a wrong declaration
    (-1, -1, "Synthetic", None),                               # a right one
    (1, -1, "capella-3", "Capella collection"),                # the quirk, confirmed by the data
    (-1, -1, "capella-3", None),                               # nothing for the quirk to fix
    (1, 1, "capella-3", "the data follow SGN +1, not -1")])    # a quirk that does not hold here
def test_sign_checked_against_the_saved_swath(tmp_path, declared, data, collector, note):
    """With an asymmetric TOA swath the data tell their sign: a wrong declaration (or a quirk that
    does not hold) is overruled and said in one line; a right one passes silently."""
    fx = build_cphd(tmp_path / "s.cphd", Case(channels=DOWNRANGE, swath=ASYMMETRIC, declared_sgn=declared,
                                              data_sgn=data, collector=collector))
    err, ph = _error(tmp_path / "s.cphd", fx["1"])
    assert err <= TOL and ph.attrs["cphd_sgn_used"] == data, err
    notes = ph.attrs["cphd_notes"]
    assert notes == [] if note is None else (len(notes) == 1 and notes[0].startswith(note)), notes
    # --sgn wins over the data (and then images the mirror)
    err, _ = _error(tmp_path / "s.cphd", fx["1"], sgn=-data)
    assert err > 0.5


def test_sign_check_on_the_command_line(tmp_path):
    from sarcli.io.hdf5 import read_image

    fx = build_cphd(tmp_path / "s.cphd", Case(channels=DOWNRANGE, swath=ASYMMETRIC, declared_sgn=1, data_sgn=-1))
    res = CliRunner().invoke(cli, ["form-image", str(tmp_path / "s.cphd"), "-o", str(tmp_path / "a.h5"),
                                   "--method", "direct"])
    assert res.exit_code == 0 and res.output.count("note: the data follow SGN -1, not +1") == 1, res.output
    assert _rel(read_image(tmp_path / "a.h5").image, independent_matched_filter(fx["1"], GRID)) <= TOL
    res = CliRunner().invoke(cli, ["import", "cphd", str(tmp_path / "s.cphd"), "-o", str(tmp_path / "b.h5"),
                                   "--sgn", "+1"])
    assert res.exit_code == 0 and "note:" not in res.output, res.output


def test_sign_check_reads_a_few_vectors(tmp_path, monkeypatch):
    """The check reads 16 vectors, once; the former then streams the rest by blocks."""
    from sarcli.formers.backprojection._setup import BLOCK

    P = 2 * BLOCK + 40
    build_cphd(tmp_path / "s.cphd", Case(channels=DOWNRANGE, P=P, swath=ASYMMETRIC, declared_sgn=1))
    asked = spy_rows(monkeypatch)
    ph = read_cphd(tmp_path / "s.cphd", lazy=True)
    assert asked == [16] and ph.attrs["cphd_sgn_used"] == -1
    form_image(ph, "backprojection", grid=Grid(16, 16, 0.5, 0.5, 0.0, 0.0))
    assert sum(asked[1:]) == P and max(asked[1:]) <= BLOCK, asked


# --------------------------------------------------------------------------------------------
# the troposphere
# --------------------------------------------------------------------------------------------
def test_iceye_troposphere_quirk(tmp_path):
    """An ICEYE file gives TDTropoSRP = 0 with the delay in its data: the modelled delay (N0 from
    its TropoParameters) is removed, said in one line; kept, the image is shifted in range."""
    fx = build_cphd(tmp_path / "i.cphd", Case(collector="ICEYE-X21", delay_in_data=True))
    td = fx["1"]["td"]
    assert 28e-9 < td.mean() < 34e-9  # 30 deg of grazing: 2.35 m / sin 30 = 4.7 m one way, 31 ns both
    err, ph = _error(tmp_path / "i.cphd", fx["1"])
    assert err <= TOL, err
    note, = ph.attrs["cphd_notes"]
    assert note.startswith("ICEYE collection (CollectorName 'ICEYE-X21')") and "N0 = 320.3" in note
    assert ph.attrs["cphd_troposphere_residual_s"] == pytest.approx(td.mean(), rel=1e-6)
    err, ph = _error(tmp_path / "i.cphd", fx["1"], troposphere="file")
    assert err > 0.3 and ph.attrs["cphd_notes"] == []


@pytest.mark.parametrize("mode, td_field, delay, ok", [
    ("auto", "model", False, True),     # the file's TDTropoSRP is in its reference: nothing to remove
    ("model", "model", False, True),    # the model less the file's value: nothing either
    ("model", "zero", True, True),      # a delay left in an anonymous file, removed on request
    ("auto", "zero", True, False)])     # ... and not without
def test_troposphere_modes(tmp_path, mode, td_field, delay, ok):
    fx = build_cphd(tmp_path / "t.cphd", Case(td_tropo_srp=td_field, delay_in_data=delay))
    err, ph = _error(tmp_path / "t.cphd", fx["1"], troposphere=mode)
    assert (err <= TOL) == ok, err
    assert bool(ph.attrs["cphd_notes"]) == (mode == "model")


# --------------------------------------------------------------------------------------------
# bad input: one line, exit 2, nothing written
# --------------------------------------------------------------------------------------------
def _rewrite(src, dst, edit):
    """Copy CPHD ``src`` to ``dst`` through sarkit, ``edit(xml, signal, pvp)`` applied in between."""
    import sarkit.cphd as skcphd

    with open(src, "rb") as f, skcphd.Reader(f) as r:
        xml = copy.deepcopy(r.metadata.xmltree)
        sig, pvp = r.read_channel("1")
    sig, pvp = edit(xml, sig, pvp)
    with open(dst, "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=xml)) as w:
        w.write_signal("1", sig)
        w.write_pvp("1", pvp)


def _nan_pvp(xml, sig, pvp):
    pvp = pvp.copy()
    pvp["TxPos"][5] = np.nan
    return sig, pvp


def _compressed(xml, sig, pvp):
    data = xml.find("{*}Data")
    E = lxml.builder.ElementMaker(namespace=lxml.etree.QName(data).namespace)
    data.find("{*}NumBytesPVP").addprevious(E.SignalCompressionID("acme-zip-7"))
    data.find("{*}Channel/{*}PVPArrayByteOffset").addnext(E.CompressedSignalSize("100"))
    return np.zeros(100, np.uint8), pvp


def _short_pvp_block(path):
    """The header's PVP block made one vector short of NumVectors (same digits, no offset moves)."""
    raw = path.read_bytes()
    key = b"PVP_BLOCK_SIZE := "
    i = raw.index(key) + len(key)
    j = raw.index(b"\n", i)
    size = int(raw[i:j])
    new = str(size - 352).rjust(j - i, "0").encode()
    path.write_bytes(raw[:i] + new + raw[j:])


@pytest.mark.parametrize("fault, expect", [
    ("nan", "CPHD PVP TxPos is NaN/Inf in 1 of 48 vectors of channel '1' (vector 5)"),
    ("compressed", "SignalCompressionID 'acme-zip-7'"),
    ("sizes", "CPHD PVP and signal sizes disagree: channel '1' has 48 signal vectors (NumVectors) but its PVP "
              "array holds 47")])
def test_bad_cphd_is_one_line_exit_2_nothing_written(tmp_path, fault, expect):
    build_cphd(tmp_path / "good.cphd")
    bad = tmp_path / "bad.cphd"
    if fault == "sizes":
        bad.write_bytes((tmp_path / "good.cphd").read_bytes())
        _short_pvp_block(bad)
    else:
        _rewrite(tmp_path / "good.cphd", bad, _nan_pvp if fault == "nan" else _compressed)
    for lazy in (False, True):
        with pytest.raises(InputFileError, match=expect.replace("(", r"\(").replace(")", r"\)")):
            read_cphd(bad, lazy=lazy)
    runner = CliRunner()
    for args in (["import", "cphd", str(bad), "-o", str(tmp_path / "o.h5")],
                 ["form-image", str(bad), "-o", str(tmp_path / "o.h5")],
                 ["info", str(bad)]):
        res = runner.invoke(cli, args)
        assert res.exit_code == 2 and res.output.count("\n") == 1 and expect in res.output, (args, res.output)
        assert str(bad) in res.output and not (tmp_path / "o.h5").exists()
