"""CPHD in/out and SICD out through sarkit: round trips, consistency checks, corrupt files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.cli.main import cli
from sarcli.io.cphd import read_cphd, write_cphd
from sarcli.errors import InputFileError, SarcliInputError
from sarcli.formers.formation import form_image
from sarcli.core.grid import Grid
from sarcli.core.types import PhaseHistory, Truth
from sarcli.io.hdf5 import read_phase_history, write_phase_history
from .conftest import spy_rows

pytestmark = [
    # a schema-invalid SICD makes sarkit's NitfWriter warn: treat that as a failure
    pytest.mark.filterwarnings("error::UserWarning"),
    # sarkit 1.8 reads its schemas with importlib.resources' legacy API
    pytest.mark.filterwarnings("ignore:.*is deprecated. Use files\\(\\) instead:DeprecationWarning"),
]

POINTS = np.array([[0.0, 0.0, 0.0], [5.0, -3.0, 0.0], [-8.0, 6.0, 0.0]])
AMPS = np.array([1.0, 0.5j, 0.7])
OHIO = {"scene_center_lat_deg": 39.78, "scene_center_lon_deg": -84.06}


def spherical_ph(P=48, M=40, *, attrs=None, r0_offset=0.0, dtype=np.complex128):
    """Spherical phase history of three points (closed form from geometry.signal_phase)."""
    f = 9.6e9 + np.arange(M) * 3e6
    az = np.pi / 3 + np.radians(np.linspace(-2.5, 2.5, P))
    el = np.full(P, np.radians(30.0))
    pos = geometry.antenna_positions_circle(az, el, 8e3)
    r0 = np.linalg.norm(pos, axis=1) + r0_offset
    psi = geometry.signal_phase(f, az, el, POINTS, model="spherical", antenna_position_m=pos,
                                range_to_center_m=r0)
    data = (np.exp(-1j * psi) @ AMPS).astype(dtype)
    acq = Acquisition(f, az, el, Grid.square(16.0, 32), antenna_position_m=pos, range_to_center_m=r0,
                      model="spherical", name="three-points")
    return PhaseHistory(data, acq, Truth(POINTS, AMPS), dict(attrs or {}))


def matched_filter(ph: PhaseHistory, grid: Grid) -> np.ndarray:
    """Brute-force spherical matched filter (docs/conventions.md eq. mf, no window)."""
    acq = ph.acquisition
    pts = grid.points().reshape(-1, 3)
    psi = geometry.signal_phase(acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad, pts,
                                model="spherical", antenna_position_m=acq.antenna_position_m,
                                range_to_center_m=acq.range_to_center_m)
    img = np.einsum("pm,pms->s", np.asarray(ph.data, np.complex128), np.exp(1j * psi))
    return (img / ph.data.size).reshape(grid.shape)


def _rel(a, b):
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


# --------------------------------------------------------------------------------------------
# CPHD
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("attrs", [None, OHIO], ids=["placeholder-site", "ohio"])
def test_cphd_round_trip(tmp_path, attrs):
    ph = spherical_ph(attrs=attrs)
    out = write_cphd(ph, tmp_path / "a.cphd")
    back = read_cphd(out)
    a, b = ph.acquisition, back.acquisition
    assert back.model == "spherical"
    assert back.data.shape == ph.data.shape
    assert np.max(np.abs(back.data - ph.data)) <= 1e-6 * np.max(np.abs(ph.data))
    np.testing.assert_allclose(b.antenna_position_m, a.antenna_position_m, rtol=0, atol=1e-6)
    np.testing.assert_allclose(b.range_to_center_m, a.range_to_center_m, rtol=1e-12)
    np.testing.assert_allclose(b.azimuth_rad, a.azimuth_rad, rtol=0, atol=1e-10)
    np.testing.assert_allclose(b.elevation_rad, a.elevation_rad, rtol=0, atol=1e-10)
    np.testing.assert_allclose(b.frequency_hz, a.frequency_hz, rtol=1e-14)
    assert b.grid == a.grid
    if attrs:
        assert back.attrs["scene_center_lat_deg"] == pytest.approx(39.78, abs=1e-9)
        assert back.attrs["scene_center_lon_deg"] == pytest.approx(-84.06, abs=1e-9)


def test_cphd_passes_sarkit_consistency(tmp_path):
    import sarkit.verification as skver

    out = write_cphd(spherical_ph(attrs=OHIO), tmp_path / "a.cphd")
    with open(out, "rb") as f:
        con = skver.CphdConsistency.from_file(f, thorough=True)
        con.check()
    assert not con.failures(), con.failures()


def _form(ph, grid):
    """The library's exact matched filter (``form_image``, method ``direct``): independent of
    :func:`matched_filter`, so a CPHD round trip is checked by two implementations."""
    return np.asarray(form_image(ph, method="direct", grid=grid).image)


def test_cphd_image_equals_original(tmp_path):
    # r0 != |a| (motion-compensated reference): the writer folds the phase into the signal
    ph = spherical_ph(attrs=OHIO, r0_offset=2.5)
    back = read_cphd(write_cphd(ph, tmp_path / "mc.cphd"))
    assert np.allclose(back.acquisition.range_to_center_m, np.linalg.norm(ph.acquisition.antenna_position_m, axis=1))
    grid = ph.acquisition.grid
    ref = matched_filter(ph, grid)
    img = matched_filter(back, grid)
    assert _rel(img, ref) <= 1e-6
    # the unit point at the centre peaks at ~1 in both (three points, some sidelobe leakage)
    r, c = grid.index_of(0.0, 0.0)
    assert abs(img[r, c]) == pytest.approx(1.0, abs=0.05)
    assert _rel(_form(back, grid), _form(ph, grid)) <= 1e-6


def test_cphd_rejects_nonuniform_and_farfield(tmp_path):
    ph = spherical_ph()
    f = ph.acquisition.frequency_hz.copy()
    f[5] += 1e5
    bad = PhaseHistory(ph.data, ph.acquisition.with_(frequency_hz=f))
    with pytest.raises(SarcliInputError, match="equally spaced"):
        write_cphd(bad, tmp_path / "x.cphd")
    ff = PhaseHistory(ph.data, ph.acquisition.with_(antenna_position_m=None, range_to_center_m=None,
                                                    model="farfield"))
    with pytest.raises(SarcliInputError, match="antenna positions"):
        write_cphd(ff, tmp_path / "y.cphd")
    assert not (tmp_path / "x.cphd").exists() and not (tmp_path / "y.cphd").exists()


def test_cphd_cli_round_trip_and_truncated(tmp_path):
    # through the group, as a user runs it (a command invoked alone caches click's help option
    # without -h, and docs/cli.md's check would then see it)
    def import_cphd(args):
        return runner.invoke(cli, ["import", "cphd", *args])

    ph = spherical_ph(attrs=OHIO)
    src = tmp_path / "ph.h5"
    write_phase_history(src, ph)
    runner = CliRunner()
    res = runner.invoke(cli, ["export-cphd", str(src), "-o", str(tmp_path / "a.cphd")])
    assert res.exit_code == 0, res.output
    res = import_cphd([str(tmp_path / "a.cphd"), "-o", str(tmp_path / "b.h5")])
    assert res.exit_code == 0, res.output
    back = read_phase_history(tmp_path / "b.h5")
    assert np.max(np.abs(back.data - ph.data)) <= 1e-6 * np.max(np.abs(ph.data))
    # truncated file: one line, exit 2, no output
    raw = (tmp_path / "a.cphd").read_bytes()
    for n in (len(raw) - 1000, 200, 3):
        (tmp_path / "t.cphd").write_bytes(raw[:n])
        with pytest.raises(InputFileError):
            read_cphd(tmp_path / "t.cphd")
        res = import_cphd([str(tmp_path / "t.cphd"), "-o", str(tmp_path / "t.h5")])
        assert res.exit_code == 2, (n, res.output)
        assert res.output.count("\n") == 1 and res.output.startswith("error:"), res.output
        assert not (tmp_path / "t.h5").exists()


# --------------------------------------------------------------------------------------------
# SICD
# --------------------------------------------------------------------------------------------
def _sicd_case(look_azimuth_rad, attrs=OHIO):
    """A collection whose k-space support is sampled at an oversampling of 1.1-2.2 by 0.75 m pixels."""
    M, P = 40, 32
    f = 9.6e9 + np.arange(M) * 3e6  # 117 MHz: 0.68 cycles/m of range support
    az = look_azimuth_rad + np.radians(np.linspace(-0.4, 0.4, P))  # 0.8°: 0.78 cycles/m across
    el = np.full(P, np.radians(30.0))
    pos = geometry.antenna_positions_circle(az, el, 8e3)
    grid = Grid(40, 24, 0.75, 0.75, 0.0, 0.0)  # rectangular, to catch transposes
    acq = Acquisition(f, az, el, grid, antenna_position_m=pos, model="spherical")
    ph = PhaseHistory(np.zeros((P, M), np.complex64), acq, attrs=dict(attrs or {}))
    rng = np.random.default_rng(3)
    im = (rng.standard_normal(grid.shape) + 1j * rng.standard_normal(grid.shape)).astype(np.complex64)
    from sarcli.core.types import Image

    return Image(im, grid.x, grid.y, method="backprojection", attrs=dict(attrs or {})), ph


def _sicd_failures(path):
    import sarkit.verification as skver

    with open(path, "rb") as f:
        con = skver.SicdConsistency.from_file(f)
        con.check()
    return con.failures(), len(con.passes())


@pytest.mark.parametrize("look_deg, row_name, to_sicd", [
    (-90.0, "south", lambda a: a[::-1, :]),  # antenna north of the scene: north-up rows
    (0.0, "east", lambda a: a.T),
    (90.0, "north", lambda a: a[:, ::-1]),
    (200.0, "west", lambda a: a.T[::-1, ::-1]),
])
def test_sicd_round_trip_and_consistency(tmp_path, look_deg, row_name, to_sicd):
    import sarkit.sicd as sksicd

    from sarcli.io.export import export_image
    from sarcli.io.sicd import read_sicd

    img, ph = _sicd_case(np.radians(look_deg))
    out = tmp_path / "a.sicd"
    export_image(img, out, phase_history=ph)
    failures, n_pass = _sicd_failures(out)
    assert not failures, list(failures)
    assert n_pass > 30
    with open(out, "rb") as f, sksicd.NitfReader(f) as r:
        pixels = r.read_image()
        xml = r.metadata.xmltree
    np.testing.assert_array_equal(pixels, to_sicd(img.image))
    assert xml.findtext("{*}Grid/{*}ImagePlane") == "GROUND"
    lat, lon = (float(xml.findtext(f"{{*}}GeoData/{{*}}SCP/{{*}}LLH/{{*}}{k}")) for k in ("Lat", "Lon"))
    assert (lat, lon) == pytest.approx((39.78, -84.06), abs=1e-9)
    # KCtr along the row: the projected centre of the k-space support, 2 f cosφ / c ≈ 55.8 cycles/m
    kctr = float(xml.findtext("{*}Grid/{*}Row/{*}KCtr"))
    assert kctr == pytest.approx(2 * 9.6585e9 * np.cos(np.radians(30)) / geometry.C
                                 * abs(np.cos(np.radians(look_deg) - {"south": -np.pi / 2, "east": 0,
                                                                      "north": np.pi / 2, "west": np.pi}[row_name])),
                                 rel=2e-3)
    back = read_sicd(out)
    np.testing.assert_array_equal(back.image, img.image)
    np.testing.assert_allclose(back.x_m, img.x_m, atol=1e-9)
    np.testing.assert_allclose(back.y_m, img.y_m, atol=1e-9)


def test_sicd_without_phase_history_is_nominal_and_consistent(tmp_path):
    import sarkit.sicd as sksicd

    from sarcli.io.sicd import write_sicd

    img, _ = _sicd_case(0.0, attrs=None)
    out = tmp_path / "n.nitf"
    info = write_sicd(img, out)
    assert info["nominal"] and info["reference"].is_default and info["name"] == "south"
    failures, _ = _sicd_failures(out)
    assert not failures, list(failures)
    with open(out, "rb") as f, sksicd.NitfReader(f) as r:
        notes = " ".join(e.text for e in r.metadata.xmltree.findall("{*}CollectionInfo/{*}Parameter"))
        np.testing.assert_array_equal(r.read_image(), img.image[::-1])
    assert "NOMINAL" in notes and "PLACEHOLDER" in notes


def test_sicd_rejects_real_kinds_and_corrupt_input(tmp_path):
    from sarcli.io.export import export_image
    from sarcli.io.hdf5 import write_image

    img, ph = _sicd_case(-np.pi / 2)
    with pytest.raises(SarcliInputError, match="complex"):
        export_image(img, tmp_path / "x.sicd", kind="magnitude")
    out = tmp_path / "a.sicd"
    export_image(img, out, phase_history=ph)
    raw = out.read_bytes()
    runner = CliRunner()
    for n in (len(raw) - 100, 1500, 2):
        bad = tmp_path / "bad.sicd"
        bad.write_bytes(raw[:n])
        res = runner.invoke(cli, ["export", str(bad), "-o", str(tmp_path / "o.png")])
        assert res.exit_code == 2, (n, res.output)
        assert res.output.count("\n") == 1 and res.output.startswith("error:"), res.output
        assert not (tmp_path / "o.png").exists()
    # the CLI: sarcli image + phase history -> SICD -> PNG
    write_image(tmp_path / "img.h5", img)
    write_phase_history(tmp_path / "ph.h5", ph)
    res = runner.invoke(cli, ["export", str(tmp_path / "img.h5"), "-o", str(tmp_path / "c.nitf"),
                              "--phase-history", str(tmp_path / "ph.h5")])
    assert res.exit_code == 0, res.output
    assert not _sicd_failures(tmp_path / "c.nitf")[0]
    res = runner.invoke(cli, ["export", str(tmp_path / "c.nitf"), "-o", str(tmp_path / "c.png")])
    assert res.exit_code == 0, res.output


from .conftest import GOTCHA_FILES  # noqa: E402


@pytest.mark.gotcha
def test_cphd_round_trip_gotcha(tmp_path):
    """Real data: one degree of GOTCHA (float32 frequencies, autofocus r0 != |a|) through CPHD."""
    files = GOTCHA_FILES[:1]
    from sarcli.io.gotcha import read_gotcha

    ph = read_gotcha(files, autofocus=True)
    ph = PhaseHistory(ph.data, ph.acquisition, attrs={**ph.attrs, **OHIO})
    back = read_cphd(write_cphd(ph, tmp_path / "g.cphd"))
    import sarkit.verification as skver

    with open(tmp_path / "g.cphd", "rb") as f:
        con = skver.CphdConsistency.from_file(f, thorough=True)
        con.check()
    assert not con.failures(), list(con.failures())
    a, b = ph.acquisition, back.acquisition
    np.testing.assert_allclose(b.antenna_position_m, a.antenna_position_m, rtol=0, atol=1e-5)
    step = float(np.median(np.diff(a.frequency_hz)))
    assert np.max(np.abs(b.frequencies_2d - a.frequencies_2d)) <= 0.01 * step
    grid = Grid(16, 16, 0.5, 0.5, 0.0, 0.0)
    ref = matched_filter(ph, grid)
    img = matched_filter(back, grid)
    assert _rel(img, ref) <= 1e-3


def test_sicd_window_broadens_impulse_response_width(tmp_path):
    import sarkit.sicd as sksicd

    from sarcli.io.sicd import write_sicd

    img, ph = _sicd_case(-np.pi / 2)
    widths = {}
    for window in ("none", "hamming"):
        img.parameters = {"window": window}
        write_sicd(img, tmp_path / f"{window}.sicd", phase_history=ph)
        with open(tmp_path / f"{window}.sicd", "rb") as f, sksicd.NitfReader(f) as r:
            x = r.metadata.xmltree
        widths[window] = (float(x.findtext("{*}Grid/{*}Row/{*}ImpRespWid"))
                          * float(x.findtext("{*}Grid/{*}Row/{*}ImpRespBW")))
        assert not _sicd_failures(tmp_path / f"{window}.sicd")[0]
    assert widths["none"] == pytest.approx(0.8859, rel=1e-9)
    assert widths["hamming"] == pytest.approx(1.30, rel=0.01)  # textbook Hamming IRW (Harris 1978)


def test_cphd_foreign_sign_convention(tmp_path):
    """A file written with SGN = +1 (conjugate convention) reads back as the same phase history."""
    import lxml.etree
    import sarkit.cphd as skcphd

    ph = spherical_ph()
    write_cphd(ph, tmp_path / "a.cphd")
    with open(tmp_path / "a.cphd", "rb") as f, skcphd.Reader(f) as r:
        xml = lxml.etree.fromstring(lxml.etree.tostring(r.metadata.xmltree)).getroottree()
        sig, pvp = r.read_channel("1")
    xml.find("{*}Global/{*}SGN").text = "1"
    with open(tmp_path / "b.cphd", "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=xml)) as w:
        w.write_signal("1", np.conj(sig).astype(np.complex64))
        w.write_pvp("1", pvp)
    back = read_cphd(tmp_path / "b.cphd")
    assert np.max(np.abs(back.data - ph.data)) <= 1e-6 * np.max(np.abs(ph.data))


# --------------------------------------------------------------------------------------------
# Exact CPHD geometry: a fixture library built from the public example XML of the standard
# --------------------------------------------------------------------------------------------
EXAMPLE_XML = Path(__file__).resolve().parent / "data" / "example-cphd-1.1.0-small.xml"
SITES = {"equator": (0.0, 0.0), "60N": (60.0, 25.0), "85S": (-85.0, 140.0), "antimeridian": (10.0, 180.0)}
FIXTURE_POINTS = np.array([[0.0, 0.0], [4.0, -3.0], [-6.0, 5.0], [7.5, 6.5]])
FIXTURE_AMPS = np.array([1.0, 0.8j, 0.6, -0.5])


def _enu_rows(lat_deg, lon_deg):
    """East, north, up of a geodetic point in ECF, written out here (independent of sarcli)."""
    la, lo = np.radians(lat_deg), np.radians(lon_deg)
    return np.array([[-np.sin(lo), np.cos(lo), 0.0],
                     [-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)],
                     [np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)]])


def _two_way(tx, rcv, pts):
    """|t - x| + |q - x| (m) for positions [P, 3] and ECF points [S, 3] -> [P, S]."""
    return (np.linalg.norm(tx[:, None, :] - pts[None], axis=-1)
            + np.linalg.norm(rcv[:, None, :] - pts[None], axis=-1))


def make_cphd_fixture(path, *, site="equator", bistatic=False, enu_axes=True, P=48, M=48,
                      grid=Grid(40, 40, 0.5, 0.5, 0.0, 0.0)):
    """A small CPHD file: the example's orbit and band moved to ``site``, point targets inside.

    Transmit and receive positions are solved at their own times (the receiver hears the SRP echo
    ``|Tx - SRP| + |Rcv - SRP| = c (t_rcv - t_tx)`` later, ~80 m further along the orbit); with
    ``bistatic`` the receiver is a second platform 20 km east and 3 km higher. Returns the ECF
    geometry the signal was computed from (the independent matched filter uses only that).
    """
    import lxml.etree
    import sarkit.cphd as skcphd
    from sarkit import wgs84

    tree = lxml.etree.parse(str(EXAMPLE_XML))
    x = lambda p: tree.find(p)  # noqa: E731
    vec = lambda p: np.array([float(x(f"{p}/{{*}}{c}").text) for c in "XYZ"])  # noqa: E731
    iarp0 = vec("{*}SceneCoordinates/{*}IARP/{*}ECF")
    arp0 = vec("{*}ReferenceGeometry/{*}Monostatic/{*}ARPPos")
    vel0 = vec("{*}ReferenceGeometry/{*}Monostatic/{*}ARPVel")
    tref = float(x("{*}ReferenceGeometry/{*}ReferenceTime").text)
    b0 = _enu_rows(0.0, 0.0)
    arp_l, vel_l = b0 @ (arp0 - iarp0), b0 @ vel0  # the example's orbit in its local frame
    lat, lon = SITES[site]
    iarp = wgs84.geodetic_to_cartesian([lat, lon, 0.0])
    basis = _enu_rows(lat, lon)
    rcv_offset = np.array([20e3, 0.0, 3e3]) if bistatic else np.zeros(3)
    t_tx = np.linspace(0.0, float(x("{*}Global/{*}Timeline/{*}TxTime2").text), P)
    tx_pos = lambda t: iarp + (arp_l + np.multiply.outer(t - tref, vel_l)) @ basis  # noqa: E731
    rcv_pos = lambda t: tx_pos(t) + rcv_offset @ basis  # noqa: E731
    tx = tx_pos(t_tx)
    t_rcv = t_tx + 2 * np.linalg.norm(tx - iarp, axis=1) / geometry.C
    for _ in range(5):  # fixed point of the echo time
        t_rcv = t_tx + (np.linalg.norm(tx - iarp, axis=1) + np.linalg.norm(rcv_pos(t_rcv) - iarp, axis=1)) / geometry.C
    rcv = rcv_pos(t_rcv)
    fx_min, fx_max = float(x("{*}Global/{*}FxBand/{*}FxMin").text), float(x("{*}Global/{*}FxBand/{*}FxMax").text)
    scss = (fx_max - fx_min) / (M - 1)
    freq = fx_min + scss * np.arange(M)
    pts = iarp + np.column_stack([FIXTURE_POINTS, np.zeros(len(FIXTURE_POINTS))]) @ basis
    dr = _two_way(tx, rcv, pts) - _two_way(tx, rcv, iarp[None])  # [P, S], SGN = -1
    sig = np.einsum("pjs,s->pj", np.exp(-2j * np.pi * freq[None, :, None] * dr[:, None, :] / geometry.C),
                    FIXTURE_AMPS).astype(np.complex64)
    # the XML: new site, sizes, grid, collect type
    for c, v in zip("XYZ", iarp):
        x(f"{{*}}SceneCoordinates/{{*}}IARP/{{*}}ECF/{{*}}{c}").text = repr(float(v))
    for tag, v in zip(("Lat", "Lon", "HAE"), (lat, lon, 0.0)):
        x(f"{{*}}SceneCoordinates/{{*}}IARP/{{*}}LLH/{{*}}{tag}").text = repr(float(v))
    if enu_axes:
        for ax, row in (("uIAX", basis[0]), ("uIAY", basis[1])):
            for c, v in zip("XYZ", row):
                x(f"{{*}}SceneCoordinates/{{*}}ReferenceSurface/{{*}}Planar/{{*}}{ax}/{{*}}{c}").text = repr(float(v))
    g = "{*}SceneCoordinates/{*}ImageGrid/"
    x(g + "{*}IARPLocation/{*}Line").text = str(grid.nx // 2)
    x(g + "{*}IARPLocation/{*}Sample").text = str(grid.ny // 2)
    x(g + "{*}IAXExtent/{*}LineSpacing").text = repr(grid.dx)
    x(g + "{*}IAXExtent/{*}NumLines").text = str(grid.nx)
    x(g + "{*}IAYExtent/{*}SampleSpacing").text = repr(grid.dy)
    x(g + "{*}IAYExtent/{*}NumSamples").text = str(grid.ny)
    x("{*}Data/{*}Channel/{*}NumVectors").text = str(P)
    x("{*}Data/{*}Channel/{*}NumSamples").text = str(M)
    x("{*}Channel/{*}Parameters/{*}RefVectorIndex").text = str(P // 2)
    x("{*}CollectionID/{*}CollectType").text = "BISTATIC" if bistatic else "MONOSTATIC"
    pvp = np.zeros(P, dtype=skcphd.get_pvp_dtype(tree))
    pvp["TxTime"], pvp["TxPos"], pvp["TxVel"] = t_tx, tx, np.broadcast_to(vel_l @ basis, (P, 3))
    pvp["RcvTime"], pvp["RcvPos"], pvp["RcvVel"] = t_rcv, rcv, np.broadcast_to(vel_l @ basis, (P, 3))
    pvp["SRPPos"] = iarp
    pvp["SC0"], pvp["SCSS"], pvp["FX1"], pvp["FX2"] = fx_min, scss, fx_min, fx_max
    pvp["TOA1"], pvp["TOA2"] = (float(x(f"{{*}}Global/{{*}}TOASwath/{{*}}TOA{m}").text) for m in ("Min", "Max"))
    pvp["SIGNAL"] = 1
    with open(path, "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=tree)) as w:
        w.write_signal("1", sig)
        w.write_pvp("1", pvp)
    return {"tx": tx, "rcv": rcv, "srp": iarp, "basis": basis, "freq": freq, "signal": sig}


def independent_matched_filter(fx, grid: Grid) -> np.ndarray:
    """eq. mf straight from the file's ECF geometry: (1/PM) Σ d exp(+i 2π f ΔR / c)."""
    xy = grid.points().reshape(-1, 3)
    pts = fx["srp"] + xy @ fx["basis"]
    dr = _two_way(fx["tx"], fx["rcv"], pts) - _two_way(fx["tx"], fx["rcv"], fx["srp"][None])
    e = np.exp(2j * np.pi * fx["freq"][None, :, None] * dr[:, None, :] / geometry.C)
    return (np.einsum("pj,pjs->s", fx["signal"].astype(np.complex128), e) / fx["signal"].size).reshape(grid.shape)


