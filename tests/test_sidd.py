"""SIDD export (sarcli.io.sidd): valid against the SIDD 3.0 schema and sarkit's consistency
checks; its projection (sarkit's pixel_to_ecef / ecef_to_pixel) agrees with where sarcli puts
each pixel, for a plane image (exact) and a map image on terrain (fitted polynomials)."""

import warnings

import lxml.etree
import numpy as np
import pytest
from sarkit import wgs84

from .test_cphd_sicd import _sicd_case


def _read(path):
    import sarkit.sidd as sksidd

    with open(path, "rb") as f, sksidd.NitfReader(f) as r:
        return r.metadata.images[0].xmltree, r.read_image(0)


def _valid(xml):
    import sarkit.sidd as sksidd

    schema = lxml.etree.XMLSchema(file=str(sksidd.VERSION_INFO["urn:SIDD:3.0.0"]["schema"]))
    return schema.validate(xml), str(schema.error_log)


def _consistency(path):
    import sarkit.verification as skver

    with open(path, "rb") as f:
        con = skver.SiddConsistency.from_file(f)
        con.check()
    return con.failures(), len(con.passes())


@pytest.mark.parametrize("look_deg", [-90.0, 0.0, 200.0])
def test_plane_image_sidd_is_valid_and_its_plane_projection_is_exact(tmp_path, look_deg):
    import sarkit.sidd as sksidd

    from sarcli.io.export import export_image
    from sarcli.io.geolocate import geolocate
    from sarcli.io.png import display_values

    img, ph = _sicd_case(np.radians(look_deg))
    img.x_m = img.x_m + 30.0   # off-centre
    out = tmp_path / "a.sidd"
    export_image(img, out, phase_history=ph)
    xml, pixels = _read(out)
    ok, log = _valid(xml)
    assert ok, log
    failures, n_pass = _consistency(out)
    assert not failures, list(failures)
    np.testing.assert_array_equal(pixels, display_values(img, kind="db")[::-1])   # north-up
    ny, nx = img.image.shape
    rows, cols = np.meshgrid([0, 5, ny - 1], [0, 7, nx - 1], indexing="ij")
    lat, lon, h = geolocate(img, rows.ravel(), cols.ravel())   # row 0 south
    ecf = wgs84.geodetic_to_cartesian(np.stack([lat, lon, h], axis=-1))
    file_px = np.stack([ny - 1 - rows.ravel(), cols.ravel()], axis=-1).astype(float)
    np.testing.assert_allclose(sksidd.pixel_to_ecef(xml, file_px), ecf, atol=1e-6)
    np.testing.assert_allclose(sksidd.ecef_to_pixel(xml, ecf), file_px, atol=1e-6)


def test_map_image_sidd_polynomials_put_pixels_at_their_map_coordinates(tmp_path):
    import sarkit.sidd as sksidd
    from pyproj import Transformer

    from sarcli.formers.formation import form_image
    from sarcli.io.export import export_image

    from .test_terrain import EPSG, TARGETS, collection, target_position, write_dem

    enu, _ = target_position(*TARGETS["30° slope"])
    ph = collection(enu, P=16, M=64)
    img = form_image(ph, "backprojection", dem=str(write_dem(tmp_path / "d.tif")), center=(enu[0], enu[1]),
                     extent=16.0, pixel_size=0.5)
    out = tmp_path / "m.sidd"
    export_image(img, out, phase_history=ph)
    xml, pixels = _read(out)
    ok, log = _valid(xml)
    assert ok, log
    assert xml.find("{*}Measurement/{*}PolynomialProjection") is not None
    failures, _ = _consistency(out)
    assert not failures, list(failures)
    fit = float(xml.findtext("{*}ProductCreation/{*}ProductCreationExtension[@name='sarcli-fit-error-m']"))
    assert fit < 1e-3
    ny, nx = img.image.shape
    r = np.array([0.0, 3.5, ny - 1.0, 10.0])
    c = np.array([0.0, nx - 1.0, 2.25, 20.0])
    ecf = sksidd.pixel_to_ecef(xml, np.stack([r, c], axis=-1))
    llh = wgs84.cartesian_to_geodetic(ecf)
    e, n = Transformer.from_crs("EPSG:4326", f"EPSG:{EPSG}", always_xy=True).transform(llh[:, 1], llh[:, 0])
    np.testing.assert_allclose(e, img.x_m[0] + c * 0.5, atol=2e-3)
    np.testing.assert_allclose(n, img.y_m[-1] - r * 0.5, atol=2e-3)
    print(f"\nmap SIDD: fit error {fit:.3g} m; pixel_to_ecef vs map CRS "
          f"{np.max(np.hypot(e - (img.x_m[0] + c * 0.5), n - (img.y_m[-1] - r * 0.5))):.3g} m")


def test_sidd_refuses_complex_and_placeholder_location(tmp_path):
    from sarcli.core.types import Image
    from sarcli.errors import SarcliInputError
    from sarcli.io.export import export_image

    img, ph = _sicd_case(0.0)
    with pytest.raises(SarcliInputError, match="detected picture"):
        export_image(img, tmp_path / "a.sidd", kind="complex", phase_history=ph)
    bare = Image(img.image, img.x_m, img.y_m)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(SarcliInputError, match="latitude and longitude"):
            export_image(bare, tmp_path / "b.sidd")
    assert not list(tmp_path.iterdir())
