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
@click.option("--precision", type=click.Choice(["float32", "float64"]), default="float32", show_default=True,
              help="Stored samples: complex64 (float32) or complex128 (float64); the sums are float64 either way.")
@click.pass_context
@handle_errors
def command(ctx, config, output, seed, snr_db, noiseless, model, precision):
    """Simulate the phase history of CONFIG's scene and write it to OUTPUT."""
    from ..io.config import load_acquisition
    from ..simulation.cost import check_simulate
    from ..simulation.simulator import PRECISIONS, simulate_file

    prepare_outputs([("config", config)], [("output", output)])
    acq = load_acquisition(config)
    check_simulate(acq, precision=precision)
    snr = None if noiseless else ("config" if snr_db is None else snr_db)
    # written by blocks of pulses: a point scene's memory is one block, not the collection
    ph = simulate_file(acq, output, seed=seed, snr_db=snr, model=model, dtype=PRECISIONS[precision])
    p, m = ph.data.shape
    wrote(output, f"{p} pulses x {m} frequencies, model {ph.model}"
          + (f", SNR {ph.acquisition.snr_db:g} dB" if ph.acquisition.snr_db is not None else ""))