@pytest.mark.parametrize("site", list(SITES))
def test_enu_frame_at_any_site(site):
    from sarcli.io.georef import ReferencePoint, ecf_to_enu, enu_basis, enu_to_ecf

    lat, lon = SITES[site]
    ref = ReferencePoint(lat, lon, 120.0)
    basis = enu_basis(ref)
    np.testing.assert_allclose(basis, _enu_rows(lat, lon), atol=1e-12)
    np.testing.assert_allclose(basis @ basis.T, np.eye(3), atol=1e-12)
    enu = np.array([[10.0, -20.0, 3.0], [-1.5e6, 2e5, 8e5]])
    np.testing.assert_allclose(ecf_to_enu(enu_to_ecf(enu, ref), ref), enu, rtol=0, atol=1e-7)


@pytest.mark.parametrize("site, bistatic", [("equator", False), ("60N", False), ("85S", False),
                                            ("antimeridian", False), ("60N", True)])
def test_cphd_fixture_exact_two_way_geometry(tmp_path, site, bistatic):
    """Spaceborne geometry (1700 km, Tx and Rcv ~80 m apart): direct and backprojection match an
    independent matched filter; the midpoint antenna with the mean range does not."""
    from sarcli.formers.formation import form_image

    fx = make_cphd_fixture(tmp_path / "f.cphd", site=site, bistatic=bistatic)
    ph = read_cphd(tmp_path / "f.cphd")
    acq = ph.acquisition
    assert acq.is_bistatic and ph.attrs["collect_type"] == ("BISTATIC" if bistatic else "MONOSTATIC")
    sep = np.linalg.norm(acq.transmit_position_m - acq.receive_position_m, axis=1)
    assert 50 < sep.min() and (sep.max() < 200 or bistatic)
    grid = acq.grid
    assert grid == Grid(40, 40, 0.5, 0.5, 0.0, 0.0)
    ref = independent_matched_filter(fx, grid)
    assert abs(ref[grid.index_of(0.0, 0.0)]) == pytest.approx(1.0, abs=0.05)
    direct = form_image(ph, method="direct").image
    bp = form_image(ph, method="backprojection").image
    assert _rel(direct, ref) <= 2e-5
    assert _rel(bp, ref) <= 2e-3
    # what the midpoint antenna with the mean range gives: a phase error
    mid = PhaseHistory(ph.data, acq.with_(transmit_position_m=None, receive_position_m=None))
    assert _rel(form_image(mid, method="direct").image, ref) > 0.1
    # and through our own HDF5 contract and CPHD writer, the geometry survives
    write_phase_history(tmp_path / "f.h5", ph)
    back = read_phase_history(tmp_path / "f.h5")
    np.testing.assert_array_equal(back.acquisition.transmit_position_m, acq.transmit_position_m)
    np.testing.assert_array_equal(back.acquisition.receive_position_m, acq.receive_position_m)
    again = read_cphd(write_cphd(back, tmp_path / "g.cphd"))
    assert _rel(form_image(again, method="direct").image, ref) <= 2e-5
    import sarkit.verification as skver

    with open(tmp_path / "g.cphd", "rb") as f:  # separate Tx/Rcv written: still consistent
        con = skver.CphdConsistency.from_file(f, thorough=True)
        con.check()
    failures = dict(con.failures())
    if site == "antimeridian":
        # sarkit's corner check orders the lat/lon corners without unwrapping longitude, so a
        # quadrilateral across ±180° looks self-intersecting to it; the geometry above is right
        failures.pop("check_image_area_corner_points", None)
    assert not failures, list(failures)


