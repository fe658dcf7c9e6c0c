"""``sar info FILE``: what a file holds (any format sarcli reads), with warnings."""

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


@click.command("info")
@click.argument("path", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
@handle_errors
def command(path, as_json):
    """Describe any file sarcli reads: a YAML acquisition, a phase history (sarcli HDF5, GOTCHA .mat,
    CPHD), an image (sarcli HDF5, SICD, GeoTIFF) or a k-grid."""
    from ..core.geometry import DEFOCUS_WARN_RAD, RESOLUTION_DEFINITION
    from ..core.windows import IRW_FACTOR_UNIFORM
    from ..formers.formation import SPHERICAL_ADVICE
    from ..io.describe import describe

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # a dependency's notes to its own developers (sarkit's use of importlib.resources) are not
        # the user's concern: only warnings about the file are shown
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        info = describe(path)
    ww = [str(w.message) for w in caught]
    notes = list(info.pop("notes", []))
    defocus = info.get("farfield_phase_error_rad_at_grid_corner")
    if defocus is not None and info.get("model") == "spherical" and defocus > DEFOCUS_WARN_RAD:
        # not a fault of the file: advice on which image formers suit it
        notes.append(f"far-field methods (nufft, pfa) would defocus the grid corner of this spherical-wavefront "
                     f"collection by {defocus:.3g} rad (more than {DEFOCUS_WARN_RAD:g} rad): image it with a "
                     f"spherical former ({SPHERICAL_ADVICE})")
    ext = info.get("grid_extent_m")
    radii = info.get("alias_free_radius_m")
    grid = info.get("grid") if isinstance(info.get("grid"), dict) else {}
    pixel = max(float(grid.get("dx", 0.0)), float(grid.get("dy", 0.0)))
    # a derived grid is the alias-free radius rounded up to an even pixel count: up to a pixel more
    if ext and radii and max(ext) / 2 > min(radii.values()) + pixel:
        ww.append(f"the grid half-width {max(ext) / 2:.4g} m exceeds the alias-free radius "
                  f"{min(radii.values()):.4g} m: content beyond it wraps around")
    if "resolution_m" in info:
        # the same word means two widths: say which one this is, and how sar quality's IRW relates
        defined = {"resolution_definition": f"{RESOLUTION_DEFINITION}; the -3 dB width (IRW, sar quality) "
                                            f"is {IRW_FACTOR_UNIFORM:.3f} of it without a window, wider with one"}
        at = list(info).index("resolution_m") + 1
        info = dict([*list(info.items())[:at], *defined.items(), *list(info.items())[at:]])
    info["warnings"] = ww
    info["notes"] = notes
    if as_json:
        click.echo(json.dumps(info, indent=2, default=float))
        return
    for k, v in info.items():
        if k in ("warnings", "notes"):
            continue
        click.echo(f"{k:>40}: {_fmt(v)}")
    for n in notes:
        click.echo(f"note: {n}")
    for w in ww:
        click.echo(f"warning: {w}")
