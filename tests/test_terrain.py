"""Map images on terrain (sar form-image --dem): point targets on a synthetic DEM (a 200 m hill
and a 30° slope), simulated at their true 3-D positions, land within 0.1 pixel of their map
coordinates in the UTM GeoTIFF, measured by reading the file's georeferencing with rasterio.
The flat-plane image's offsets are printed beside them (``-s``; docs/formats.md)."""

import json
import warnings

import numpy as np
import pytest
import tifffile

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.core.grid import Grid
from sarcli.core.types import PhaseHistory

LAT, LON = 45.3, 9.2            # UTM zone 32 N (EPSG:32632)
EPSG = 32632
PIXEL = 0.4
SLOPE = np.tan(np.radians(30.0))


def _transformer(src, dst):
    from pyproj import Transformer

    return Transformer.from_crs(src, dst, always_xy=True)


def _centre_en():
    return _transformer("EPSG:4326", f"EPSG:{EPSG}").transform(LON, LAT)


def terrain(e, n):
    """Heights (m above the ellipsoid) at UTM offsets (e, n) from the scene centre: a 200 m
    Gaussian hill (σ 150 m, its flanks up to 39° steep) at the centre and a 30° slope rising east
    of e = 150 m."""
    return 200.0 * np.exp(-(e ** 2 + n ** 2) / (2 * 150.0 ** 2)) + SLOPE * np.maximum(e - 150.0, 0.0)


def write_dem(path, *, crs="utm", post=2.0, half=400.0, vertical=None, nodata_box=None):
    """A GeoTIFF DEM of :func:`terrain` in UTM (metres) or EPSG:4326 (degrees), PixelIsArea."""
    ec, nc = _centre_en()
    if crs == "utm":
        xs = np.arange(-half, half + post, post) + ec
        ys = np.arange(half, -half - post, -post) + nc
        ee, nn = np.meshgrid(xs, ys)
        code, dx, dy = EPSG, post, post
    else:
        dlat, dlon = post / 111e3, post / (111e3 * np.cos(np.radians(LAT)))
        lats = LAT + np.arange(half / 111e3, -half / 111e3 - dlat, -dlat)
        lons = LON + np.arange(-half / 80e3, half / 80e3 + dlon, dlon)
        lo, la = np.meshgrid(lons, lats)
        ee, nn = _transformer("EPSG:4326", f"EPSG:{EPSG}").transform(lo, la)
        xs, ys, code, dx, dy = lons, lats, 4326, dlon, dlat
    h = terrain(ee - ec, nn - nc).astype(np.float32)
    if nodata_box is not None:
        h[nodata_box] = -9999.0
    key = 3072 if code != 4326 else 2048
    keys = [1, 1, 0, 3, 1024, 0, 1, 1 if code != 4326 else 2, 1025, 0, 1, 1, key, 0, 1, code]
    if vertical:
        keys[3] += 1
        keys += [4096, 0, 1, vertical]
    tags = [(33550, "d", 3, (dx, dy, 0.0)), (33922, "d", 6, (0, 0, 0, xs[0] - dx / 2, ys[0] + dy / 2, 0)),
            (34735, "H", len(keys), keys)]
    if nodata_box is not None:
        tags.append((42113, "s", 0, "-9999"))
    tifffile.imwrite(path, h, extratags=tags)
    return path


def target_position(e, n):
    """A target at UTM offsets (e, n) on the terrain: local ENU (m) and its height."""
    from sarkit import wgs84

    from sarcli.io.georef import ReferencePoint, ecf_to_enu

    ec, nc = _centre_en()
    lon, lat = _transformer(f"EPSG:{EPSG}", "EPSG:4326").transform(ec + e, nc + n)
    h = float(terrain(np.float64(e), np.float64(n)))
    return ecf_to_enu(wgs84.geodetic_to_cartesian([lat, lon, h]), ReferencePoint(LAT, LON, 0.0)), h


