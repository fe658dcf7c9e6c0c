"""``sar import cphd FILE.cphd -o PH.h5``: a CPHD file as a sarcli phase history."""

from __future__ import annotations

import click

from .options import cphd_arguments, cphd_options, echo_notes, handle_errors, prepare_outputs, wrote


@click.command("cphd")
@click.argument("cphd_file", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="Phase-history file to write (HDF5).")
@cphd_options
@click.pass_context
@handle_errors
def command(ctx, cphd_file, output, channel, sgn, troposphere):
    """Import one channel of CPHD_FILE (FX or TOA domain, monostatic or bistatic) as a spherical phase history."""
    from ..io.cphd import read_cphd
    from ..io.hdf5 import write_phase_history

    prepare_outputs([("input", cphd_file)], [("output", output)])
    ph = read_cphd(cphd_file, **(cphd_arguments(channel, sgn, troposphere) or {}))
    echo_notes(ph)
    write_phase_history(output, ph)
    P, M = ph.data.shape
    wrote(output, f"channel '{ph.attrs['cphd_channel']}', {P} pulses x {M} frequencies, spherical model")
