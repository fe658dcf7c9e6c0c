"""``sar simulate CONFIG -o PH.h5``."""

from __future__ import annotations

import click

from .options import handle_errors, prepare_outputs, wrote


@click.command("simulate")
@click.argument("config", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Phase-history file to write (.h5).")
@click.option("--seed", type=click.IntRange(min=0), default=None, help="Seed for random phases and noise (default: the config's).")
@click.option("--snr-db", type=click.FloatRange(-200, 400), default=None, help="Override the config's noise.snr_db.")
@click.option("--noiseless", is_flag=True, help="Ignore the config's noise section.")
@click.option("--model", type=click.Choice(["farfield", "spherical"]), default=None,
              help="Data model (default: the config's).")
@click.option("--single", is_flag=True, help="Store complex64 samples instead of complex128.")
@click.pass_context
@handle_errors
def command(ctx, config, output, seed, snr_db, noiseless, model, single):
    """Simulate the phase history of CONFIG's scene and write it to OUTPUT."""
    import numpy as np

    from ..io.config import load_acquisition
    from ..io.hdf5 import write_phase_history
    from ..simulation.simulator import simulate

    from ..simulation.cost import check_simulate

    prepare_outputs([("config", config)], [("output", output)])
    acq = load_acquisition(config)
    check_simulate(acq, single=single)
    snr = None if noiseless else ("config" if snr_db is None else snr_db)
    ph = simulate(acq, seed=seed, snr_db=snr, model=model, dtype=np.complex64 if single else np.complex128)
    write_phase_history(output, ph)
    p, m = ph.data.shape
    wrote(output, f"{p} pulses x {m} frequencies, model {ph.model}"
          + (f", SNR {ph.acquisition.snr_db:g} dB" if ph.acquisition.snr_db is not None else ""))
