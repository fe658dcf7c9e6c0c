"""One door in: every format sarcli reads is recognised by its content and described by `sar info`;
every writing command says what it wrote; PNGs are annotated figures unless --bare."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image as PILImage

import sarcli
from sarcli.cli.main import cli
from sarcli.core.types import Image
from sarcli.errors import InputFileError
from sarcli.io import detect_format, open_input
from sarcli.io.describe import describe
from sarcli.io.geotiff import read_geotiff, write_geotiff
from sarcli.io.hdf5 import write_image

from .conftest import GOTCHA_FILES, small_config


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """One file of every format sarcli writes, from a small far-field collection."""
    import yaml

    d = tmp_path_factory.mktemp("formats")
    cfg = d / "acq.yaml"
    cfg.write_text(yaml.safe_dump(small_config()))
    run = CliRunner()
    out = {"config": cfg}
    steps = [("phase-history", ["simulate", str(cfg), "-o", str(d / "ph.h5")]),
             ("image", ["form-image", str(d / "ph.h5"), "-o", str(d / "img.h5"), "--method", "backprojection"]),
             ("kgrid", ["regrid", str(d / "ph.h5"), "-o", str(d / "kg.h5")]),
             ("sicd", ["export", str(d / "img.h5"), "-o", str(d / "img.sicd"), "--phase-history", str(d / "ph.h5")]),
             ("geotiff", ["export", str(d / "img.h5"), "-o", str(d / "img.tif")]),
             ("cphd", ["export-cphd", str(d / "ph.h5"), "-o", str(d / "ph.cphd")])]
    for fmt, args in steps:
        res = run.invoke(cli, args)
        assert res.exit_code == 0, (args, res.output)
        path = args[args.index("-o") + 1]
        assert f"wrote {path} (" in res.output, (args, res.output)  # every writing command says so
        out[fmt] = path
    return out


@pytest.mark.parametrize("fmt", ["config", "phase-history", "image", "kgrid", "sicd", "geotiff", "cphd"])
def test_every_written_format_is_recognised_and_described(files, fmt):
    assert detect_format(files[fmt]) == fmt
    info = describe(files[fmt])
    assert info["format"] == fmt
    if fmt in ("config", "phase-history", "cphd"):
        assert info["pulses"] == 32 and info["frequencies"] == 64
    elif fmt == "kgrid":
        assert len(info["shape"]) == 2 and min(info["dk_rad_per_m"]) > 0
    else:
        assert info["shape"] == [64, 64] and info["peak_magnitude"] > 0
    res = CliRunner().invoke(cli, ["info", str(files[fmt])])
    assert res.exit_code == 0, res.output
    assert f"format: {fmt}" in res.output


@pytest.mark.gotcha
def test_gotcha_mat_is_recognised():
    path = GOTCHA_FILES[0]
    assert detect_format(path) == "gotcha"
    info = describe(path)
    assert info["model"] == "spherical" and info["pulses"] > 100


def test_foreign_and_missing_files_are_one_line(tmp_path):
    junk = tmp_path / "junk.bin"
    junk.write_bytes(b"\x00\x01 not a radar file")
    with pytest.raises(InputFileError, match="unrecognised file content"):
        detect_format(junk)
    with pytest.raises(InputFileError, match="no such file"):
        detect_format(tmp_path / "missing.h5")
    res = CliRunner().invoke(cli, ["info", str(junk)])
    assert res.exit_code == 2 and res.output.count("\n") == 1 and "junk.bin" in res.output


def test_open_input_expect_refuses_the_wrong_kind(files):
    with pytest.raises(InputFileError, match="is an image file; expected phase-history"):
        open_input(files["image"], expect="phase-history")
    fmt, ph = open_input(files["phase-history"], expect=("phase-history", "cphd"))
    assert fmt == "phase-history" and isinstance(ph, sarcli.PhaseHistory)


def test_form_image_refuses_an_image_as_input(files, tmp_path):
    res = CliRunner().invoke(cli, ["form-image", str(files["image"]), "-o", str(tmp_path / "x.h5")])
    assert res.exit_code == 2 and "expected" in res.output and not (tmp_path / "x.h5").exists()


def test_geotiff_reads_back_on_the_image_grid(tmp_path):
    rng = np.random.default_rng(0)
    img = Image(rng.standard_normal((6, 8)) + 0j, np.arange(8) * 0.5 - 1.75, np.arange(6) * 0.25 + 3.0, method="t")
    write_geotiff(img, tmp_path / "a.tif")
    back = read_geotiff(tmp_path / "a.tif")
    np.testing.assert_allclose(back.x_m, img.x_m, atol=1e-9)
    np.testing.assert_allclose(back.y_m, img.y_m, atol=1e-9)
    np.testing.assert_allclose(back.image.real, np.abs(img.image), rtol=1e-6)  # magnitude, rows back south-up


def test_png_is_an_annotated_figure_unless_bare(tmp_path):
    img = Image(np.outer(np.hanning(40), np.hanning(30)) + 0j, np.arange(30) * 0.1, np.arange(40) * 0.1, method="t")
    write_image(tmp_path / "img.h5", img)
    run = CliRunner()
    res = run.invoke(cli, ["export", str(tmp_path / "img.h5"), "-o", str(tmp_path / "fig.png")])
    assert res.exit_code == 0 and "wrote" in res.output, res.output
    res = run.invoke(cli, ["export", str(tmp_path / "img.h5"), "-o", str(tmp_path / "raw.png"), "--bare"])
    assert res.exit_code == 0, res.output
    with PILImage.open(tmp_path / "raw.png") as pic:
        assert pic.size == (30, 40)                                    # one pixel per image pixel
    with PILImage.open(tmp_path / "fig.png") as pic:
        w, h = pic.size
    assert w > 300 and h > 200                                         # a readable figure, not a thumbnail


def test_png_description_says_what_each_picture_is_and_annotate_is_deprecated(tmp_path):
    # docs/formats.md: both the figure and the --bare raster carry a Description text chunk
    img = Image(np.outer(np.hanning(40), np.hanning(30)) + 0j, np.arange(30) * 0.1, np.arange(40) * 0.1, method="t")
    write_image(tmp_path / "img.h5", img)
    run = CliRunner()
    for name, extra in (("fig.png", []), ("raw.png", ["--bare"])):
        res = run.invoke(cli, ["export", str(tmp_path / "img.h5"), "-o", str(tmp_path / name),
                               "--dynamic-range-db", "35", "--cmap", "magma", *extra])
        assert res.exit_code == 0, res.output
        with PILImage.open(tmp_path / name) as pic:
            text = pic.text
        assert "clipped to [-35, 0] dB -> 0..255" in text["Description"] and "colormap magma" in text["Description"]
        assert text["Software"] == f"sarcli {sarcli.__version__}"
        layout = "axes x east and y north in metres" if name == "fig.png" else "file row 0 is the northern edge"
        assert layout in text["Description"], text["Description"]
    res = run.invoke(cli, ["export", str(tmp_path / "img.h5"), "-o", str(tmp_path / "a.png"), "--annotate"])
    assert res.exit_code == 0 and "--annotate is deprecated and has no effect" in res.output, res.output
    with PILImage.open(tmp_path / "a.png") as pic:
        assert pic.size[0] > 300                                       # still the figure
    res = run.invoke(cli, ["export", str(tmp_path / "img.h5"), "-o", str(tmp_path / "b.png"), "--annotate", "--bare"])
    assert res.exit_code == 2 and "contradict" in res.output and not (tmp_path / "b.png").exists()
    assert "--annotate" not in run.invoke(cli, ["export", "--help"]).output


def test_quiet_prints_nothing_on_success(files, tmp_path):
    res = CliRunner().invoke(cli, ["-q", "export", str(files["image"]), "-o", str(tmp_path / "q.tif")])
    assert res.exit_code == 0 and res.output == ""


def test_warning_lines_go_above_a_live_bar(capsys):
    from sarcli._util.progress import message, progress

    bar = progress(range(3), disable=False)
    message("warning: test")
    bar.close()
    err = capsys.readouterr().err
    assert "warning: test\n" in err


def test_a_bar_not_drawn_does_without_tqdm():
    """Where no bar is drawn (--quiet, no terminal, or disable=True) progress() hands back a silent
    bar with the interface the package uses, and tqdm is never imported (its import costs a
    command's start-up 18 ms)."""
    import subprocess
    import sys

    code = ("import sys\n"
            "from sarcli._util.progress import progress\n"
            "assert list(progress(range(3), disable=True)) == [0, 1, 2]\n"
            "b = progress(iter('ab'))\n"
            "assert list(b) == ['a', 'b'] and b.n == 2\n"
            "c = progress(total=5, desc='x', unit='u')\n"
            "c.update(2); c.update(); c.set_postfix(a=1); c.set_description('y'); c.refresh()\n"
            "assert c.n == 3 and c.total == 5 and c.disable\n"
            "c.reset(total=7); c.close()\n"
            "assert c.n == 0 and c.total == 7\n"
            "with progress(total=1) as d:\n"
            "    d.update()\n"
            "print('tqdm' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, stdin=subprocess.DEVNULL)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_image_formation_never_reads_the_truth(tmp_path, monkeypatch):
    """form-image reads /truth not at all: the group is made unreadable and the command still works."""
    import h5py

    cfg = small_config(scene={"phantom": {"name": "disks", "half_width_m": 3.0}})
    import yaml

    (tmp_path / "a.yaml").write_text(yaml.safe_dump(cfg))
    run = CliRunner()
    assert run.invoke(cli, ["simulate", str(tmp_path / "a.yaml"), "-o", str(tmp_path / "ph.h5")]).exit_code == 0
    with h5py.File(tmp_path / "ph.h5", "a") as f:
        assert "truth/scene" in f  # an extended scene keeps its dense truth
        del f["truth/scene"]       # ... now break the group: a reader that touched it would fail
        f["truth/scene"] = np.zeros(3)
    res = run.invoke(cli, ["form-image", str(tmp_path / "ph.h5"), "-o", str(tmp_path / "img.h5"), "--method", "nufft"])
    assert res.exit_code == 0, res.output
    res = run.invoke(cli, ["info", str(tmp_path / "ph.h5")])  # a reader that does read it refuses
    assert res.exit_code == 2 and "truth/scene" in res.output