def collection(target_enu, P=64, M=64):
    """An airborne spotlight at 8 km, 35° elevation, looking north-east, its reference range that
    to the target (a CPHD's SRP on it), the data those of the one target at its 3-D position."""
    f = 9.6e9 + (300e6 / M) * np.arange(M)
    az = np.radians(np.linspace(-0.9, 0.9, P)) + np.radians(-120.0)
    el = np.full(P, np.radians(35.0))
    pos = geometry.antenna_positions_circle(az, el, 8e3) + np.array([target_enu[0], target_enu[1], 0.0])
    r0 = np.linalg.norm(pos - target_enu, axis=1)
    psi = geometry.signal_phase(f, az, el, [target_enu], model="spherical", antenna_position_m=pos,
                                range_to_center_m=r0)
    acq = Acquisition(f, az, el, Grid.square(8.0, 40), antenna_position_m=pos, range_to_center_m=r0,
                      model="spherical")
    attrs = {"scene_center_lat_deg": LAT, "scene_center_lon_deg": LON, "scene_center_height_m": 0.0}
    return PhaseHistory(np.exp(-1j * psi[..., 0]), acq, attrs=attrs)


def peak(image):
    """Sub-pixel (row, col) of an image's peak: its spectrum's support rolled to the centre, the
    image interpolated 16x by zero-padding, then a parabola through the largest sample."""
    f = np.fft.fft2(image)
    ny, nx = image.shape
    prof_y, prof_x = np.abs(f).sum(axis=1), np.abs(f).sum(axis=0)
    # roll each axis so its spectral energy's circular centre sits at the middle
    sy = int(np.round(np.angle(np.sum(prof_y * np.exp(2j * np.pi * np.arange(ny) / ny))) * ny / (2 * np.pi)))
    sx = int(np.round(np.angle(np.sum(prof_x * np.exp(2j * np.pi * np.arange(nx) / nx))) * nx / (2 * np.pi)))
    f = np.roll(f, (ny // 2 - sy, nx // 2 - sx), axis=(0, 1))
    k = 16
    big = np.zeros((ny * k, nx * k), complex)
    big[(ny * k - ny) // 2:(ny * k + ny) // 2, (nx * k - nx) // 2:(nx * k + nx) // 2] = f
    up = np.abs(np.fft.ifft2(np.fft.ifftshift(big)))
    r, c = np.unravel_index(np.argmax(up), up.shape)

    def vertex(a, b, cc):
        den = a - 2 * b + cc
        return 0.0 if den == 0 else 0.5 * (a - cc) / den

    dr = vertex(up[(r - 1) % up.shape[0], c], up[r, c], up[(r + 1) % up.shape[0], c])
    dc = vertex(up[r, (c - 1) % up.shape[1]], up[r, c], up[r, (c + 1) % up.shape[1]])
    return (r + dr) / k, (c + dc) / k


def geotiff_peak_en(path):
    """Easting / northing of a GeoTIFF's peak, from the file's own georeferencing (rasterio)."""
    rasterio = pytest.importorskip("rasterio")
    with rasterio.open(path) as src:
        img = src.read(1)
        r, c = peak(img)
        e, n = src.transform @ (c + 0.5, r + 0.5)   # (col, row) of a pixel centre
        return e, n, src.crs.to_epsg()


#: UTM offsets from the scene centre: the hilltop (200 m), the flank where it is 30° steep (176 m),
#: and the 30° slope (108 m: 58 m of slope on 50 m of the hill's foot)
TARGETS = {"hilltop": (0.0, 0.0), "hill flank": (60.0, -45.0), "30° slope": (250.0, 20.0)}


@pytest.mark.parametrize("name", list(TARGETS))
@pytest.mark.parametrize("dem_crs", ["utm", "geographic"])
def test_map_geotiff_puts_terrain_targets_within_a_tenth_of_a_pixel(tmp_path, name, dem_crs):
    from sarcli.formers.formation import form_image
    from sarcli.io.export import export_image

    e, n = TARGETS[name]
    enu, h = target_position(e, n)
    ph = collection(enu)
    dem = write_dem(tmp_path / "dem.tif", crs=dem_crs)
    img = form_image(ph, "auto", dem=str(dem), center=(enu[0], enu[1]), extent=12.8, pixel_size=PIXEL)
    assert img.method == "backprojection" and img.parameters["map"]["crs"] == f"EPSG:{EPSG}"
    out = tmp_path / "map.tif"
    export_image(img, out, kind="complex")
    pe, pn, epsg = geotiff_peak_en(out)
    ec, nc = _centre_en()
    off = np.hypot(pe - (ec + e), pn - (nc + n)) / PIXEL
    assert epsg == EPSG
    assert off < 0.1, (name, off, h)
    assert 0.8 < np.abs(img.image).max() <= 1.0 + 1e-3   # focused: a unit point peaks at 1 at its own position


def _flat_offset(name):
    """The flat-plane (z = 0) image's offset of a target from its map position, in pixels."""
    from sarcli.formers.formation import form_image
    from sarcli.io.geolocate import geolocate

    e, n = TARGETS[name]
    enu, h = target_position(e, n)
    ph = collection(enu)
    look = np.array([np.cos(np.radians(-120.0)), np.sin(np.radians(-120.0))])   # the look: the radar is behind
    guess = enu[:2] - look * h * np.tan(np.radians(35.0))   # toward the radar by h tan(elevation)
    img = form_image(ph, "backprojection", center=tuple(guess), extent=25.6, pixel_size=PIXEL)
    r, c = peak(img.image)
    lat, lon, _ = geolocate(img, r, c)
    pe, pn = _transformer("EPSG:4326", f"EPSG:{EPSG}").transform(lon, lat)
    ec, nc = _centre_en()
    return float(np.hypot(pe - (ec + e), pn - (nc + n)) / PIXEL), h


def test_flat_plane_offsets_for_the_docs():
    rows = []
    for name in TARGETS:
        off, h = _flat_offset(name)
        rows.append((name, h, off))
    print("\ntarget, height m, flat-plane offset px (0.4 m pixels)")
    for name, h, off in rows:
        print(f"{name}: {h:.1f} m, {off:.1f} px ({off * PIXEL:.1f} m)")
    hill = dict((r[0], r[2]) for r in rows)["hilltop"]
    assert hill * PIXEL > 100.0   # h tan(35°) = 140 m of layover on the plane


@pytest.fixture()
def cli_case(tmp_path):
    from sarcli.io.hdf5 import write_phase_history

    enu, _ = target_position(*TARGETS["hilltop"])
    ph = collection(enu, P=16, M=16)
    path = tmp_path / "ph.h5"
    write_phase_history(path, ph)
    return tmp_path, path, enu


def _sar(args):
    from click.testing import CliRunner

    from sarcli.cli.main import cli

    return CliRunner().invoke(cli, [str(a) for a in args])


def test_cli_map_image_round_trips_through_geotiff_in_utm(cli_case):
    tmp, ph, enu = cli_case
    dem = write_dem(tmp / "dem.tif", crs="geographic")
    out, tif = tmp / "map.h5", tmp / "map.tif"
    grid = ["--center", f"{enu[0]},{enu[1]}", "--extent", "6.4", "--pixel-size", str(PIXEL)]
    res = _sar(["form-image", ph, "-o", out, "--dem", dem, *grid])
    assert res.exit_code == 0, res.output
    res = _sar(["export", out, "-o", tif, "--crs", f"EPSG:{EPSG}"])
    assert res.exit_code == 0, res.output
    from sarcli.io.geotiff import read_geotiff

    back = read_geotiff(tif)
    assert back.parameters["map"]["crs"] == f"EPSG:{EPSG}"
    ec, nc = _centre_en()
    assert abs(back.x_m.mean() - ec) < 10 and abs(back.y_m.mean() - nc) < 10   # eastings, northings
    with tifffile.TiffFile(tif) as f:
        meta = json.loads(f.pages[0].description)
    assert meta["crs"] == f"EPSG:{EPSG}"


@pytest.mark.parametrize("case, message", [
    ("uncovered", "does not cover the scene"),
    ("not_tiff", "not a GeoTIFF DEM"),
    ("no_georef", "without GeoTIFF georeferencing"),
    ("user_crs", "not an EPSG code"),
    ("nodata", "has no data"),
    ("geoid", "geoid"),
    ("ffbp", "forms the plane z = 0 only"),
    ("bad_crs", "projected CRS in metres"),
    ("unknown_crs", "expected EPSG:NNNN"),
    ("crs_without_dem", "give --dem"),
])
def test_bad_dem_input_is_one_line_exit_2_nothing_written(cli_case, case, message):
    tmp, ph, enu = cli_case
    dem = tmp / "dem.tif"
    extra = []
    if case == "uncovered":
        write_dem(dem, half=100.0)
        enu = enu + np.array([300.0, 0.0, 0.0])
    elif case == "not_tiff":
        dem.write_text("not a raster")
    elif case == "no_georef":
        tifffile.imwrite(dem, np.zeros((4, 4), np.float32))
    elif case == "user_crs":
        tifffile.imwrite(dem, np.zeros((4, 4), np.float32), extratags=[
            (33550, "d", 3, (1.0, 1.0, 0.0)), (33922, "d", 6, (0, 0, 0, 0, 0, 0)),
            (34735, "H", 8, [1, 1, 0, 1, 1024, 0, 1, 32767])])
    elif case == "nodata":
        write_dem(dem, nodata_box=(slice(190, 210), slice(190, 210)))
    elif case == "geoid":
        write_dem(dem, vertical=5773)
    else:
        write_dem(dem)
        extra = {"ffbp": ["--method", "ffbp"], "bad_crs": ["--crs", "EPSG:4326"], "unknown_crs": ["--crs", "UTM32"],
                 "crs_without_dem": ["--crs", "EPSG:32632"]}[case]
    out = tmp / "map.h5"
    args = ["form-image", ph, "-o", out, "--center", f"{enu[0]},{enu[1]}", "--extent", "4", "--pixel-size", "0.5"]
    if case != "crs_without_dem":
        args += ["--dem", dem]
    res = _sar(args + extra)
    if case == "geoid":
        from pyproj import Transformer

        n = Transformer.from_crs("EPSG:4326+5773", "EPSG:4979", always_xy=True).transform(LON, LAT, 0.0)[2]
        if n != 0.0:
            pytest.skip("pyproj has the EGM96 grid here: geoid heights are converted, not refused")
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.strip().splitlines() if ln]
    assert len(lines) == 1 and message in lines[0], res.output
    assert "Traceback" not in res.output
    assert not out.exists() and not list(tmp.glob("*.tmp*")) and not list(tmp.glob(".*map*"))


def test_export_crs_of_a_plane_image_or_another_crs_is_refused(cli_case):
    from sarcli.formers.formation import form_image
    from sarcli.io.hdf5 import read_phase_history, write_image

    tmp, ph_path, enu = cli_case
    ph = read_phase_history(ph_path)
    plane = tmp / "plane.h5"
    with warnings.catch_warnings():   # the plane below the hilltop is outside these data's range window
        warnings.simplefilter("ignore")
        write_image(plane, form_image(ph, "backprojection", center=(enu[0], enu[1]), extent=4, pixel_size=0.5))
    res = _sar(["export", plane, "-o", tmp / "p.tif", "--crs", "EPSG:32632"])
    assert res.exit_code == 2 and "plane image" in res.output and not (tmp / "p.tif").exists()
    dem = write_dem(tmp / "dem.tif")
    mapped = tmp / "map.h5"
    write_image(mapped, form_image(ph, "auto", dem=str(dem), center=(enu[0], enu[1]), extent=4, pixel_size=0.5))
    res = _sar(["export", mapped, "-o", tmp / "m.tif", "--crs", "EPSG:32633"])
    assert res.exit_code == 2 and "EPSG:32632" in res.output and not (tmp / "m.tif").exists()
    res = _sar(["export", mapped, "-o", tmp / "m.sicd"])
    assert res.exit_code == 2 and "not a SICD" in res.output and not (tmp / "m.sicd").exists()


def test_geolocate_refuses_a_map_image(tmp_path):
    from sarcli.errors import SarcliInputError
    from sarcli.formers.formation import form_image
    from sarcli.io.geolocate import geolocate

    enu, _ = target_position(*TARGETS["30° slope"])
    img = form_image(collection(enu, P=8, M=8), "direct", dem=str(write_dem(tmp_path / "d.tif")),
                     center=(enu[0], enu[1]), extent=2.0, pixel_size=0.5)
    assert img.image.shape == (img.y_m.size, img.x_m.size) and img.method == "direct"
    with pytest.raises(SarcliInputError, match="map CRS"):
        geolocate(img, 0, 0)
