"""``sar quality IMG.h5 [--ph PH.h5 | --config CONFIG.yaml] [--at X,Y ...] [--json]``."""

from __future__ import annotations

import json

import click

from .options import handle_errors, parse_pair, window_choice


def _num(v, fmt):
    return "-" if v is None else format(v + 0.0, fmt)  # + 0.0: no "-0.000"


def _irw_definition(predicted) -> str:
    """The footer line that says which width the IRW columns are (not sar info's resolution)."""
    from ..core.windows import IRW_FACTOR_UNIFORM

    window = predicted.get("window") or "none"
    return (f"IRW: the -3 dB width of the main lobe along each cut, window {window} (pred: of the predicted PSF); "
            f"sar info's resolution c/(2B cos(elevation)) is the first null's distance, about "
            f"{1 / IRW_FACTOR_UNIFORM:.3f} x the IRW without a window")


def results_table(results) -> str:
    """The results as a table: every number is the JSON's, rounded (``measured`` x_m, y_m, ...)."""
    head = (f"{'target':<7s} {'status':<7s} {'exp_x':>8s} {'exp_y':>8s} {'x_m':>8s} {'y_m':>8s} {'err_m':>7s} "
            f"{'peak':>7s} | {'IRW_r m':>8s} {'pred':>8s} {'PSLR_r':>7s} {'pred':>7s} {'ISLR_r':>7s} {'pred':>7s} | "
            f"{'IRW_cr m':>8s} {'pred':>8s} {'PSLR_cr':>7s} {'pred':>7s} {'ISLR_cr':>7s} {'pred':>7s}")
    rows = [head, "-" * len(head)]
    empty = {"x_m": None, "y_m": None, "peak_position_error_m": None, "peak_magnitude": None,
             "range": {}, "cross_range": {}}
    for r in results:
        m, p = r["measured"] or empty, r["predicted"]
        cells = [f"{r['name']:<7s}", f"{r['status']:<7s}", _num(r["expected_at_m"][0], "8.3f"),
                 _num(r["expected_at_m"][1], "8.3f"), _num(m["x_m"], "8.3f"), _num(m["y_m"], "8.3f"),
                 _num(m["peak_position_error_m"], "7.4f"), _num(m["peak_magnitude"], "7.4f") + " |"]
        for d in ("range", "cross_range"):
            cells += [_num(m[d].get("irw_m"), "8.4f"), _num(p[d]["irw_m"], "8.4f"), _num(m[d].get("pslr_db"), "7.2f"),
                      _num(p[d]["pslr_db"], "7.2f"), _num(m[d].get("islr_db"), "7.2f"), _num(p[d]["islr_db"], "7.2f")]
            if d == "range":
                cells[-1] += " |"
        rows.append(" ".join(cells))
    measured = [r["measured"] for r in results if r["measured"]]
    if measured:
        m = measured[0]
        rows.append(f"range direction {m['range_direction_deg']:.2f} deg; dB values are 1-D cuts; ISLR within "
                    f"+/-{m['sidelobe_extent_cells']:g} resolution cells of the peak")
        rows.append("exp_x, exp_y: where the target should focus (truth plus layover for points off the image "
                    "plane); x_m, y_m: its own peak; err_m: the distance between the two")
        rows.append(_irw_definition(results[0]["predicted"]))
    for r in results:
        if r["layover_m"] is not None and any(abs(v) > 0 for v in r["layover_m"]):
            dx, dy = r["layover_m"]
            rows.append(f"{r['name']}: {r['truth_at_m'][2]:g} m off the image plane, focuses {dx:+.3f}, {dy:+.3f} m "
                        "from its (x, y) (layover)")
        if r["status"] == "close":
            rows.append(f"{r['name']}: close to {r['neighbour']} ({r['neighbour_cells']:.2f} resolution cells): "
                        "own peak measured, cut figures not (they would cross its main lobe)")
        elif r["status"] == "no peak":
            rows.append(f"{r['name']}: no peak of its own within reach of its expected position "
                        "(merged with a neighbour, or absent)")
    for r in results:
        m = r["measured"]
        if m and m["patch_truncated"]:
            rows.append(f"note: {r['name']} at ({m['x_m']:.3f}, {m['y_m']:.3f}) m lies near the image border: its "
                        f"neighbourhood (+/-{m['sidelobe_extent_cells'] + 2:g} resolution cells) is cut by it, so PSLR "
                        "and ISLR see only the sidelobes inside the image")
    return "\n".join(rows)


