"""Every compiled kernel family's outputs on fixed small inputs, saved or compared bit for bit.

    python scripts/native_bits.py save OUT.npz      # the outputs of the kernels installed here
    python scripts/native_bits.py compare A.npz B.npz

A change to ``src/native`` that is meant to leave the arithmetic alone leaves every array the
same bit for bit (``compare`` exits 1 and lists what differs otherwise, with the largest relative
difference). Run ``save`` with each build (e.g. ``SARCLI_BP_ISA=1`` too, for the AVX2 copies).
"""

from __future__ import annotations

import sys

import numpy as np
import yaml

import sarcli
from sarcli.core import geometry
from sarcli.core.grid import Grid
from sarcli.formers.backprojection import backproject, pulse_contractions, reproject
from sarcli.formers.direct import direct_spherical
from sarcli.formers.ffbp import ffbp
from sarcli.formers.points import backproject_points, reproject_points
from sarcli.linops.warped import WarpedNufftOperator
from sarcli.core.collection import Collection
from sarcli.formers.options import BackprojectionOptions

GRID = Grid(48, 40, 0.3, 0.3)
FREQ = 9.7e9 + 4e6 * np.arange(96)


def _point_data(a, r0, rcv=None):
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(-6, 6, 8), rng.uniform(-6, 6, 8), np.zeros(8)])
    amps = rng.normal(size=8) + 1j * rng.normal(size=8)
    dr = geometry.differential_range(a, r0, pts) if rcv is None else \
        geometry.bistatic_differential_range(a, rcv, r0, pts)
    psi = 4 * np.pi / geometry.C * FREQ[None, :, None] * dr[:, None, :]
    return (np.exp(-1j * psi) * amps).sum(-1)


def _circle(P, r0=3e3, aperture_deg=6.0):
    az = np.radians(np.linspace(-aperture_deg / 2, aperture_deg / 2, P))
    a = geometry.antenna_positions_circle(az, np.radians(35), r0)
    return a, np.linalg.norm(a, axis=1)


def outputs() -> dict[str, np.ndarray]:
    """Name -> array of every case."""
    out = {}
    a, r0 = _circle(96)
    d = _point_data(a, r0)
    rcv = a + np.array([0.0, 40.0, 5.0])
    r0b = 0.5 * (np.linalg.norm(a, axis=1) + np.linalg.norm(rcv, axis=1))
    db = _point_data(a, r0b, rcv)
    near, rn = _circle(64, r0=60.0)   # near the radar: the series range model's tiles
    dn = _point_data(near, rn)
    g = np.random.default_rng(5).normal(size=GRID.shape) + 0j
    for interp in ("linear", "cubic", "lanczos"):
        for prec in ("float32", "float64"):
            k = BackprojectionOptions(interp=interp, precision=prec, upsample=8)
            mono, bi, close = Collection(FREQ, a, r0), Collection(FREQ, a, r0b, receive_position_m=rcv), \
                Collection(FREQ, near, rn)
            out[f"bp/{interp}/{prec}"] = backproject(d, mono, GRID, k)
            out[f"bp-bistatic/{interp}/{prec}"] = backproject(db, bi, GRID, k)
            out[f"bp-near/{interp}/{prec}"] = backproject(dn, close, GRID, k)
            out[f"rp/{interp}/{prec}"] = reproject(out[f"bp/{interp}/{prec}"], mono, GRID, k)
            out[f"rp-near/{interp}/{prec}"] = reproject(out[f"bp-near/{interp}/{prec}"], close, GRID, k)
            out[f"contract/{interp}/{prec}"] = pulse_contractions(d, g, mono, GRID, k)
            pts = np.stack(np.meshgrid(GRID.x, GRID.y), -1)
            pts = np.concatenate([pts, 0.3 * np.sin(pts[..., :1])], -1)
            out[f"points/{interp}/{prec}"] = backproject_points(d, mono, pts, k)
            out[f"points-bistatic/{interp}/{prec}"] = backproject_points(db, bi, pts, k)
            out[f"rpoints/{interp}/{prec}"] = reproject_points(out[f"points/{interp}/{prec}"], mono, pts, k)
    a2, r02 = _circle(192)
    d2 = _point_data(a2, r02)
    for knobs in (dict(), dict(interp="cubic", os_range=3, os_angle=3, upsample=8),
                  dict(interp="linear", os_range=4, os_angle=4, upsample=8),
                  dict(interp="lanczos", os_range=3, os_angle=2), dict(interp="optimal", base=2, merge=3),
                  dict(interp="optimal", os_range=1.5, upsample=3.0)):
        name = "ffbp/" + ",".join(f"{k}={v}" for k, v in knobs.items())
        out[name] = ffbp(d2, Collection(FREQ, a2, r02), GRID, **knobs)
    out["ffbp-bistatic"] = ffbp(db, Collection(FREQ, a, r0b, receive_position_m=rcv), GRID)
    out["direct"] = direct_spherical(d, FREQ, a, r0, GRID)
    cfg = yaml.safe_load(open("configs/three-points.yaml"))
    cfg["frequencies"]["count"] = 64
    cfg["azimuths"]["count"] = 48
    cfg["image"] = {"half_width_m": 5.0, "pixels": 64}
    acq = sarcli.parse_acquisition(cfg)
    for model in ("spherical", "farfield"):
        ph = sarcli.simulate(acq, model=model)
        out[f"simulate/{model}"] = ph.data
        methods = ("direct", "backprojection", "ffbp", "subimage") if model == "spherical" else \
            ("direct", "nufft", "pfa", "backprojection")
        for method in methods:
            out[f"form/{model}/{method}"] = sarcli.form_image(ph, method).image
    op = WarpedNufftOperator(acq, Grid(64, 64, 10.0 / 64, 10.0 / 64), subapertures=4)
    rng = np.random.default_rng(7)
    x = rng.normal(size=op.ishape) + 1j * rng.normal(size=op.ishape)
    y = op.forward(x)
    out["spread/forward"] = y
    out["spread/adjoint"] = op.adjoint(y)
    return out


def main(argv) -> int:
    if len(argv) == 2 and argv[0] == "save":
        np.savez(argv[1], **{k.replace("/", "|"): np.asarray(v) for k, v in outputs().items()})
        return 0
    if len(argv) == 3 and argv[0] == "compare":
        a, b = np.load(argv[1]), np.load(argv[2])
        bad = 0
        for k in sorted(set(a.files) | set(b.files)):
            if k not in a.files or k not in b.files:
                print(f"{k}: in one file only")
                bad += 1
                continue
            x, y = a[k], b[k]
            if x.shape != y.shape or x.tobytes() != y.tobytes():
                rel = np.max(np.abs(x - y)) / max(np.max(np.abs(x)), 1e-300) if x.shape == y.shape else np.inf
                print(f"{k.replace('|', '/')}: differs (max |a - b| / max |a| = {rel:.3g})")
                bad += 1
        print(f"{len(a.files)} arrays, {bad} differ")
        return 1 if bad else 0
    print(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
