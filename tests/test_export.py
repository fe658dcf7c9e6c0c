"""GeoTIFF and PNG export: tags, georeferencing (tifffile and GDAL), north-up, dB mapping."""

from __future__ import annotations

import json

import numpy as np
import pytest
import tifffile
from click.testing import CliRunner

from sarcli.cli.main import cli
from sarcli.errors import SarcliInputError
from sarcli.io.export import export_image
from sarcli.io.geotiff import LOCAL_CITATION
from sarcli.io.georef import utm_epsg
from sarcli.core.grid import Grid
from sarcli.core.types import Image
from sarcli.io.hdf5 import write_image

NORTH_POINT = (10.0, 30.0)  # x east, y north (m): a point well north of the centre


def _image(lat_lon=None, nx=48, ny=32):
    """A small rectangular image: faint background, unit peak at NORTH_POINT, 0.01 at the centre."""
    grid = Grid(nx, ny, 2.0, 2.5, 0.0, 0.0)
    rng = np.random.default_rng(1)
    im = 1e-4 * (rng.standard_normal(grid.shape) + 1j * rng.standard_normal(grid.shape))
    r, c = grid.index_of(*NORTH_POINT)
    im[r, c] = 1.0
    im[grid.index_of(0.0, 0.0)] = 0.01
    attrs = {}
    if lat_lon:
        attrs = {"scene_center_lat_deg": lat_lon[0], "scene_center_lon_deg": lat_lon[1]}
    return Image(im.astype(np.complex64), grid.x, grid.y, method="test", attrs=attrs), (r, c)


def test_geotiff_local_frame_tags_and_north_up(tmp_path):
    img, (r, c) = _image()
    out = tmp_path / "a.tif"
    export_image(img, out)
    with tifffile.TiffFile(out) as tf:
        geo = tf.geotiff_metadata
        data = tf.asarray()
        desc = json.loads(tf.pages[0].description)
    assert data.dtype == np.float32 and data.shape == (32, 48)
    # row 0 of the file is north: the peak sits at the flipped row
    assert np.unravel_index(np.argmax(data), data.shape) == (31 - r, c)
    assert data[31 - r, c] == pytest.approx(1.0)
    assert "north-up" in desc["orientation"]
    assert int(geo["GTModelTypeGeoKey"]) == 32767
    assert int(geo["GTRasterTypeGeoKey"]) == 1
    assert geo["GTCitationGeoKey"] == LOCAL_CITATION
    assert geo["ModelPixelScale"][:2] == [2.0, 2.5]
    # tie point: upper-left corner of the north-west pixel
    x0 = img.x_m[0] - 1.0
    y0 = img.y_m[-1] + 1.25
    assert geo["ModelTiepoint"] == pytest.approx([0, 0, 0, x0, y0, 0])


def test_geotiff_orthographic_and_gdal(tmp_path):
    import rasterio  # a test dependency (pyproject [test]): an import failure must fail the test
    from pyproj import Transformer

    lat, lon = 39.78, -84.06
    img, (r, c) = _image((lat, lon))
    out = tmp_path / "u.tif"
    export_image(img, out, kind="db")
    with rasterio.open(out) as ds:
        proj = ds.crs.to_proj4()
        assert "+proj=ortho" in proj and f"+lat_0={lat}" in proj and f"+lon_0={lon}" in proj
        t = ds.transform
        assert (t.a, t.e) == pytest.approx((2.0, -2.5))  # on the ellipsoid (no height): our own metres
        assert (t.c, t.f) == pytest.approx((img.x_m[0] - 1.0, img.y_m[-1] + 1.25), abs=1e-9)
        band = ds.read(1)
        # the pixel holding the point's latitude / longitude, found through GDAL's CRS, holds the peak
        to_geo = Transformer.from_crs(ds.crs.to_wkt(), "EPSG:4326", always_xy=True)
        plon, plat = to_geo.transform(*NORTH_POINT)
        X, Y = to_geo.transform(plon, plat, direction="INVERSE")
        row, col = ds.index(X, Y)
        assert band[row, col] == pytest.approx(0.0, abs=1e-5)
        assert band.min() == pytest.approx(-50.0, abs=1e-4)


def test_geotiff_local_frame_read_by_gdal(tmp_path):
    import rasterio  # a test dependency (pyproject [test]): an import failure must fail the test
    img, _ = _image()
    out = tmp_path / "c.tif"
    export_image(img, out, kind="complex")
    with rasterio.open(out) as ds:
        assert ds.dtypes[0] == "complex64"
        assert "sarcli local ENU frame" in ds.crs.to_wkt()
        assert 'UNIT["metre",1' in ds.crs.to_wkt()
        assert (ds.transform.c, ds.transform.f) == pytest.approx((img.x_m[0] - 1.0, img.y_m[-1] + 1.25))
        np.testing.assert_array_equal(ds.read(1), img.image[::-1])


