"""The HDF5 contract: exact round trips, and refusal of foreign or broken files with one line."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

import sarcli
from sarcli.cli.main import cli
from sarcli.errors import InputFileError

from .conftest import CONFIGS, small_config


@pytest.fixture
def ph_file(tmp_path, write_config):
    ph = sarcli.simulate(sarcli.load_acquisition(write_config(small_config())), snr_db=20, seed=1)
    path = tmp_path / "ph.h5"
    sarcli.write_phase_history(path, ph)
    return ph, path


def test_round_trip_exact(ph_file):
    ph, path = ph_file
    back = sarcli.read_phase_history(path)
    a, b = ph.acquisition, back.acquisition
    assert np.array_equal(back.data, ph.data) and back.data.dtype == ph.data.dtype
    for name in ("frequency_hz", "azimuth_rad", "elevation_rad", "antenna_position_m", "range_to_center_m"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert b.model == "spherical" and b.grid == a.grid and b.snr_db == 20
    assert np.array_equal(back.truth.point_position_m, ph.truth.point_position_m)
    assert np.array_equal(back.truth.point_amplitude, ph.truth.point_amplitude)
    assert np.array_equal(back.truth.scene, ph.truth.scene)
    assert back.attrs["sarcli_version"] == sarcli.__version__
    assert "frequencies:" in back.attrs["config_yaml"]  # provenance: the YAML text itself


def test_file_follows_conventions_exactly(ph_file):
    """Read it with h5py alone, as another program knowing only docs/conventions.md would."""
    _, path = ph_file
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == "sarcli-phase-history" and int(f.attrs["version"]) == 1
        assert f.attrs["model"] == "spherical"
        P, M = f["phase_history"].shape
        assert f["phase_history"].dtype in (np.complex64, np.complex128)   # the contract allows both
        assert f["frequency_hz"].shape == (M,) and f["frequency_hz"].dtype == np.float64
        for name, shape in [("azimuth_rad", (P,)), ("elevation_rad", (P,)), ("antenna_position_m", (P, 3)),
                            ("range_to_center_m", (P,))]:
            assert f[name].shape == shape and f[name].dtype == np.float64
        assert f["truth/point_position_m"].shape == (2, 3) and f["truth/point_amplitude"].dtype == np.complex128
        assert "truth/scene" not in f and "truth/magnitude" not in f  # a point scene needs no dense truth
        # the look direction convention: antenna at azimuth θ + π
        a = f["antenna_position_m"][()]
        th = f["azimuth_rad"][()]
        assert np.allclose(np.cos(np.arctan2(a[:, 1], a[:, 0]) - th), -1, rtol=0, atol=1e-15)   # measured 0


def _corrupt(path, how):
    if how == "truncate":
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 3])
        return
    with h5py.File(path, "r+") as f:
        if how == "format":
            f.attrs["format"] = "someone-elses-format"
        elif how == "version":
            f.attrs["version"] = 7
        elif how == "missing":
            del f["azimuth_rad"]
        elif how == "shape":
            del f["elevation_rad"]
            f["elevation_rad"] = np.zeros(3)
        elif how == "dtype":
            d = f["phase_history"][()]
            del f["phase_history"]
            f["phase_history"] = np.abs(d)
        elif how == "nan":
            d = f["phase_history"][()]
            d[0, 0] = np.nan
            f["phase_history"][...] = d
        elif how == "frequency":
            f["frequency_hz"][0] = -1.0
        elif how == "model":
            f.attrs["model"] = "wavy"
        elif how == "duplicate":
            az = f["azimuth_rad"][()]
            az[3] = az[2]
            f["azimuth_rad"][...] = az


@pytest.mark.parametrize("how,needle", [
    ("format", "format"), ("version", "version 7"), ("missing", "missing dataset 'azimuth_rad'"),
    ("shape", "'elevation_rad' has shape (3,)"), ("dtype", "expected complex"), ("nan", "NaN"),
    ("frequency", "non-positive"), ("model", "model"), ("truncate", "ph.h5"),
    ("duplicate", "pulses 2 and 3 look from the same azimuth"),
])
def test_broken_files_refused_with_one_line(ph_file, how, needle):
    _, path = ph_file
    _corrupt(path, how)
    with pytest.raises(InputFileError):
        sarcli.read_phase_history(path)
    res = CliRunner().invoke(cli, ["info", str(path)])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(path) in lines[0]
    assert needle in lines[0]


def test_not_hdf5_and_missing(tmp_path):
    junk = tmp_path / "junk.h5"
    junk.write_text("hello")
    for p in (junk, tmp_path / "absent.h5"):
        res = CliRunner().invoke(cli, ["info", str(p)])
        assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1


def test_image_round_trip(tmp_path):
    img = sarcli.Image(image=(np.arange(12.0) + 1j).reshape(3, 4), x_m=np.arange(4.0), y_m=np.arange(3.0) - 1,
                       method="direct", parameters={"window": "hann", "eps": 1e-9}, runtime_s=0.5,
                       history={"objective": np.array([3.0, 2.0])})
    path = tmp_path / "img.h5"
    sarcli.write_image(path, img)
    back = sarcli.read_image(path)
    assert np.array_equal(back.image, img.image) and np.array_equal(back.y_m, img.y_m)
    assert back.method == "direct" and back.parameters == img.parameters and back.runtime_s == 0.5
    assert np.array_equal(back.history["objective"], [3.0, 2.0])
    with h5py.File(path, "r+") as f:
        f.attrs["format"] = "sarcli-phase-history"
    with pytest.raises(InputFileError, match="format"):
        sarcli.read_image(path)


def test_info_prints_the_numbers(tmp_path):
    res = CliRunner().invoke(cli, ["info", str(CONFIGS / "three-points.yaml"), "--json"])
    assert res.exit_code == 0
    import json

    info = json.loads(res.output)
    assert info["alias_free_radius_m"]["range"] == pytest.approx(73.7055, rel=1e-6)   # measured 3.8e-7 (the rounded literal)
    # the far-field defocus at the grid corner exceeds the threshold: a note names it, no warning
    from sarcli.core.geometry import DEFOCUS_WARN_RAD

    defocus = info["farfield_phase_error_rad_at_grid_corner"]
    assert defocus > DEFOCUS_WARN_RAD and not info["warnings"]
    assert sum(f"by {defocus:.3g} rad" in n for n in info["notes"]) == 1


def test_an_image_is_stored_in_the_type_asked_cast_by_blocks_of_rows(tmp_path, monkeypatch):
    from sarcli.core.types import Image
    from sarcli.io import hdf5

    rng = np.random.default_rng(3)
    a = rng.normal(size=(37, 16)) + 1j * rng.normal(size=(37, 16))
    img = Image(image=a, x_m=np.arange(16.0), y_m=np.arange(37.0), method="direct", parameters={}, runtime_s=0.0)
    monkeypatch.setattr(hdf5, "_CAST_ROWS_BYTES", 5 * a[:1].nbytes)   # eight blocks, the last short
    for dtype in (np.complex64, np.complex128, None):
        path = tmp_path / f"{np.dtype(dtype).name if dtype else 'own'}.h5"
        sarcli.write_image(path, img, dtype)
        back = sarcli.read_image(path)
        want = a if dtype is None else a.astype(dtype)
        assert back.image.dtype == want.dtype and np.array_equal(back.image, want)
    with pytest.raises(ValueError, match="complex64 or complex128"):
        sarcli.write_image(tmp_path / "f.h5", img, np.float32)
    assert not (tmp_path / "f.h5").exists()


def test_form_image_stores_complex64_from_complex64_samples_unless_asked(ph_file, tmp_path):
    from sarcli.io.hdf5 import COMPLEX64_TOLERANCE, stored_image_dtype

    assert stored_image_dtype(np.complex64) == np.complex64
    assert stored_image_dtype(np.complex128) == np.complex128
    assert stored_image_dtype(np.complex64, complex128=True) == np.complex128
    assert stored_image_dtype(np.complex64, tolerance=COMPLEX64_TOLERANCE / 10) == np.complex128
    assert stored_image_dtype(np.complex64, tolerance=COMPLEX64_TOLERANCE) == np.complex64
    ph, path = ph_file
    assert ph.data.dtype == np.complex64
    runner = CliRunner()
    out = {}
    for name, extra in (("default", []), ("wide", ["--complex128"]), ("fine", ["--tolerance", "1e-7"]),
                        ("exact", ["--method", "direct"]), ("bp", ["--method", "backprojection"]),
                        ("bp64", ["--method", "backprojection", "--precision", "float64"])):
        res = runner.invoke(cli, ["-q", "form-image", str(path), "-o", str(tmp_path / f"{name}.h5"), *extra])
        assert res.exit_code == 0, res.output
        out[name] = sarcli.read_image(tmp_path / f"{name}.h5").image
    assert out["default"].dtype == np.complex64 and out["bp"].dtype == np.complex64
    assert all(out[name].dtype == np.complex128 for name in ("wide", "fine", "exact", "bp64"))
    # the stored image differs from the complex128 one by complex64's rounding only
    assert np.linalg.norm(out["default"] - out["wide"]) <= 1e-7 * np.linalg.norm(out["wide"])


def test_large_files_are_written_in_place_into_space_reserved_first(ph_file, tmp_path, monkeypatch):
    """Above IN_MEMORY_MAX_BYTES a file is written by HDF5 straight into its temporary file (no copy
    in memory), after space at least the file's size is reserved; the files read back the same."""
    import io

    from sarcli.core.types import Image
    from sarcli.io import h5output

    reserved = []

    def spy(tmp, nbytes):
        reserved.append(nbytes)
        assert tmp.name.startswith(".") and ".tmp-" in tmp.name   # the temporary name, not the output
        return reserve(tmp, nbytes)

    def no_copy(*a, **k):
        raise AssertionError("a large file was built in memory")

    import os

    writes = []
    pwrite = os.pwrite

    def count(fd, data, offset):
        writes.append(len(data))
        return pwrite(fd, data, offset)

    reserve = h5output.reserve_space
    monkeypatch.setattr(os, "pwrite", count)
    monkeypatch.setattr(h5output, "reserve_space", spy)
    monkeypatch.setattr(h5output, "IN_MEMORY_MAX_BYTES", 1024)
    monkeypatch.setattr(io, "BytesIO", no_copy)
    rng = np.random.default_rng(5)
    a = (rng.normal(size=(300, 200)) + 1j * rng.normal(size=(300, 200))).astype(np.complex128)
    img = Image(image=a, x_m=np.arange(200.0), y_m=np.arange(300.0), method="direct", parameters={"k": 1},
                runtime_s=0.25, history={"objective": np.arange(50.0)})
    ph, _ = ph_file
    for path, write, read, same in (
            (tmp_path / "img.h5", lambda p: sarcli.write_image(p, img, np.complex64), sarcli.read_image,
             lambda b: np.array_equal(b.image, a.astype(np.complex64)) and b.parameters == {"k": 1}),
            (tmp_path / "ph.h5", lambda p: sarcli.write_phase_history(p, ph), sarcli.read_phase_history,
             lambda b: np.array_equal(b.data, ph.data))):
        writes.clear()
        write(path)
        assert same(read(path))
        # the samples by our own writes, none larger than WRITE_CHUNK_BYTES
        samples = a.size * 8 if path.name == "img.h5" else ph.data.nbytes
        assert sum(writes) == samples and max(writes) <= h5output.WRITE_CHUNK_BYTES
        assert path.stat().st_size <= reserved[-1]          # the reservation bounds the file from above
        assert not list(tmp_path.glob(f".{path.name}.tmp-*"))
    # a phase history given by blocks of pulses (as the simulator writes it), the blocks uneven
    cuts = [0, 1, 7, ph.data.shape[0]]
    blocks = [(slice(a0, a1), ph.data[a0:a1]) for a0, a1 in zip(cuts, cuts[1:])]
    writes.clear()
    sarcli.write_phase_history(tmp_path / "blocks.h5", ph, blocks=iter(blocks))
    back = sarcli.read_phase_history(tmp_path / "blocks.h5")
    assert np.array_equal(back.data, ph.data) and back.data.dtype == ph.data.dtype
    assert sum(writes) == ph.data.nbytes
    assert len(reserved) == 3


