"""Geolocation (sarcli.geolocate / sarcli.pixel_of) agrees with sarkit's SICD projection of the
SICD that sarcli exports for the same image (≤ 1 cm over a 1 km scene, with and without heights),
inverts itself to 1e-6 pixel, lays raised points over toward the radar by h·tan(grazing), and
refuses bad input with one line."""

from __future__ import annotations

import numpy as np
import pytest

import sarcli
from sarcli.core.grid import Grid
from sarcli.core.types import Image
from sarcli.errors import SarcliInputError
from sarcli.io.geolocate import image_geometry

from .conftest import small_config

# (lat, lon, hae of the scene centre, look azimuth of the collection in degrees)
CASES = [(34.95, -106.52, 1500.0, -90.0), (-33.9, 18.4, 0.0, 0.0), (78.2, 15.6, 200.0, 135.0),
         (10.0, 179.99, 50.0, 50.0)]


def _collection(look_deg: float):
    cfg = small_config(azimuths={"center_deg": look_deg, "extent_deg": 3.0, "count": 32})
    return sarcli.parse_acquisition(cfg)


def _image(lat, lon, hae):
    """A 1 km x 0.9 km grid, off-centre, non-square pixels; each pixel holds its own flat index."""
    grid = Grid(200, 120, 5.0, 7.5, 30.0, -20.0)
    data = np.arange(grid.ny * grid.nx, dtype=np.float32).reshape(grid.shape).astype(np.complex64)
    attrs = {"scene_center_lat_deg": lat, "scene_center_lon_deg": lon, "scene_center_height_m": hae}
    return Image(data, grid.x, grid.y, method="t", attrs=attrs)