def _speckle(img, region, as_json):
    """Print the speckle metrics of ``img`` (:mod:`sarcli.analysis.speckle`)."""
    from ..analysis.speckle import region_slices, speckle_metrics
    from ..errors import SarcliInputError

    sl = None
    if region is not None:
        try:
            parts = [float(v) for v in region.split(",")]
            sl = region_slices(img.x_m, img.y_m, parts)
        except ValueError as exc:
            raise SarcliInputError(f"--region {region!r}: {exc}" if "region" in str(exc) else
                                   f"--region {region!r}: expected X0,X1,Y0,Y1 in metres") from None
    m = speckle_metrics(img.image, sl)
    if sl is not None:
        m["region_pixels"] = [sl[0].stop - sl[0].start, sl[1].stop - sl[1].start]
    if as_json:
        click.echo(json.dumps({"speckle": m}, indent=2))
        return
    where = "the whole image" if sl is None else f"region {region} m ({m['region_pixels'][0]} x {m['region_pixels'][1]} px)"
    click.echo(f"speckle: entropy {m['entropy']:.4f} nats (lower = sharper), peak/mean {m['peak_to_mean']:.4g}; "
               f"over {where}: ENL {m['enl']:.4g}, contrast {m['contrast']:.4f}")


@click.command("quality")
@click.argument("image", type=click.Path(dir_okay=False))
@click.option("--ph", "ph_path", type=click.Path(dir_okay=False), default=None,
              help="Phase history giving the geometry and the truth point targets.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False), default=None,
              help="YAML acquisition giving the geometry and the scene's point targets.")
@click.option("--at", "at", multiple=True, help="Target position X,Y in metres (repeatable).")
@window_choice(default=None,
              help="Window of the prediction (default: the one recorded in the image).")
@click.option("--oversample", type=click.IntRange(1, 64), default=8, show_default=True, help="FFT interpolation factor.")
@click.option("--sidelobe-extent", "extent_cells", type=click.FloatRange(min=1, max=1000), default=10.0, show_default=True,
              help="Sidelobe extent for PSLR/ISLR, in resolution cells.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
@click.option("--speckle", is_flag=True,
              help="Also print speckle metrics: entropy, peak/mean, ENL and contrast (alone without --ph/--config).")
@click.option("--region", default=None, metavar="X0,X1,Y0,Y1",
              help="Homogeneous region (m) for ENL and contrast (default: the whole image).")
@handle_errors
def command(image, ph_path, config_path, at, window, oversample, extent_cells, as_json, speckle, region):
    """Measure IRW, PSLR, ISLR and peak position of point targets in IMAGE, beside the predicted values.

    Each target is matched to its own peak of the image (no peak serves two targets), expected
    where the geometry focuses it: a point off the image plane lies over toward the radar by its
    height times tan(elevation). Targets within 3 resolution cells of another are marked 'close'
    (position and peak measured, cut figures not); 'no peak': none of its own within reach.
    """
    from ..errors import SarcliInputError
    from ..io import open_input
    from ..core.types import to_json
    from ..analysis.quality import image_quality, load_reference

    if speckle or region is not None:
        _speckle(open_input(image, expect=("image", "sicd"))[1], region, as_json)
        if ph_path is None and config_path is None:
            return
    if (ph_path is None) == (config_path is None):
        raise SarcliInputError("give exactly one of --ph PH.h5 or --config CONFIG.yaml (the geometry)")
    acq, truth = load_reference(ph_path or config_path)
    img = open_input(image, expect=("image", "sicd"))[1]
    targets = [parse_pair(a, "--at") for a in at] or None
    results = image_quality(img, acq, at=targets, truth=truth, window=window, oversample=oversample,
                            sidelobe_extent_cells=extent_cells)
    click.echo(json.dumps(json.loads(to_json(results)), indent=2) if as_json else results_table(results))