def test_cphd_rotated_image_axes_warn(tmp_path):
    from sarcli.io.georef import GeometryWarning

    make_cphd_fixture(tmp_path / "r.cphd", enu_axes=False)
    with pytest.warns(GeometryWarning, match="ImageGrid not used"):
        ph = read_cphd(tmp_path / "r.cphd")
    assert ph.acquisition.grid.cx == 0.0 and ph.acquisition.grid.cy == 0.0


def test_monostatic_bistatic_range_is_bit_identical():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(7, 3)) * 1e4
    r0 = np.linalg.norm(a, axis=1) + 0.25
    pts = rng.normal(size=(5, 3)) * 10
    assert np.array_equal(geometry.bistatic_differential_range(a, a.copy(), r0, pts),
                          geometry.differential_range(a, r0, pts))
    q = a + 40.0
    half = geometry.bistatic_differential_range(a, q, r0, pts)
    exact = 0.5 * (np.linalg.norm(a[:, None] - pts, axis=-1) + np.linalg.norm(q[:, None] - pts, axis=-1)) - r0[:, None]
    np.testing.assert_allclose(half, exact, rtol=0, atol=1e-9)


def test_phase_history_without_tx_rx_still_reads(tmp_path):
    import h5py

    ph = spherical_ph()
    write_phase_history(tmp_path / "a.h5", ph)
    with h5py.File(tmp_path / "a.h5", "r") as f:
        assert "transmit_position_m" not in f
    back = read_phase_history(tmp_path / "a.h5")
    assert back.acquisition.transmit_position_m is None and not back.acquisition.is_bistatic


