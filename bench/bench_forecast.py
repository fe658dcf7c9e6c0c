"""The time forecast of ``regularize`` (``predicted_s``, the notice line) against measured runs.

Two collections of ``bench_lam.py``'s disk family ("shapes", 10 dB, seed 3001): far-field data
(128 pulses x 128 frequencies, 248² pixels: the Toeplitz operator) and spherical data from 1 km
(40 x 40 samples, 78² pixels: the exact spherical pair, each AᴴA product a backprojection and a
reprojection). Each is solved with λ auto and at a fixed λ (0.05), ptv, every other default. Prints,
per run, the forecast (expected and bound), the wall seconds of the run after its scaling's
second product (what the forecast covers; ``runtime_s`` less the set-up before it), the AᴴA
products counted, and forecast / measured. Usage: ``python bench/bench_forecast.py``.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_lam import disk_scene  # noqa: E402


def main():
    import sarcli.regularize.forecast as forecast
    from sarcli.errors import ConvergenceWarning
    from sarcli.regularize import regularize

    cases = (("far-field (toeplitz)", {"P": 128, "M": 128}, False),
             ("spherical", {"P": 40, "M": 40}, True))
    print("| collection | λ | pixels | AᴴA products (scaling, path, final) | s per product | forecast s "
          "(bound) | measured s | forecast / measured |")
    print("|" + "---|" * 8)
    for name, kw, spherical in cases:
        ph, _, _ = disk_scene("shapes", 10.0, spherical=spherical, seed=3001, **kw)
        for lam in ("auto", 0.05):
            marks = []
            orig = forecast.Forecast.on_power

            def on_power(self, i, _orig=orig):
                _orig(self, i)
                if i == 2:
                    marks.append(time.perf_counter())

            forecast.Forecast.on_power = on_power
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", ConvergenceWarning)
                    img = regularize(ph, prior="ptv", lam=lam, operator="spherical" if spherical else "auto")
                end = time.perf_counter()
            finally:
                forecast.Forecast.on_power = orig
            p = img.parameters
            g = p["gram_products"]
            measured = end - marks[0]
            print(f"| {name} | {lam} | {p['grid']['nx']} | {g['total']} "
                  f"({g['scaling']}, {g['path']}, {g['final']}) | {p['seconds_per_product']:.3g} | "
                  f"{p['predicted_s']:.1f} ({p['predicted_max_s']:.1f}) | {measured:.1f} | "
                  f"{p['predicted_s'] / measured:.2f} |", flush=True)


if __name__ == "__main__":
    main()
