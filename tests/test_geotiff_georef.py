"""Georeferencing is exact: every pixel corner of a 1 km GeoTIFF lies where its CRS, as GDAL reads
it, says, anywhere on Earth (within UTM zones, at their edges, both hemispheres, near a pole, on the
antimeridian, above the ellipsoid); SICD pixels are where sarkit's projection puts them."""

from __future__ import annotations

import numpy as np
import pytest

from sarcli.core.grid import Grid
from sarcli.core.types import Image
from sarcli.io.export import export_image
from sarcli.io.georef import ReferencePoint, enu_to_ecf
from sarcli.io.geotiff import read_geotiff

SITES = [(34.95, -106.52), (34.95, -107.999), (34.95, -102.001), (-33.9, 18.4), (-45.0, 170.9),
         (78.2, 15.6), (-89.5, 30.0), (10.0, 179.99), (0.0, 0.5)]


def _scene(lat, lon, hae, n=100, pixel=10.0):
    grid = Grid(n, n, pixel, pixel, 0.0, 0.0)  # 1 km x 1 km
    attrs = {"scene_center_lat_deg": lat, "scene_center_lon_deg": lon, "scene_center_height_m": hae}
    return Image(np.ones(grid.shape, np.float32) + 0j, grid.x, grid.y, method="t", attrs=attrs)


@pytest.mark.parametrize("hae", [0.0, 2500.0])
@pytest.mark.parametrize("lat,lon", SITES)
def test_every_pixel_corner_is_where_gdal_says(tmp_path, lat, lon, hae):
    import rasterio
    from pyproj import CRS, Geod, Transformer

    img = _scene(lat, lon, hae)
    out = tmp_path / "g.tif"
    export_image(img, out)
    n, h = img.image.shape[0], img.grid.dx
    edge = np.arange(0, n + 1, 10)
    cols, rows = np.meshgrid(edge, edge)  # pixel corners, file rows counted from the north
    with rasterio.open(out) as ds:
        crs = CRS.from_wkt(ds.crs.to_wkt())
        t = ds.transform
        X = t.c + t.a * cols.ravel() + t.b * rows.ravel()
        Y = t.f + t.d * cols.ravel() + t.e * rows.ravel()
    lon_f, lat_f = Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(np.asarray(X), np.asarray(Y))
    # the truth: the same corner in our local frame (row 0 of the image is the south edge), on the Earth
    x = img.x_m[0] - h / 2 + h * cols.ravel()
    y = img.y_m[-1] + h / 2 - h * rows.ravel()
    ecf = enu_to_ecf(np.stack([x, y, np.zeros_like(x)], axis=1), ReferencePoint(lat, lon, hae))
    lon_t, lat_t, _ = Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True).transform(*ecf.T)
    _, _, dist = Geod(ellps="WGS84").inv(lon_f, lat_f, lon_t, lat_t)
    # measured 4.6e-6 m at most (a hundredth of a 0.1 m pixel would be 1e-3 m)
    print(f"max corner error {np.max(dist):.2e} m")
    assert np.max(dist) < 2e-5, np.max(dist)


def test_not_rotating_a_utm_grid_would_fail_this_check():
    """The check can fail: a UTM raster with our x, y added to the centre's easting / northing (no
    grid convergence) puts a corner 500 m out metres away at 34.95 N, 106.52 W."""
    from pyproj import Geod, Transformer

    lat, lon = 34.95, -106.52
    tr = Transformer.from_crs("EPSG:4326", "EPSG:32613", always_xy=True)
    e0, n0 = tr.transform(lon, lat)
    lon_u, lat_u = tr.transform(e0 + 500.0, n0 + 500.0, direction="INVERSE")
    ecf = enu_to_ecf(np.array([[500.0, 500.0, 0.0]]), ReferencePoint(lat, lon, 0.0))
    lon_t, lat_t, _ = Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True).transform(*ecf.T)
    assert Geod(ellps="WGS84").inv(lon_u, lat_u, lon_t[0], lat_t[0])[2] > 5.0


def test_read_back_restores_local_coordinates(tmp_path):
    img = _scene(-33.9, 18.4, 1200.0, n=20)
    export_image(img, tmp_path / "r.tif")
    back = read_geotiff(tmp_path / "r.tif")
    np.testing.assert_allclose(back.x_m, img.x_m, rtol=0, atol=1e-13)   # measured 1.4e-14
    np.testing.assert_allclose(back.y_m, img.y_m, rtol=0, atol=1e-13)   # measured 1.1e-14
    assert back.attrs["scene_center_height_m"] == 1200.0


@pytest.mark.parametrize("lat,lon,hae", [(34.95, -106.52, 0.0), (-33.9, 18.4, 1500.0), (78.2, 15.6, 0.0),
                                         (10.0, 179.99, 300.0)])
def test_sicd_pixels_are_where_sarkit_projects_them(tmp_path, lat, lon, hae):
    """sarkit's scene-to-image projection of a pixel's position (local frame -> ECF) lands on the
    SICD pixel that holds it: marked pixels far from the centre, 1 km scene."""
    import warnings

    import sarkit.sicd as sksicd
    from sarkit.sicd import projection

    from sarcli.io.sicd import write_sicd

    n, h = 100, 10.0
    img = _scene(lat, lon, hae, n=n, pixel=h)
    marks = [(0, 0), (0, n - 1), (n - 1, 0), (n - 1, n - 1), (3, 77), (60, 10)]  # (row, col), row 0 south
    data = np.zeros((n, n), np.complex64)
    for i, (r, c) in enumerate(marks):
        data[r, c] = i + 1
    img.image = data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        write_sicd(img, tmp_path / "m.sicd")
        with open(tmp_path / "m.sicd", "rb") as f, sksicd.NitfReader(f) as rd:
            xml, arr = rd.metadata.xmltree, rd.read_image()
        meta = projection.MetadataParams.from_xml(xml)
        enu = np.array([[img.x_m[c], img.y_m[r], 0.0] for r, c in marks])
        loc, _, ok = projection.scene_to_image(meta, enu_to_ecf(enu, ReferencePoint(lat, lon, hae)))
    assert ok
    scp = np.array([float(xml.findtext("{*}ImageData/{*}SCPPixel/{*}Row")),
                    float(xml.findtext("{*}ImageData/{*}SCPPixel/{*}Col"))])
    ss = np.array([float(xml.findtext("{*}Grid/{*}Row/{*}SS")), float(xml.findtext("{*}Grid/{*}Col/{*}SS"))])
    first = np.array([float(xml.findtext("{*}ImageData/{*}FirstRow")), float(xml.findtext("{*}ImageData/{*}FirstCol"))])
    pix = scp - first + loc / ss  # fractional SICD (row, col) of each marked position
    print(f"sicd max pixel offset {np.max(np.abs(pix - np.rint(pix))):.2e}")
    np.testing.assert_allclose(pix, np.rint(pix), rtol=0, atol=5e-10)  # measured 7.8e-11 pixel at most
    for i, (r, c) in enumerate(np.rint(pix).astype(int)):
        assert arr[r, c] == i + 1