def test_a_file_size_limit_on_an_in_place_write_is_one_line(tmp_path):
    """A write in place that cannot fit fails at the reservation: one clean error, no traceback
    from h5py's destructors, no temporary left, the previous file untouched."""
    import resource
    import signal
    import subprocess
    import sys

    out = tmp_path / "img.h5"
    out.write_bytes(b"previous output")
    script = ("import numpy as np, sys\n"
              "from sarcli.io import h5output, hdf5\n"
              "from sarcli.core.types import Image\n"
              "from sarcli._util.atomic import WriteError\n"
              "h5output.IN_MEMORY_MAX_BYTES = 0\n"
              "a = np.ones((256, 128), np.complex128)\n"
              "img = Image(image=a, x_m=np.arange(128.0), y_m=np.arange(256.0), method='direct', parameters={},"
              " runtime_s=0.0)\n"
              "try:\n"
              f"    hdf5.write_image({str(out)!r}, img)\n"
              "except WriteError as exc:\n"
              "    print(exc)\n"
              "    sys.exit(2)\n")

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (64_000, 64_000))

    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, preexec_fn=limit, timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr == "" and len(r.stdout.strip().splitlines()) == 1
    assert "could not be written (File too large)" in r.stdout
    assert out.read_bytes() == b"previous output" and not list(tmp_path.glob(".img.h5.tmp-*"))