# --------------------------------------------------------------------------------------------
# CPHD -> SICD in one command
# --------------------------------------------------------------------------------------------
def test_form_image_cphd_to_sicd_true_geometry(tmp_path):
    """``sar form-image FILE.cphd -o IMG.sicd``: the collection's own times, positions and band;
    sarkit's SICD checker reports no errors and no warnings."""
    import sarkit.sicd as sksicd

    fx = make_cphd_fixture(tmp_path / "f.cphd", site="60N")
    res = CliRunner().invoke(cli, ["form-image", str(tmp_path / "f.cphd"), "-o", str(tmp_path / "f.sicd"),
                                   "--method", "backprojection", "--pixel-size", "0.6", "--extent", "24"])
    assert res.exit_code == 0, res.output
    failures, n_pass = _sicd_failures(tmp_path / "f.sicd")
    assert not failures, list(failures)  # neither errors nor warnings
    assert n_pass > 40
    with open(tmp_path / "f.sicd", "rb") as f, sksicd.NitfReader(f) as r:
        x = r.metadata.xmltree
    assert x.findtext("{*}Timeline/{*}CollectStart").startswith("2022-12-05T18:41:24")
    assert x.findtext("{*}CollectionInfo/{*}CollectorName") == "Synthetic"
    assert float(x.findtext("{*}RadarCollection/{*}TxFrequency/{*}Min")) == pytest.approx(fx["freq"][0])
    assert float(x.findtext("{*}RadarCollection/{*}TxFrequency/{*}Max")) == pytest.approx(fx["freq"][-1])
    # the ARP at the centre of aperture is the collection's (midpoint of Tx and Rcv), ~1700 km out
    t_coa = float(x.findtext("{*}SCPCOA/{*}SCPTime"))
    arp = np.array([float(x.findtext(f"{{*}}SCPCOA/{{*}}ARPPos/{{*}}{c}")) for c in "XYZ"])
    ph = read_cphd(tmp_path / "f.cphd")
    t_mid = 0.5 * (ph.acquisition.extra["tx_time_s"] + ph.acquisition.extra["rcv_time_s"])
    mid = 0.5 * (fx["tx"] + fx["rcv"])
    expect = np.array([np.interp(t_coa, t_mid, mid[:, i]) for i in range(3)])
    assert np.linalg.norm(arp - expect) < 1.0  # an order-5 fit of a straight orbit segment
    assert 1.6e6 < float(x.findtext("{*}SCPCOA/{*}SlantRange")) < 1.8e6
    assert "synthetic" not in " ".join(e.text for e in x.findall("{*}CollectionInfo/{*}Parameter"))