def test_png_db_mapping_and_orientation(tmp_path):
    from PIL import Image as PILImage

    img, (r, c) = _image()
    out = tmp_path / "a.png"
    export_image(img, out, dynamic_range_db=40)
    pic = np.asarray(PILImage.open(out))
    assert pic.dtype == np.uint8 and pic.shape == (32, 48)
    assert pic.max() == 255
    row, col = np.unravel_index(np.argmax(pic), pic.shape)
    assert (row, col) == (31 - r, c) and row < 16  # north of the centre -> upper half
    assert pic.min() == 0  # the -80 dB background is below -DR
    # the centre pixel is 0.01 = -40 dB = exactly -DR -> 0; at DR 80 it is mid-scale
    rc, cc = img.grid.index_of(0.0, 0.0)
    assert pic[31 - rc, cc] == 0
    export_image(img, tmp_path / "b.png", dynamic_range_db=80)
    pic80 = np.asarray(PILImage.open(tmp_path / "b.png"))
    assert pic80[31 - rc, cc] == round(255 * 40 / 80)


def test_png_colormap_rgb_and_annotated(tmp_path):
    from PIL import Image as PILImage

    img, _ = _image()
    export_image(img, tmp_path / "v.png", cmap="viridis")
    rgb = np.asarray(PILImage.open(tmp_path / "v.png"))
    assert rgb.shape == (32, 48, 3)
    import matplotlib

    top = np.rint(np.asarray(matplotlib.colormaps["viridis"](1.0)[:3]) * 255)
    assert np.abs(rgb.reshape(-1, 3).astype(int) - top).sum(axis=1).min() == 0
    from sarcli.viz import image_figure

    image_figure(img, tmp_path / "ann.png")
    fig = np.asarray(PILImage.open(tmp_path / "ann.png"))
    assert fig.shape[0] > 200 and fig.shape[1] > 200  # a figure, not the 32x48 pixels


def test_bad_requests():
    img, _ = _image()
    with pytest.raises(SarcliInputError, match="suffix"):
        export_image(img, "x.jpg")
    with pytest.raises(SarcliInputError, match="complex"):
        export_image(img, "x.png", kind="complex")
    with pytest.raises(SarcliInputError, match="colormap"):
        export_image(img, "x.png", cmap="nope")


def test_cli_export(tmp_path):
    img, (r, c) = _image()
    src = tmp_path / "img.h5"
    write_image(src, img)
    runner = CliRunner()
    res = runner.invoke(cli, ["export", str(src), "-o", str(tmp_path / "o.tif"), "--kind", "db"])
    assert res.exit_code == 0, res.output
    data = tifffile.imread(tmp_path / "o.tif")
    assert data[31 - r, c] == pytest.approx(0.0, abs=1e-5)
    res = runner.invoke(cli, ["export", str(src), "-o", str(tmp_path / "o.bmp")])
    assert res.exit_code == 2 and "suffix" in res.output
    assert not (tmp_path / "o.bmp").exists()
    res = runner.invoke(cli, ["export", str(tmp_path / "missing.h5"), "-o", str(tmp_path / "o.png")])
    assert res.exit_code == 2 and "no such file" in res.output


def test_georef_enu_ecf_and_utm_zones():
    from sarcli.io.georef import DEFAULT_REFERENCE, ReferencePoint, ecf_to_enu, enu_to_ecf, reference_point

    # at 0N 0E: east is +Y, north is +Z, up is +X of ECF; the origin sits on the equator, a = 6378137 m
    enu = np.array([[0, 0, 0], [10.0, 0, 0], [0, 20.0, 0], [0, 0, 30.0]])
    ecf = enu_to_ecf(enu, DEFAULT_REFERENCE)
    np.testing.assert_allclose(ecf, [[6378137, 0, 0], [6378137, 10, 0], [6378137, 0, 20], [6378167, 0, 0]],
                               atol=1e-8)
    ref = ReferencePoint(39.78, -84.06, 250.0)
    pts = np.random.default_rng(0).uniform(-5e3, 5e3, (20, 3))
    np.testing.assert_allclose(ecf_to_enu(enu_to_ecf(pts, ref), ref), pts, atol=1e-8)
    assert reference_point({}, None) is DEFAULT_REFERENCE
    assert reference_point({"scene_center_lat_deg": 1, "scene_center_lon_deg": 350}).lon_deg == -10
    assert utm_epsg(-33.9, 18.4) == 32734  # Cape Town, zone 34 south
    assert utm_epsg(51.5, -0.1) == 32630  # London, zone 30 north
    assert utm_epsg(10.0, 179.99) == 32660