def test_write_chunked_goes_on_after_short_writes_and_stops_on_none(tmp_path, monkeypatch):
    import os

    from sarcli.io.h5output import WRITE_CHUNK_BYTES, write_chunked

    data = np.arange(3 * WRITE_CHUNK_BYTES // 8 + 5, dtype=np.float64)
    pwrite = os.pwrite
    sizes = []

    def short(fd, buf, offset):   # at most 1000 bytes a call
        sizes.append(len(buf))
        return pwrite(fd, buf[:1000], offset)

    monkeypatch.setattr(os, "pwrite", short)
    path = tmp_path / "f.bin"
    with open(path, "wb") as fh:
        fh.write(b"head")
        end = write_chunked(fh.fileno(), data, 4)
    assert end == 4 + data.nbytes and max(sizes) == WRITE_CHUNK_BYTES
    raw = path.read_bytes()
    assert raw[:4] == b"head" and np.array_equal(np.frombuffer(raw[4:], np.float64), data)
    monkeypatch.setattr(os, "pwrite", lambda fd, buf, offset: 0)
    with open(path, "r+b") as fh, pytest.raises(OSError, match="No space left"):
        write_chunked(fh.fileno(), data, 0)


def test_an_interruption_between_reserving_and_opening_leaves_no_temporary(tmp_path, monkeypatch):
    """The interruption's clean-up removes the temporary file while the main thread runs on (it
    stops the children first): the in-place HDF5 file must not be created again behind it."""
    from sarcli._util import atomic
    from sarcli.io import h5output

    reserve = h5output.reserve_space

    def reserve_then_interrupted(tmp, nbytes):
        reserve(tmp, nbytes)
        atomic.release_all()            # what the watchdog does on SIGINT

    monkeypatch.setattr(h5output, "reserve_space", reserve_then_interrupted)
    out, created = tmp_path / "img.h5", []
    with pytest.raises(KeyboardInterrupt):
        with atomic.atomic_path(out) as tmp:
            with h5output.h5_output(tmp, h5output.IN_MEMORY_MAX_BYTES + 1):
                # the process may end at any moment now (os._exit): nothing may be on disk
                created += [p.name for p in tmp_path.iterdir()]
    assert created == [] and sorted(p.name for p in tmp_path.iterdir()) == []