def test_export_sicd_without_phase_history_warns_nominal(tmp_path):
    from sarcli.io.hdf5 import write_image

    img, _ = _sicd_case(0.0)
    write_image(tmp_path / "img.h5", img)
    res = CliRunner().invoke(cli, ["export", str(tmp_path / "img.h5"), "-o", str(tmp_path / "x.sicd")])
    assert res.exit_code == 0, res.output
    assert "NOMINAL" in res.output and "GeometryWarning" in res.output


# --------------------------------------------------------------------------------------------
# CPHD left on disk: read by blocks of pulses (read_cphd(lazy=True), open_input, form-image, batch)
# --------------------------------------------------------------------------------------------
def _recoded_cphd(src, dst, fmt, *, amp_sf=False, sgn=-1, drop=()):
    """Rewrite the CPHD file ``src`` with sarkit: signal stored as ``fmt`` (CI2, CI4, CI8, CF8,
    CF16), optionally scaled by an ``AmpSF`` PVP, in the SGN = +1 convention, and with vectors
    ``drop`` marked ``SIGNAL = 0``. Returns the samples the reader should give, decoded here."""
    import copy

    import lxml.builder
    import sarkit.cphd as skcphd

    with open(src, "rb") as f, skcphd.Reader(f) as r:
        xml = copy.deepcopy(r.metadata.xmltree)
        sig, pvp0 = r.read_channel("1")
    sig = sig.astype(np.complex128)
    P, M = sig.shape
    xml.find("{*}Data/{*}SignalArrayFormat").text = fmt
    if sgn == 1:
        xml.find("{*}Global/{*}SGN").text = "1"
        sig = np.conj(sig)
    if amp_sf:
        node = xml.find("{*}PVP")
        E = lxml.builder.ElementMaker(namespace=lxml.etree.QName(node).namespace)
        words = int(xml.findtext("{*}Data/{*}NumBytesPVP")) // 8
        node.find("{*}SRPPos").addnext(E.AmpSF(E.Offset(str(words)), E.Size("1"), E.Format("F8")))
        xml.find("{*}Data/{*}NumBytesPVP").text = str(8 * (words + 1))
    pvp = np.zeros(P, dtype=skcphd.get_pvp_dtype(xml))
    for name in pvp0.dtype.names:
        pvp[name] = pvp0[name]
    pvp["SIGNAL"][list(drop)] = 0
    top = {"CI2": 100, "CI4": 30000, "CI8": 2 ** 30}.get(fmt)
    amp = None
    if amp_sf:  # one scale per vector (integer formats: the vector's peak maps near full scale)
        peak = np.max(np.abs(np.column_stack([sig.real, sig.imag])), axis=1)
        amp = peak / top if top else np.linspace(0.5, 2.0, P)
        pvp["AmpSF"] = amp
        sig = sig / amp[:, None]
    elif top:
        sig = sig * (top / np.max(np.abs(np.column_stack([sig.real, sig.imag]))))
    dtype = skcphd.binary_format_string_to_dtype(fmt)
    if top:
        stored = np.zeros((P, M), dtype=dtype)
        stored["real"], stored["imag"] = np.round(sig.real), np.round(sig.imag)
        expect = (stored["real"].astype(np.float32) + 1j * stored["imag"].astype(np.float32)).astype(np.complex64)
    else:
        stored = sig.astype(dtype)
        expect = stored.astype(np.complex64)
    if amp is not None:
        expect = (expect * amp[:, None]).astype(np.complex64)
    if sgn == 1:
        expect = np.conj(expect)
    with open(dst, "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=xml)) as w:
        w.write_signal("1", stored)
        w.write_pvp("1", pvp)
    return np.delete(expect, list(drop), axis=0)


@pytest.mark.parametrize("fmt, amp_sf, sgn, drop", [
    ("CF8", False, -1, ()), ("CF8", True, 1, ()), ("CF16", False, -1, (0, 7)), ("CI2", True, -1, ()),
    ("CI2", False, 1, (3, 4, 5)), ("CI4", True, 1, (10,)), ("CI4", False, -1, ()), ("CI8", True, -1, (47,))])
def test_lazy_cphd_samples_equal_eager_every_format(tmp_path, fmt, amp_sf, sgn, drop):
    """The source left on disk gives exactly the eager reader's samples, and both equal the
    decoding written out above (storage format, AmpSF, SGN, dropped vectors)."""
    from sarcli.io import open_input
    from sarcli.io.cphd import CphdSignal

    write_cphd(spherical_ph(), tmp_path / "a.cphd")
    expect = _recoded_cphd(tmp_path / "a.cphd", tmp_path / "b.cphd", fmt, amp_sf=amp_sf, sgn=sgn, drop=drop)
    eager = read_cphd(tmp_path / "b.cphd")
    fmt_name, lazy = open_input(tmp_path / "b.cphd", lazy=True)
    assert fmt_name == "cphd" and isinstance(lazy.data, CphdSignal)
    assert eager.data.dtype == np.complex64 and lazy.data.dtype == np.complex64
    assert lazy.data.shape == eager.data.shape == expect.shape == (48 - len(drop), 40)
    np.testing.assert_array_equal(eager.data, expect)
    np.testing.assert_array_equal(np.asarray(lazy.data), eager.data)
    P = eager.data.shape[0]
    for key in (slice(0, 5), slice(5, 37), slice(40, None), 3, -1, [0, 2, 3, 4, 30], np.arange(P) % 3 == 0,
                (slice(2, 9), slice(1, 4))):
        np.testing.assert_array_equal(lazy.data[key], eager.data[key])
    np.testing.assert_array_equal(lazy.acquisition.antenna_position_m, eager.acquisition.antenna_position_m)
    if not fmt.startswith("CI"):  # float formats keep the original samples to complex64 rounding
        ref = np.delete(np.asarray(spherical_ph().data), list(drop), axis=0)
        assert np.max(np.abs(eager.data - ref)) <= 1e-6 * np.max(np.abs(ref))


def test_lazy_cphd_of_a_sarkit_written_file(tmp_path):
    """A file built by sarkit directly (the standard's example geometry, bistatic): same samples."""
    fx = make_cphd_fixture(tmp_path / "f.cphd", bistatic=True)
    lazy = read_cphd(tmp_path / "f.cphd", lazy=True)
    np.testing.assert_array_equal(np.asarray(lazy.data), fx["signal"])
    np.testing.assert_array_equal(lazy.data[10:20], fx["signal"][10:20])


@pytest.mark.parametrize("method", ["backprojection", "ffbp"])
def test_lazy_and_eager_cphd_give_the_same_image(tmp_path, method):
    from sarcli.formers.formation import form_image

    make_cphd_fixture(tmp_path / "f.cphd", P=96)
    eager = form_image(read_cphd(tmp_path / "f.cphd"), method)
    lazy = form_image(read_cphd(tmp_path / "f.cphd", lazy=True), method)
    np.testing.assert_allclose(lazy.image, eager.image, rtol=0, atol=1e-12 * np.abs(eager.image).max())


def test_form_image_command_streams_cphd(tmp_path, monkeypatch):
    """`sar form-image X.cphd --method backprojection` reads the signal by blocks, never whole."""
    from sarcli.formers.backprojection._setup import BLOCK as _BLOCK

    P = 2 * _BLOCK + 40
    make_cphd_fixture(tmp_path / "f.cphd", P=P)
    asked = spy_rows(monkeypatch)
    res = CliRunner().invoke(cli, ["form-image", str(tmp_path / "f.cphd"), "-o", str(tmp_path / "img.h5"),
                                   "--method", "backprojection", "--extent", "8"])
    assert res.exit_code == 0, res.output
    assert asked and sum(asked) == P and max(asked) <= _BLOCK, asked


def test_batch_job_streams_cphd(tmp_path, monkeypatch):
    """A `sar batch` job on a CPHD file reads it by blocks and gives the eager image."""
    import yaml

    from sarcli.batch.run import load_plan, run_job
    from sarcli.formers.formation import form_image
    from sarcli.io.hdf5 import read_image

    from sarcli.formers.backprojection._setup import BLOCK as _BLOCK

    P = 2 * _BLOCK + 40
    make_cphd_fixture(tmp_path / "f.cphd", P=P)
    plan = tmp_path / "plan.yaml"
    plan.write_text(yaml.safe_dump({"jobs": [{"input": str(tmp_path / "f.cphd"), "method": "backprojection",
                                              "options": {"nthreads": 1}}]}))
    ref = form_image(read_cphd(tmp_path / "f.cphd"), "backprojection", nthreads=1)
    asked = spy_rows(monkeypatch)
    job, = load_plan(plan).jobs
    res = run_job(job, tmp_path / "out")
    assert res.status == "done", res.error
    assert asked and sum(asked) == P and max(asked) <= _BLOCK, asked
    np.testing.assert_allclose(read_image(tmp_path / "out" / job.name).image, ref.image, rtol=0,
                               atol=1e-12 * np.abs(ref.image).max())


def test_batch_subapertures_of_a_cphd_file(tmp_path):
    """`sar batch` splits a CPHD file into azimuth windows (its geometry read without the signal),
    and each window's image equals the eager reader's subset imaged alone."""
    import yaml

    from sarcli.batch.run import load_plan, run_job
    from sarcli.formers.formation import form_image
    from sarcli.io.hdf5 import read_image

    make_cphd_fixture(tmp_path / "f.cphd", P=96)
    ph = read_cphd(tmp_path / "f.cphd")
    az = np.degrees(np.unwrap(ph.acquisition.azimuth_rad))
    window = 0.51 * float(np.ptp(az))
    plan = tmp_path / "plan.yaml"
    plan.write_text(yaml.safe_dump({"defaults": {"method": "backprojection", "options": {"nthreads": 1}},
                                    "jobs": [{"subapertures": {"input": str(tmp_path / "f.cphd"),
                                                               "window_deg": window, "composite": "max",
                                                               "name": "sub"}}]}))
    windows = [j for j in load_plan(plan).jobs if j.pulses is not None]
    assert len(windows) >= 2
    assert sorted(set(np.concatenate([np.asarray(j.pulses) for j in windows]))) == list(range(96))
    for job in windows:
        res = run_job(job, tmp_path / "out")
        assert res.status == "done", res.error
        sel = np.asarray(job.pulses)
        alone = form_image(PhaseHistory(ph.data[sel], ph.acquisition.subset(pulses=sel)), "backprojection",
                           grid=ph.acquisition.grid, nthreads=1)
        img = read_image(tmp_path / "out" / job.name)
        np.testing.assert_allclose(img.image, alone.image, rtol=0, atol=1e-12 * np.abs(alone.image).max())


def test_bad_cphd_block_read_lazily_is_one_line(tmp_path):
    """A NaN in the signal, or a file cut short after it was opened, is an InputFileError naming
    the file when the block is reached (and one line, exit 2, from the command)."""
    import shutil

    import sarkit.cphd as skcphd

    from sarcli.formers.formation import form_image

    good = write_cphd(spherical_ph(), tmp_path / "a.cphd")
    with open(good, "rb") as f:
        _, kvp = skcphd.read_file_header(f)
    sig0 = int(kvp["SIGNAL_BLOCK_BYTE_OFFSET"])
    bad = tmp_path / "nan.cphd"
    shutil.copyfile(good, bad)
    with open(bad, "r+b") as f:  # vector 30, sample 3: CF8 is big-endian float32 pairs
        f.seek(sig0 + (30 * 40 + 3) * 8)
        f.write(np.array([np.nan], ">f4").tobytes())
    ph = read_cphd(bad, lazy=True)  # nothing read yet
    np.testing.assert_array_equal(ph.data[:16], read_cphd(good).data[:16])
    with pytest.raises(InputFileError, match="NaN/Inf") as exc:
        form_image(ph, "backprojection")
    assert str(bad) in str(exc.value)
    with pytest.raises(InputFileError, match="NaN/Inf"):
        read_cphd(bad)
    res = CliRunner().invoke(cli, ["form-image", str(bad), "-o", str(tmp_path / "img.h5"),
                                   "--method", "backprojection"])
    assert res.exit_code == 2 and res.output.count("\n") == 1 and "NaN/Inf" in res.output, res.output
    assert not (tmp_path / "img.h5").exists()
    cut = tmp_path / "cut.cphd"
    shutil.copyfile(good, cut)
    ph = read_cphd(cut, lazy=True)
    with open(cut, "r+b") as f:  # cut after it was opened: the second half of the pulses is gone
        f.truncate(sig0 + 24 * 40 * 8)
    assert ph.data[:20].shape == (20, 40)
    with pytest.raises(InputFileError, match="truncated or corrupt CPHD file") as exc:
        form_image(ph, "backprojection")
    assert str(cut) in str(exc.value)


def test_compressed_cphd_is_refused_in_one_line(tmp_path):
    """sarkit cannot read rows of a compressed signal array and sarcli cannot decompress one."""
    import copy

    import lxml.builder
    import sarkit.cphd as skcphd

    write_cphd(spherical_ph(), tmp_path / "a.cphd")
    with open(tmp_path / "a.cphd", "rb") as f, skcphd.Reader(f) as r:
        xml = copy.deepcopy(r.metadata.xmltree)
        pvp = r.read_pvps("1")
    data = xml.find("{*}Data")
    E = lxml.builder.ElementMaker(namespace=lxml.etree.QName(data).namespace)
    data.find("{*}NumBytesPVP").addprevious(E.SignalCompressionID("some-codec"))
    data.find("{*}Channel/{*}PVPArrayByteOffset").addnext(E.CompressedSignalSize("100"))
    with open(tmp_path / "c.cphd", "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=xml)) as w:
        w.write_signal("1", np.zeros(100, np.uint8))
        w.write_pvp("1", pvp)
    for lazy in (False, True):
        with pytest.raises(InputFileError, match="compressed CPHD signal array .channel .1., SignalCompressionID .some-codec.*no decoder"):
            read_cphd(tmp_path / "c.cphd", lazy=lazy)


def test_lazy_cphd_memory_does_not_grow_with_pulses(tmp_path):
    """Image fixed, a 4x longer CPHD collection: the traced peak of reading it lazily and forming a
    backprojection image rises by its per-pulse geometry only, at most a tenth of the added signal
    (holding the signal would more than double it)."""
    import gc
    import tracemalloc

    import sarcli

    from .conftest import small_config

    M, P0 = 256, 4096
    grid = Grid.square(4.0, 64)
    files = {}
    for P in (P0, 4 * P0):  # same pulse spacing: the aperture grows with the pulse count
        cfg = small_config(frequencies={"center_frequency_ghz": 10.0, "bandwidth_mhz": 600.0, "count": M},
                           azimuths={"center_deg": 50.0, "extent_deg": 3.0 * P / P0, "count": P})
        files[P] = write_cphd(sarcli.simulate(sarcli.parse_acquisition(cfg), seed=3, snr_db=None),
                              tmp_path / f"p{P}.cphd")
    sarcli.form_image(read_cphd(files[P0], lazy=True), "backprojection", grid=grid)  # plan, warm the caches
    peaks = {}
    for P, path in files.items():
        gc.collect()
        tracemalloc.start()
        try:
            img = sarcli.form_image(read_cphd(path, lazy=True), "backprojection", grid=grid)
            peaks[P] = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert np.all(np.isfinite(img.image))
    # what the 3 P0 more pulses add: their per-pulse geometry (about 110 bytes a pulse: 1.9 MB
    # measured), not their signal (2 KiB a pulse: 25 MB)
    extra_signal = 3 * P0 * M * np.dtype(np.complex64).itemsize
    assert peaks[4 * P0] - peaks[P0] <= 0.1 * extra_signal, peaks
    assert 4 * P0 * M * 8 > 2 * peaks[P0], peaks  # the test can tell: the whole signal would not fit


@pytest.mark.parametrize("look_deg", [-90.0, 0.0, 200.0])
@pytest.mark.parametrize("centre", [(36.0, 0.0), (0.0, -36.0), (300.0, -200.0)])
def test_sicd_of_an_off_centre_grid_reads_back_where_it_was(tmp_path, look_deg, centre):
    """An off-centre grid's rows are the scene centre's cardinal directions, not the SCP's (they
    differ by the offset over the Earth's radius, 6e-6 rad at 36 m): the file reads back with the
    coordinates, scene centre and geolocation it was written with."""
    from sarcli.core.types import Image
    from sarcli.io.export import export_image
    from sarcli.io.geolocate import geolocate
    from sarcli.io.sicd import read_sicd

    img, ph = _sicd_case(np.radians(look_deg))
    img = Image(img.image, img.x_m + centre[0], img.y_m + centre[1], method=img.method, attrs=img.attrs)
    out = tmp_path / "off.sicd"
    export_image(img, out, phase_history=ph)
    back = read_sicd(out)
    np.testing.assert_array_equal(back.image, img.image)
    np.testing.assert_allclose(back.x_m, img.x_m, atol=1e-6)
    np.testing.assert_allclose(back.y_m, img.y_m, atol=1e-6)
    assert back.attrs["scene_center_lat_deg"] == pytest.approx(OHIO["scene_center_lat_deg"], abs=1e-10)
    assert back.attrs["scene_center_lon_deg"] == pytest.approx(OHIO["scene_center_lon_deg"], abs=1e-10)
    assert abs(back.attrs["scene_center_height_m"]) < 1e-6
    rows, cols = np.meshgrid([0, img.image.shape[0] - 1], [0, img.image.shape[1] - 1], indexing="ij")
    a = np.stack(geolocate(img, rows.ravel(), cols.ravel()), axis=-1)
    b = np.stack(geolocate(back, rows.ravel(), cols.ravel()), axis=-1)
    np.testing.assert_allclose(b[:, :2], a[:, :2], atol=1e-10)   # degrees: about 10 µm
    np.testing.assert_allclose(b[:, 2], a[:, 2], atol=1e-6)


@pytest.mark.parametrize("bistatic", [False, True])
def test_regularizer_pair_models_a_cphd_collection_exactly(tmp_path, bistatic):
    """A CPHD collection keeps transmit and receive positions apart (~80 m along the orbit even
    when monostatic): the regulariser's exact pair, whose Aᴴb also feeds the warped operator, is its
    two-way model, so its matched filter matches the independent one (the midpoint model does not)."""
    from sarcli.regularize import matched_filter

    fx = make_cphd_fixture(tmp_path / "f.cphd", site="60N", bistatic=bistatic)
    ph = read_cphd(tmp_path / "f.cphd")
    ref = independent_matched_filter(fx, ph.acquisition.grid)
    assert _rel(matched_filter(ph, operator="spherical"), ref) <= 2e-3
