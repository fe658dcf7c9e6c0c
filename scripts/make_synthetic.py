"""Regenerate data/synthetic/: small phase-history files for tests, demos and other tools.

Each file is one of the shipped configs reduced in size (fewer pulses and frequencies, same band
and aperture) and stored as complex64, so the folder stays well under 1 MB.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import yaml

import sarcli

REDUCED = {
    "three-points": {"frequencies.count": 128, "azimuths.count": 64, "image.pixels": 128},
    "shepp-logan": {"frequencies.count": 96, "azimuths.count": 96, "image.pixels": 96},
}


def reduced_config(name: str) -> dict:
    root = Path(__file__).resolve().parents[1]
    cfg = yaml.safe_load((root / "configs" / f"{name}.yaml").read_text())
    for dotted, value in REDUCED[name].items():
        node = cfg
        *parents, last = dotted.split(".")
        for k in parents:
            node = node[k]
        node[last] = value
    return cfg


def main(out_dir: str) -> None:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for name in REDUCED:
        cfg = reduced_config(name)
        text = yaml.safe_dump(cfg, sort_keys=False)
        acq = sarcli.parse_acquisition(cfg, source=f"configs/{name}.yaml (reduced)", text=text)
        ph = sarcli.simulate(acq, seed=1, dtype=np.complex64)
        path = out / f"{name}-small.h5"
        sarcli.write_phase_history(path, ph)
        print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "data/synthetic")
