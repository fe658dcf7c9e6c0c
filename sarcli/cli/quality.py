"""``sar quality IMG.h5 [--ph PH.h5 | --config CONFIG.yaml] [--at X,Y ...] [--json]``."""

from __future__ import annotations

import json

import click

from .options import handle_errors, parse_pair, window_choice


def _num(v, fmt):
    return "-" if v is None else format(v + 0.0, fmt)  # + 0.0: no "-0.000"


def _table(results) -> str:
    head = (f"{'target':<7s} {'x_m':>8s} {'y_m':>8s} {'err_m':>8s} {'peak':>7s} | "
            f"{'IRW_r m':>8s} {'pred':>8s} {'PSLR_r':>7s} {'pred':>7s} {'ISLR_r':>7s} {'pred':>7s} | "
            f"{'IRW_cr m':>8s} {'pred':>8s} {'PSLR_cr':>7s} {'pred':>7s} {'ISLR_cr':>7s} {'pred':>7s}")
    rows = [head, "-" * len(head)]
    for r in results:
        m, p = r["measured"], r["predicted"]
        cells = [f"{r['name']:<7s}", _num(m["x_m"], "8.3f"), _num(m["y_m"], "8.3f"),
                 _num(m["peak_position_error_m"], "8.4f"), _num(m["peak_magnitude"], "7.4f") + " |"]
        for d in ("range", "cross_range"):
            cells += [_num(m[d]["irw_m"], "8.4f"), _num(p[d]["irw_m"], "8.4f"), _num(m[d]["pslr_db"], "7.2f"),
                      _num(p[d]["pslr_db"], "7.2f"), _num(m[d]["islr_db"], "7.2f"), _num(p[d]["islr_db"], "7.2f")]
            if d == "range":
                cells[-1] += " |"
        rows.append(" ".join(cells))
    if results:
        m = results[0]["measured"]
        rows.append(f"range direction {m['range_direction_deg']:.2f} deg; dB values are 1-D cuts; "
                    f"ISLR within +/-{m['sidelobe_extent_cells']:g} resolution cells of the peak")
    if any(r["measured"]["patch_truncated"] for r in results):
        rows.append("note: some targets lie near the image border (neighbourhood truncated)")
    return "\n".join(rows)


@click.command("quality")
@click.argument("image", type=click.Path(dir_okay=False))
@click.option("--ph", "ph_path", type=click.Path(dir_okay=False), default=None,
              help="Phase history giving the geometry and the truth point targets.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False), default=None,
              help="YAML acquisition giving the geometry and the scene's point targets.")
@click.option("--at", "at", multiple=True, help="Target position X,Y in metres (repeatable).")
@window_choice(default=None,
              help="Window of the prediction (default: the one recorded in the image).")
@click.option("--oversample", type=int, default=8, show_default=True, help="FFT interpolation factor.")
@click.option("--sidelobe-extent", "extent_cells", type=float, default=10.0, show_default=True,
              help="Sidelobe extent for PSLR/ISLR, in resolution cells.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
@handle_errors
def command(image, ph_path, config_path, at, window, oversample, extent_cells, as_json):
    """Measure IRW, PSLR, ISLR and peak position of point targets in IMAGE, beside the predicted values."""
    from ..errors import SarcliInputError
    from ..io.hdf5 import read_image
    from ..core.types import to_json
    from ..analysis.quality import image_quality, load_reference

    if (ph_path is None) == (config_path is None):
        raise SarcliInputError("give exactly one of --ph PH.h5 or --config CONFIG.yaml (the geometry)")
    acq, truth = load_reference(ph_path or config_path)
    img = read_image(image)
    targets = [parse_pair(a, "--at") for a in at] or None
    results = image_quality(img, acq, at=targets, truth=truth, window=window, oversample=oversample,
                            sidelobe_extent_cells=extent_cells)
    click.echo(json.dumps(json.loads(to_json(results)), indent=2) if as_json else _table(results))
