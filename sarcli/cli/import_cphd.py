"""``sar import cphd FILE.cphd -o PH.h5``: a CPHD file as a sarcli phase history."""

from __future__ import annotations

import click

from .options import handle_errors, prepare_outputs, wrote


@click.command("cphd")
@click.argument("cphd_file", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Phase-history file to write (HDF5).")
@click.pass_context
@handle_errors
def command(ctx, cphd_file, output):
    """Import CPHD_FILE (FX domain, monostatic or bistatic; first channel) as a spherical phase history."""
    from ..io.cphd import read_cphd
    from ..io.hdf5 import write_phase_history

    prepare_outputs([("input", cphd_file)], [("output", output)])
    ph = read_cphd(cphd_file)
    write_phase_history(output, ph)
    P, M = ph.data.shape
    wrote(output, f"{P} pulses x {M} frequencies, spherical model")
