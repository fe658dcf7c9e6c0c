"""``sar regularize PH.h5 -o IMG.h5 --prior ...``: regularised reconstruction by ADMM or CG."""

from __future__ import annotations

import click

from ..regularize.options import OPERATORS, RegularizeOptions
from .options import export_options, grid_options, handle_errors, parse_pair, write_side_outputs, wrote

_DEFAULTS = RegularizeOptions()


def _help(name: str) -> str:
    """The help of an option: :class:`RegularizeOptions`'s text for its field."""
    return RegularizeOptions.__dataclass_fields__[name].metadata["help"]


def _parse_lam(text):
    """'auto' or a finite number >= 0 (one-line error otherwise)."""
    from ..errors import SarcliInputError

    if str(text).strip().lower() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (value >= 0 and value != float("inf")):
        raise SarcliInputError(f"--lam {text!r}: expected 'auto' or a finite number >= 0")
    return value


@click.command("regularize")
@click.argument("input_path", metavar="PH.h5", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Image file to write (.h5).")
@click.option("--prior", type=click.Choice(["tv", "hotv", "l1", "ptv", "tikhonov"]), default=_DEFAULTS.prior,
              show_default=True, help=_help("prior"))
@click.option("--order", type=click.IntRange(1, 3), default=_DEFAULTS.order, show_default=True, help=_help("order"))
@click.option("--lam", default=_DEFAULTS.lam, show_default=True, metavar="auto|NUMBER", help=_help("lam"))
@click.option("--beta", type=click.FloatRange(min=0, min_open=True), default=None, help=_help("beta"))
@click.option("--iters", type=click.IntRange(min=1), default=_DEFAULTS.iters, show_default=True, help=_help("iters"))
@click.option("--tol", type=click.FloatRange(min=0, min_open=True), default=_DEFAULTS.tol, show_default=True,
              help=_help("tol"))
@click.option("--operator", type=click.Choice(OPERATORS), default=_DEFAULTS.operator, show_default=True,
              help=_help("operator"))
@click.option("--tolerance", type=click.FloatRange(min=0, max=1, min_open=True, max_open=True),
              default=_DEFAULTS.tolerance, show_default=True, help=_help("tolerance"))
@click.option("--anisotropic", is_flag=True, help="Anisotropic TV shrinkage (default isotropic).")
@click.option("--reestimate-every", type=click.IntRange(min=0), default=_DEFAULTS.reestimate_every, show_default=True,
              help=_help("reestimate_every"))
@click.option("--outside", "outside_path", type=click.Path(dir_okay=False), default=None, metavar="IMG.h5",
              help="A regularised image of the whole scene: its part outside this grid (and a guard band of "
                   "four resolution cells) is reprojected and taken out of the data first, so that a patch is "
                   "regularised against its own echoes.")
@click.option("--init", "init_path", type=click.Path(dir_okay=False), default=None,
              help="Initial image file (also the phase estimate f0 of ptv; default: the matched filter).")
@grid_options
@click.option("--history-png", "history_png", type=click.Path(dir_okay=False), default=None,
              help="Plot objective and relative change against iteration and time.")
@export_options
@click.pass_context
@handle_errors
def command(ctx, input_path, output, **knobs):
    """Regularised image of a phase history: min ‖Af − b‖² + λ‖Tf‖₁ (ADMM) or Tikhonov (CG)."""
    from ..io import open_input
    from ..io.hdf5 import write_image
    from .._util.progress import message, progress
    from ..viz import plot_history
    from ..regularize import regularize

    from ..core.grid import resolve_grid
    from ..formers.planning.cost import check_regularize
    from .options import prepare_outputs

    outside_path, init_path, history_png = knobs.pop("outside_path"), knobs.pop("init_path"), knobs.pop("history_png")
    center, extent, pixel_size = knobs.pop("center"), knobs.pop("extent"), knobs.pop("pixel_size")
    png_path, tif_path = knobs.pop("png_path"), knobs.pop("tif_path")
    prepare_outputs([("input", input_path), ("--init", init_path), ("--outside", outside_path)],
                    [("output", output), ("--png", png_path), ("--geotiff", tif_path), ("--history-png", history_png)])
    knobs["isotropic"] = not knobs.pop("anisotropic")
    knobs["lam"] = _parse_lam(knobs["lam"])
    opts = RegularizeOptions(**knobs)
    where = dict(center=parse_pair(center, "--center"), extent=parse_pair(extent, "--extent"), pixel_size=pixel_size)
    _, ph = open_input(input_path, expect=("phase-history", "gotcha", "cphd"), truth=False)
    grid = resolve_grid(ph.acquisition.grid, **where)
    check_regularize(ph, grid, iters=opts.iters, operator=opts.operator, auto=opts.auto)
    init = open_input(init_path, expect=("image", "sicd"))[1] if init_path else None
    if outside_path:
        from ..regularize.patch import without_outside

        ph = without_outside(ph, open_input(outside_path, expect=("image",))[1], grid)
    bar = progress(total=opts.iters, desc=f"regularize {opts.prior}", unit="it")
    quiet = bool((ctx.find_root().obj or {}).get("quiet"))

    def callback(iteration, objective):
        bar.set_postfix(objective=f"{objective:.4g}", refresh=False)

    try:
        img = regularize(ph, opts, grid=grid, init=init, callback=callback, progress=bar,
                         notice=None if quiet else message)
    finally:
        bar.close()
    write_image(output, img)
    write_side_outputs(img, png_path, tif_path)
    if history_png:
        plot_history(img.history, history_png)
        wrote(history_png, "objective and relative change per iteration")
    p = img.parameters
    sel = p.get("lam_selection")
    how = f"lam {p['lam']:.4g}" + (f" by {sel['criterion']}" if sel else "")
    op = p["operator"] + (f", {p['subapertures']} sub-apertures, predicted error {p['operator_predicted_error']:.2g}"
                          if p["operator"] == "warped" else "")
    if sel and sel.get("at_path_end"):
        how += f" at the {sel['at_path_end']} lam of its path"
    cap = " (cap reached)" if p.get("iteration_cap_reached") else ""
    wrote(output, f"{opts.prior} ({op}), {how}, {p.get('iterations', 0)} iterations{cap}, {img.runtime_s:.3g} s")
    if not quiet:
        for item in p.get("advice", []):
            click.echo(f"note: {item['line']}")
    if sel and (ctx.find_root().obj or {}).get("verbose") and not quiet:
        click.echo(lam_selection_line(sel))


def lam_selection_line(sel: dict) -> str:
    """One line of ``parameters['lam_selection']``: criterion, λ, noise estimate and source, path."""
    path = " ".join(f"{lam:.3g}" for lam in sel["lams"])
    sigma2 = sel.get("noise_power")
    noise = f"{sigma2:.3g}" if sigma2 is not None and sigma2 == sigma2 else "none"
    return (f"lam selection: {sel['criterion']} -> lam {sel['lam']:.4g} ({sel['status']}); noise power {noise} "
            f"({sel['noise_source']}); path lam {path}; {sum(sel.get('path_iterations', []))} path iterations x 2")
