"""``sar autofocus PH.h5 -o FOCUSED.h5 [--method pga|min-entropy]``: remove per-pulse phase errors."""

from __future__ import annotations

import click

from ..autofocus import DEFAULT_METHOD, METHODS
from .options import echo_info, grid_options, handle_errors, parse_pair, prepare_outputs, wrote


@click.command("autofocus")
@click.argument("input_path", metavar="PH.h5", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Corrected phase-history file to write (.h5).")
@click.option("--method", type=click.Choice(METHODS), default=DEFAULT_METHOD, show_default=True,
              help="Minimum entropy, coarse to fine, or phase gradient autofocus; either "
                   "cross-validated between halves of the scene.")
@grid_options
@click.pass_context
@handle_errors
def command(ctx, input_path, output, method, center, extent, pixel_size):
    """Estimate per-pulse phase errors from the data and write the corrected phase history.

    The data are multiplied by exp(-i estimate) per pulse; the estimate is stored in
    /autofocus/phase_rad with the method. Constant and linear phase (a cross-range shift) are not
    observable and are left out of the estimate. The grid options choose the scene part the
    estimate is made on (default the file's grid). No correction is applied when none makes the
    image sharper (entropy and peak-to-mean), when the estimates from two halves of the scene
    do not agree beyond chance and sharpen the other half (min-entropy: each half; pga: in sum),
    or when they predict the estimate leaves no less error than they find in the data. What was
    decided and why (its code in brackets when nothing is applied) is stored in the file's
    attribute autofocus_decision and printed with -v.
    """
    import numpy as np

    from ..autofocus import autofocus
    from ..core.grid import resolve_grid
    from ..core.types import PhaseHistory
    from ..io import open_input
    from ..io.hdf5 import write_phase_history

    prepare_outputs([("input", input_path)], [("output", output)])
    _, ph = open_input(input_path, expect=("phase-history", "gotcha", "cphd"))
    ph = PhaseHistory(np.asarray(ph.data), ph.acquisition, ph.truth, dict(ph.attrs))
    grid = resolve_grid(ph.acquisition.grid, center=parse_pair(center, "--center"),
                        extent=parse_pair(extent, "--extent"), pixel_size=pixel_size)
    out, res = autofocus(ph, method, grid=grid)
    write_phase_history(output, out)
    if (ctx.find_root().obj or {}).get("verbose"):
        echo_info(ctx, out.attrs["autofocus_decision"])
    rms = float(np.sqrt(np.mean(res.phase_rad ** 2)))
    wrote(output, f"{method}: {rms:.3g} rad rms removed, entropy {res.entropy_before:.4f} -> "
                  f"{res.entropy_after:.4f}, peak-to-mean {res.peak_to_mean_before:.4g} -> "
                  f"{res.peak_to_mean_after:.4g}")
