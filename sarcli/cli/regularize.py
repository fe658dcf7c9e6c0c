"""``sar regularize PH.h5 -o IMG.h5 --prior ...``: regularised reconstruction by ADMM or CG."""

from __future__ import annotations

import click

from .options import export_options, grid_options, handle_errors, parse_pair, write_side_outputs, wrote


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
@click.option("--prior", type=click.Choice(["tv", "hotv", "l1", "ptv", "tikhonov"]), default="ptv",
              show_default=True, help="Regulariser: TV, higher-order TV, l1, phase-corrected TV, Tikhonov.")
@click.option("--order", type=click.IntRange(1, 3), default=1, show_default=True,
              help="Difference order k (hotv, ptv, tikhonov).")
@click.option("--lam", default="auto", show_default=True, metavar="auto|NUMBER",
              help="Regularisation weight λ in normalised units (l1: λ ≥ 2 zeroes the image); auto: SURE "
                   "with the noise power from the file or from range bins outside the scene, else "
                   "generalised cross-validation (no noise level needed).")
@click.option("--beta", type=click.FloatRange(min=0, min_open=True), default=None, help="ADMM penalty β (default 32 λ).")
@click.option("--iters", type=click.IntRange(min=1), default=300, show_default=True, help="Iteration cap.")
@click.option("--tol", type=click.FloatRange(min=0, min_open=True), default=1e-4, show_default=True, help="Relative-change tolerance.")
@click.option("--operator", type=click.Choice(["auto", "nufft", "toeplitz", "warped", "spherical"]), default="auto",
              show_default=True, help="Forward operator: far-field NUFFT pair or its pre-gridded Toeplitz form; "
                                      "for spherical data, warped sub-aperture NUFFTs held to --tolerance or the "
                                      "exact backprojection pair. auto: Toeplitz where the far field holds, else "
                                      "warped where it meets --tolerance, else the exact pair.")
@click.option("--tolerance", type=click.FloatRange(min=0, max=1, min_open=True, max_open=True), default=1e-3,
              show_default=True, help="Relative error of AᴴA, against the exact spherical model, that the warped "
                                      "operator is held to (--tol is the solver's stopping tolerance).")
@click.option("--anisotropic", is_flag=True, help="Anisotropic TV shrinkage (default isotropic).")
@click.option("--reestimate-every", type=click.IntRange(min=0), default=0, show_default=True,
              help="ptv: re-estimate the phases Θ from the iterate every N iterations (0: never).")
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
def command(ctx, input_path, output, prior, order, lam, beta, iters, tol, operator, tolerance, anisotropic,
            reestimate_every, outside_path, init_path, center, extent, pixel_size, history_png, png_path, tif_path):
    """Regularised image of a phase history: min ‖Af − b‖² + λ‖Tf‖₁ (ADMM) or Tikhonov (CG)."""
    from ..io import open_input
    from ..io.hdf5 import write_image
    from .._util.progress import message, progress
    from ..viz import plot_history
    from ..regularize import regularize

    from ..core.grid import resolve_grid
    from ..formers.planning.cost import check_regularize
    from .options import prepare_outputs

    prepare_outputs([("input", input_path), ("--init", init_path), ("--outside", outside_path)],
                    [("output", output), ("--png", png_path), ("--geotiff", tif_path), ("--history-png", history_png)])
    lam = _parse_lam(lam)
    _, ph = open_input(input_path, expect=("phase-history", "gotcha", "cphd"), truth=False)
    check_regularize(ph, resolve_grid(ph.acquisition.grid, center=parse_pair(center, "--center"),
                                      extent=parse_pair(extent, "--extent"), pixel_size=pixel_size),
                     iters=iters, operator=operator, auto=lam == "auto")
    init = open_input(init_path, expect=("image", "sicd"))[1] if init_path else None
    if outside_path:
        from ..regularize.patch import without_outside

        grid = resolve_grid(ph.acquisition.grid, center=parse_pair(center, "--center"),
                            extent=parse_pair(extent, "--extent"), pixel_size=pixel_size)
        ph = without_outside(ph, open_input(outside_path, expect=("image",))[1], grid)
    bar = progress(total=iters, desc=f"regularize {prior}", unit="it")
    quiet = bool((ctx.find_root().obj or {}).get("quiet"))

    def callback(iteration, objective):
        bar.set_postfix(objective=f"{objective:.4g}", refresh=False)

    try:
        img = regularize(ph, prior=prior, order=order, lam=lam, beta=beta, iters=iters, tol=tol,
                         operator=operator, tolerance=tolerance, center=parse_pair(center, "--center"),
                         extent=parse_pair(extent, "--extent"), pixel_size=pixel_size, init=init,
                         isotropic=not anisotropic, reestimate_every=reestimate_every, callback=callback,
                         progress=bar, notice=None if quiet else message)
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
    wrote(output, f"{prior} ({op}), {how}, {p.get('iterations', 0)} iterations{cap}, {img.runtime_s:.3g} s")
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