def _exported(tmp_path, img, acq):
    """The SICD's XML and the affine map from sarcli (row, col) to SICD (row, col), read from where
    the exported array put each pixel's index (independent of any frame arithmetic)."""
    import sarkit.sicd as sksicd

    from sarcli.io.sicd import write_sicd

    write_sicd(img, tmp_path / "g.sicd", phase_history=acq)
    with open(tmp_path / "g.sicd", "rb") as f, sksicd.NitfReader(f) as rd:
        xml, arr = rd.metadata.xmltree, rd.read_image()
    nx = img.image.shape[1]
    idx = np.rint(arr.real).astype(int)
    srow, scol = np.indices(arr.shape)
    ours = np.stack([(idx // nx).ravel(), (idx % nx).ravel(), np.ones(idx.size)], axis=1)
    fit, *_ = np.linalg.lstsq(ours, np.stack([srow.ravel(), scol.ravel()], axis=1), rcond=None)
    assert np.allclose(ours @ fit, np.stack([srow.ravel(), scol.ravel()], axis=1), atol=1e-9)
    return xml, fit


def _to_sicd_metres(xml, fit, row, col):
    """sarkit image-grid coordinates (xrow, ycol, metres from the SCP) of sarcli pixels."""
    rc = np.stack([row, col, np.ones_like(row)], axis=-1) @ fit
    scp = np.array([float(xml.findtext("{*}ImageData/{*}SCPPixel/{*}Row")),
                    float(xml.findtext("{*}ImageData/{*}SCPPixel/{*}Col"))])
    ss = np.array([float(xml.findtext("{*}Grid/{*}Row/{*}SS")), float(xml.findtext("{*}Grid/{*}Col/{*}SS"))])
    return (rc - scp) * ss


def _pixels(img, n_random=40, seed=0):
    ny, nx = img.image.shape
    rng = np.random.default_rng(seed)
    fixed = np.array([[0, 0], [0, nx - 1], [ny - 1, 0], [ny - 1, nx - 1], [ny // 2, nx // 2], [ny / 2, nx / 2]],
                     float)
    rand = rng.uniform([-0.5, -0.5], [ny - 0.5, nx - 0.5], size=(n_random, 2))
    rc = np.concatenate([fixed, rand])
    return rc[:, 0], rc[:, 1]


def _ecf(lat, lon, h):
    from sarkit import wgs84

    return wgs84.geodetic_to_cartesian(np.stack([lat, lon, h], axis=-1))


@pytest.mark.parametrize("lat,lon,hae,look", CASES)
def test_geolocate_agrees_with_sarkit_on_the_exported_sicd(tmp_path, lat, lon, hae, look):
    import sarkit.sicd as sksicd
    from sarkit.sicd import projection

    img, acq = _image(lat, lon, hae), _collection(look)
    xml, fit = _exported(tmp_path, img, acq)
    row, col = _pixels(img)
    locs = _to_sicd_metres(xml, fit, row, col)
    meta = projection.MetadataParams.from_xml(xml)
    normal = np.cross(meta.uRow, meta.uCol)
    # in the image plane: sarkit's projection onto the image plane itself
    ref_plane = sksicd.image_to_ground_plane(xml, locs, meta.SCP, normal / np.linalg.norm(normal))[0]
    ours = _ecf(*sarcli.geolocate(img, row, col))
    err0 = np.linalg.norm(ours - ref_plane, axis=-1).max()
    # at heights off the plane: sarkit's constant-HAE projection (its default tolerances)
    errs = [err0]
    for dh in (-100.0, 0.0, 250.0):
        h = np.full(row.shape, hae + dh)
        theirs, _, ok = sksicd.image_to_constant_hae_surface(xml, locs, h)
        assert ok
        ours = _ecf(*sarcli.geolocate(img, row, col, h, phase_history=acq))
        errs.append(np.linalg.norm(ours - theirs, axis=-1).max())
    print(f"max distance to sarkit: plane {errs[0]:.2e} m, heights {max(errs[1:]):.2e} m")
    assert max(errs) < 0.01, errs


@pytest.mark.parametrize("lat,lon,hae,look", CASES[:2])
def test_pixel_of_agrees_with_sarkit_scene_to_image(tmp_path, lat, lon, hae, look):
    import sarkit.sicd as sksicd

    img, acq = _image(lat, lon, hae), _collection(look)
    xml, fit = _exported(tmp_path, img, acq)
    rng = np.random.default_rng(1)
    row, col = _pixels(img, seed=2)
    h = hae + rng.uniform(-100, 300, row.size)
    # scene points: some pixels' plane points moved off the plane to random heights
    la, lo, _ = sarcli.geolocate(img, row, col)
    r, c = sarcli.pixel_of(img, la, lo, h, phase_history=acq)
    loc, _, ok = sksicd.scene_to_image(xml, _ecf(la, lo, h), delta_gp_s2i=1e-6, maxiter=50)
    assert ok
    theirs = _to_sicd_metres(xml, fit, r, c)
    err = np.linalg.norm(theirs - loc, axis=-1).max()
    print(f"pixel_of vs sarkit scene_to_image: {err:.2e} m")
    assert err < 0.01, err


def test_round_trip_to_a_millionth_of_a_pixel():
    img, acq = _image(-33.9, 18.4, 700.0), _collection(20.0)
    row, col = _pixels(img, n_random=200, seed=3)
    back = sarcli.pixel_of(img, *sarcli.geolocate(img, row, col)[:2])
    err0 = np.max(np.abs(np.subtract(back, (row, col))))
    h = 700.0 + np.linspace(-300.0, 900.0, row.size)
    geo = image_geometry(img, acq)  # built once, reused
    back_h = sarcli.pixel_of(geo, *sarcli.geolocate(geo, row, col, h))
    err_h = np.max(np.abs(np.subtract(back_h, (row, col))))
    print(f"round trip: plane {err0:.1e} px, heights {err_h:.1e} px")
    assert err0 < 1e-6 and err_h < 1e-6, (err0, err_h)


def test_a_raised_point_lays_over_toward_the_radar_by_h_tan_grazing():
    """Far from the radar the layover of a point at height h is h·tan φ toward the antenna."""
    img = _image(45.0, 7.0, 0.0)
    cfg = small_config(azimuths={"center_deg": 0.0, "extent_deg": 1.0, "count": 16},
                       geometry={"path": "circle", "standoff_range_m": 1e6})
    acq = sarcli.parse_acquisition(cfg)  # looking east: the antenna is west of the scene
    ny, nx = img.image.shape
    lat, lon, _ = sarcli.geolocate(img, ny // 2, nx // 2)
    r, c = sarcli.pixel_of(img, lat, lon, 100.0, phase_history=acq)
    shift_east_m = (c - nx // 2) * img.grid.dx
    assert abs(r - ny // 2) < 1e-3
    np.testing.assert_allclose(shift_east_m, -100.0 * np.tan(np.radians(30.0)), rtol=2e-3)


def test_vectorised_shapes_broadcast():
    img = _image(10.0, 20.0, 0.0)
    lat, lon, h = sarcli.geolocate(img, np.zeros((3, 1)), np.arange(4.0))
    assert lat.shape == lon.shape == h.shape == (3, 4)
    assert isinstance(sarcli.geolocate(img, 1, 2)[0], float)
    row, col = sarcli.pixel_of(img, lat[0], lon)  # (4,) with (3, 4)
    assert row.shape == (3, 4) and np.allclose(row, 0.0, atol=1e-6) and np.allclose(col, np.arange(4.0), atol=1e-6)


@pytest.mark.parametrize("call,message", [
    (lambda img, acq: sarcli.geolocate(img, np.nan, 3), "row must be finite"),
    (lambda img, acq: sarcli.geolocate(img, 5, 1e6),
     "pixel (row, col) = (5, 1e+06) is far outside the 120 x 200 image: col 1e+06"),
    (lambda img, acq: sarcli.geolocate(img, 5, 5, 100.0), "needs the collection"),
    (lambda img, acq: sarcli.geolocate(img, 5, 5, [np.nan], phase_history=acq), "height must be finite"),
    (lambda img, acq: sarcli.geolocate(img, 5, 5, 1e9, phase_history=acq), "does not reach"),
    (lambda img, acq: sarcli.pixel_of(img, 95.0, 0.0), "latitude 95 is outside"),
    (lambda img, acq: sarcli.pixel_of(img, 34.0, -106.52), "point (lat, lon) = (34, -106.52) is far outside"),
    (lambda img, acq: sarcli.pixel_of(img, 34.95, np.nan), "longitude must be finite"),
])
def test_bad_input_is_one_clear_line(call, message):
    img, acq = _image(34.95, -106.52, 0.0), _collection(0.0)
    with pytest.raises(SarcliInputError) as info:
        call(img, acq)
    assert message in str(info.value) and "\n" not in str(info.value), str(info.value)


def test_an_image_without_georeference_is_refused():
    grid = Grid(8, 8, 1.0, 1.0)
    img = Image(np.zeros(grid.shape, np.complex64), grid.x, grid.y)
    with pytest.raises(SarcliInputError, match="no georeference: scene_center_lat_deg"):
        sarcli.geolocate(img, 1, 1)
    with pytest.raises(SarcliInputError, match="no georeference"):
        sarcli.pixel_of(img, 0.0, 0.0)


@pytest.mark.parametrize("site", ["60N", "antimeridian"])
def test_spaceborne_cphd_collection_agrees_with_sarkit(tmp_path, site):
    """The CPHD standard's example orbit (~1700 km slant range, its own pulse times): the SICD that
    sarcli writes from the CPHD and geolocate agree to well under a centimetre at every height."""
    import sarkit.sicd as sksicd

    from sarcli.io.cphd import read_cphd

    from .test_cphd_sicd import make_cphd_fixture

    make_cphd_fixture(tmp_path / "f.cphd", site=site)
    ph = read_cphd(tmp_path / "f.cphd")
    grid = Grid(160, 100, 3.0, 4.0, -20.0, 10.0)
    data = np.arange(grid.ny * grid.nx, dtype=np.float32).reshape(grid.shape).astype(np.complex64)
    img = Image(data, grid.x, grid.y, method="t", attrs={k: v for k, v in ph.attrs.items()
                                                         if k.startswith("scene_center")})
    xml, fit = _exported(tmp_path, img, ph)
    row, col = _pixels(img, seed=4)
    locs = _to_sicd_metres(xml, fit, row, col)
    errs = []
    for hae in (-50.0, 0.0, 400.0):
        h = np.full(row.shape, hae)
        theirs, _, ok = sksicd.image_to_constant_hae_surface(xml, locs, h)
        assert ok
        ours = _ecf(*sarcli.geolocate(img, row, col, h, phase_history=ph))
        errs.append(np.linalg.norm(ours - theirs, axis=-1).max())
    print(f"spaceborne {site}: max distance to sarkit {max(errs):.2e} m")
    assert max(errs) < 0.01, errs


def test_an_image_file_is_read_and_geolocated_like_the_image(tmp_path):
    img = _image(60.0, 25.0, 30.0)
    sarcli.write_image(tmp_path / "img.h5", img)
    row, col = np.array([0.0, 17.5, 119.0]), np.array([199.0, 3.25, 0.0])
    np.testing.assert_array_equal(sarcli.geolocate(tmp_path / "img.h5", row, col), sarcli.geolocate(img, row, col))
    with pytest.raises(SarcliInputError, match="no such file"):
        sarcli.geolocate(tmp_path / "missing.h5", 0, 0)
