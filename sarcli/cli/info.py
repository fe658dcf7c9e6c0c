"""``sar info FILE``: sizes, band, aperture, resolution, alias-free radii, model, warnings."""

from __future__ import annotations

import json
import warnings

import click

from .options import handle_errors


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    if isinstance(v, dict):
        return ", ".join(f"{k} {_fmt(x)}" for k, x in v.items())
    return str(v)


def describe(path) -> dict:
    """Summary of a YAML acquisition, a phase-history file or an image file (library-level)."""
    from pathlib import Path

    import h5py

    from ..io.config import load_acquisition
    from ..io.hdf5 import IMAGE_FORMAT, read_image, read_phase_history

    p = Path(path)
    if p.suffix.lower() in (".yaml", ".yml"):
        acq = load_acquisition(p)
        out = {"file": str(p), "kind": "acquisition (YAML)", **acq.summary()}
        if acq.scene:
            out["scene"] = sorted(acq.scene)
        return out
    fmt = None
    try:
        with h5py.File(p, "r") as f:
            fmt = f.attrs.get("format")
            fmt = fmt.decode() if isinstance(fmt, bytes) else fmt
    except OSError:
        pass
    if fmt == IMAGE_FORMAT:
        img = read_image(p)
        mag = abs(img.image)
        return {"file": str(p), "kind": "image", "method": img.method, "shape": list(img.image.shape),
                "x_m": [float(img.x_m[0]), float(img.x_m[-1])], "y_m": [float(img.y_m[0]), float(img.y_m[-1])],
                "peak_magnitude": float(mag.max()), "runtime_s": img.runtime_s, "parameters": img.parameters}
    ph = read_phase_history(p)
    out = {"file": str(p), "kind": "phase history", **ph.acquisition.summary(),
           "dtype": str(ph.data.dtype), "sarcli_version": ph.attrs.get("sarcli_version", "?")}
    if ph.truth is not None:
        out["truth_points"] = int(len(ph.truth.point_amplitude))
    return out


@click.command("info")
@click.argument("path", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
@handle_errors
def command(path, as_json):
    """Describe a YAML acquisition, a phase-history file or an image file."""
    from ..core.geometry import DEFOCUS_WARN_RAD

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        info = describe(path)
    ww = [str(w.message) for w in caught]
    if "farfield_phase_error_rad_at_grid_corner" in info and info["farfield_phase_error_rad_at_grid_corner"] > DEFOCUS_WARN_RAD:
        ww.append(f"a far-field method on this collection defocuses the grid corner by "
                  f"{info['farfield_phase_error_rad_at_grid_corner']:.3g} rad (use backprojection or direct)")
    ext = info.get("grid_extent_m")
    radii = info.get("alias_free_radius_m")
    if ext and radii and max(ext) / 2 > min(radii.values()):
        ww.append(f"the grid half-width {max(ext) / 2:.4g} m exceeds the alias-free radius "
                  f"{min(radii.values()):.4g} m: content beyond it wraps around")
    info["warnings"] = ww
    if as_json:
        click.echo(json.dumps(info, indent=2, default=float))
        return
    for k, v in info.items():
        if k == "warnings":
            continue
        click.echo(f"{k:>40}: {_fmt(v)}")
    for w in ww:
        click.echo(f"warning: {w}")
