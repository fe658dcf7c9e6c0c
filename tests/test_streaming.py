"""Phase histories left on disk and read by blocks of pulses give the same images, and the block
readers never hold the whole collection."""

from __future__ import annotations

import numpy as np
import pytest

import sarcli
from sarcli.errors import InputFileError
from sarcli.formers.direct import direct_spherical
from sarcli.io.hdf5 import read_phase_history, write_phase_history
from sarcli.io.pulses import PulseArray

from .conftest import small_config, spy_rows


@pytest.fixture(scope="module")
def ph_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("stream") / "ph.h5"
    from sarcli.formers.backprojection._setup import BLOCK as _BLOCK

    # more pulses than one block of the block readers (backprojection's is the largest)
    cfg = small_config(azimuths={"center_deg": 50.0, "extent_deg": 3.0, "count": 2 * _BLOCK + 44})
    write_phase_history(path, sarcli.simulate(sarcli.parse_acquisition(cfg), seed=3, snr_db=None))
    return path


@pytest.mark.filterwarnings("ignore::sarcli.errors.DefocusWarning")  # nufft on spherical data: only equality matters
@pytest.mark.parametrize("method", ["backprojection", "direct", "nufft", "ffbp"])
def test_lazy_and_in_memory_give_the_same_image(ph_file, method):
    eager = sarcli.form_image(read_phase_history(ph_file), method)
    lazy_ph = read_phase_history(ph_file, lazy=True)
    assert isinstance(lazy_ph.data, PulseArray)
    lazy = sarcli.form_image(lazy_ph, method)
    # FINUFFT's multithreaded spreading is not bitwise repeatable: two identical calls differ ~1e-11
    # (measured 1.7e-11 of the peak at most over 30 lazy images); the others measured bit-identical
    tol = 1e-10 if method == "nufft" else 1e-12
    np.testing.assert_allclose(lazy.image, eager.image, rtol=0, atol=tol * np.abs(eager.image).max())


def test_block_formers_never_read_the_whole_collection(ph_file, monkeypatch):
    """Backprojection, ffbp and the spherical matched filter ask for blocks, never for all pulses at once."""
    asked = spy_rows(monkeypatch)
    ph = read_phase_history(ph_file, lazy=True)
    n = ph.data.shape[0]
    sarcli.form_image(ph, "backprojection", extent=2.0)  # blocks of backprojection.BLOCK pulses
    assert asked and sum(asked) == n and max(asked) < n, asked
    asked.clear()
    sarcli.form_image(ph, "ffbp", extent=2.0)  # stage 0: whole sub-apertures, at most 64 pulses a block
    assert asked and sum(asked) == n and max(asked) <= 64, asked
    asked.clear()
    acq = ph.acquisition  # the spherical matched filter's chunk is set by a memory budget; force a small one
    direct_spherical(ph.data, acq.frequency_hz, acq.antenna_position_m, acq.range_to_center_m,
                     sarcli.Grid.square(2.0, 16), chunk=16)
    assert sum(asked) == n and max(asked) == 16, asked


def test_nan_in_a_lazy_block_is_one_line(tmp_path, ph_file):
    import shutil

    import h5py

    bad = tmp_path / "bad.h5"
    shutil.copyfile(ph_file, bad)
    with h5py.File(bad, "a") as f:
        f["phase_history"][5, 3] = np.nan
    ph = read_phase_history(bad, lazy=True)  # nothing read yet
    with pytest.raises(InputFileError, match="NaN/Inf"):
        sarcli.form_image(ph, "backprojection")


def test_form_image_command_streams(ph_file, tmp_path, monkeypatch):
    """`sar form-image --method backprojection` reads the file by blocks, never whole."""
    from click.testing import CliRunner

    from sarcli.cli.main import cli

    asked = spy_rows(monkeypatch)
    res = CliRunner().invoke(cli, ["form-image", str(ph_file), "-o", str(tmp_path / "img.h5"),
                                   "--method", "backprojection", "--extent", "2"])
    assert res.exit_code == 0, res.output
    assert asked and sum(asked) == read_phase_history(ph_file, lazy=True).data.shape[0] > max(asked), asked


def test_library_checks_memory_before_allocating(ph_file, monkeypatch):
    """form_image refuses a grid whose estimate exceeds the memory limit, counting only one block of
    pulses when the data stay on disk (streamed backprojection of a file larger than RAM is allowed)."""
    from sarcli._util import resources
    from sarcli.errors import SarcliInputError
    from sarcli.formers.planning.cost import Samples, form_image_bytes

    ph = read_phase_history(ph_file, lazy=True)
    grid = sarcli.Grid.square(2.0, 16)
    eager = form_image_bytes("backprojection", Samples(100_000, 4096), grid, upsample=8)
    streamed = form_image_bytes("backprojection", Samples(100_000, 4096, streamed=True), grid, upsample=8)
    # 100k pulses on disk cost one block in memory: as many as a million do
    assert streamed == form_image_bytes("backprojection", Samples(1_000_000, 4096, streamed=True), grid, upsample=8)
    assert streamed < eager / 30
    resources.set_memory_limit(1024)  # 1 KiB: nothing fits
    try:
        with pytest.raises(SarcliInputError, match="needs about"):
            sarcli.form_image(ph, "nufft", grid=grid)
    finally:
        resources.set_memory_limit(None)


def test_memory_models_count_the_stored_sample_size():
    """complex64 samples cost 8 bytes each where they are held as stored, not 16."""
    from sarcli.formers.planning.cost import Samples, form_image_bytes, regularize_bytes

    grid = sarcli.Grid.square(2.0, 16)   # a small image: the samples dominate
    for method in ("nufft", "pfa", "direct"):
        wide = form_image_bytes(method, Samples(1000, 1000, itemsize=16), grid)
        narrow = form_image_bytes(method, Samples(1000, 1000, itemsize=8), grid)
        assert narrow < wide and wide - narrow == pytest.approx(8 * 1000 * 1000)
    # regularisation copies narrow samples to complex128: the stored ones then cost 8 more, not less
    assert regularize_bytes(1000, 1000, grid, itemsize=8) == pytest.approx(
        regularize_bytes(1000, 1000, grid, itemsize=16) + 8 * 1000 * 1000)


def test_plan_memory_counts_what_the_formers_hold(ph_file):
    """The planner's memory column: the samples at their stored size, one block of them for the
    formers that read samples left on disk by blocks (backprojection: and of their weighted
    complex128 copy)."""
    from sarcli.formers.backprojection._setup import BLOCK
    from sarcli.formers.planning.planner import candidates

    eager, lazy = read_phase_history(ph_file), read_phase_history(ph_file, lazy=True)
    P, M = eager.data.shape
    item = eager.data.dtype.itemsize
    assert item == 8 and P > BLOCK
    grid = sarcli.Grid.square(2.0, 16)
    mem = {name: {c.method: c.memory for c in candidates(ph, grid, 1e-2)} for name, ph in (("eager", eager), ("lazy", lazy))}
    assert mem["eager"]["ffbp"] - mem["lazy"]["ffbp"] == pytest.approx((P - BLOCK) * M * item)
    assert mem["eager"]["backprojection"] - mem["lazy"]["backprojection"] == pytest.approx((P - BLOCK) * M * (item + 16))
