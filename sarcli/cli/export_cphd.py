"""``sar export-cphd PH.h5 -o FILE.cphd``: a phase history as a CPHD 1.1.0 file."""

from __future__ import annotations

import click

from .options import handle_errors, prepare_outputs, wrote


@click.command("export-cphd")
@click.argument("phase_history", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="CPHD file to write.")
@handle_errors
def command(phase_history, output):
    """Export PHASE_HISTORY (needs antenna positions and equally spaced frequencies) to CPHD."""
    from ..io import open_input
    from ..io.cphd import write_cphd

    prepare_outputs([("input", phase_history)], [("output", output)])
    _, ph = open_input(phase_history, expect=("phase-history", "gotcha", "cphd"), truth=False)
    write_cphd(ph, output)
    wrote(output, f"CPHD, {ph.data.shape[0]} pulses x {ph.data.shape[1]} frequencies")
