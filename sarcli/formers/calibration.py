"""The planner's cost model: seconds per operation of every former, measured on this machine.

:mod:`sarcli.formers.planner` predicts a former's time as its operation counts times these
constants. :func:`calibrate` measures them with small instances of every former (a few seconds)
and, for the whole command, the start-up (a fresh interpreter importing what ``sar form-image``
imports), reading and writing. Its result is kept per machine in the user's cache folder
(``$SARCLI_CACHE_DIR``, else ``$XDG_CACHE_HOME/sarcli``, else ``~/.cache/sarcli``), named by a
fingerprint of the CPU model, the processors this process may use, the kernels' SIMD level and
sarcli's version, so a calibration never serves another machine. Until a machine is calibrated
(``sar plan`` calibrates it on first use; ``sar plan --calibrate`` again), the constants are those
of the reference machine that ship with the package (``cost_model.json`` beside this module,
written by ``bench/bench_ffbp.py --calibrate``).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from ..core.grid import Grid

__all__ = ["DEFAULT_COSTS", "COST_MODEL_PATH", "load_cost_model", "calibrate", "is_calibrated", "machine",
           "user_cost_model_path"]

#: The reference machine's constants, shipped with the package.
COST_MODEL_PATH = Path(__file__).with_name("cost_model.json")
#: Per-operation seconds (one core) where neither a calibration nor the shipped file has one;
#: ``startup``, ``planning``: seconds; ``read_per_byte``, ``write_per_byte``: seconds per byte.
DEFAULT_COSTS = {"direct": 6e-9, "bp": 3e-9, "bp_fft": 4e-9, "ffbp_stage0": 4e-9, "ffbp_mac": 1.5e-9,
                 "ffbp_node0": 0.0, "ffbp_pair": 0.0, "nufft_spread": 3e-9, "nufft_fft": 3e-9,
                 "subimage_point": 2e-9, "threads": 2, "startup": 0.5, "planning": 0.02,
                 "read_per_byte": 1e-9, "write_per_byte": 2e-9}
#: What a fresh ``sar form-image`` imports before it forms an image (the start-up it pays).
_STARTUP_IMPORTS = ("import sarcli.cli.main, sarcli.cli.form_image, sarcli.formers.formation, "
                    "sarcli.formers.planner, sarcli.io.hdf5, sarcli._native; sarcli._native.threads()")


@functools.lru_cache(maxsize=1)
def machine() -> dict:
    """What a calibration is valid for: CPU model, usable processors, SIMD level, sarcli version."""
    from .. import __version__
    from .._native import simd_level

    model = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            model = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), model)
    except OSError:
        pass
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:
        cpus = os.cpu_count() or 1
    return {"cpu": model, "cpus": cpus, "simd": simd_level(), "sarcli": __version__}


def user_cost_model_path() -> Path:
    """This machine's calibration file in the user's cache folder (see the module docstring)."""
    root = os.environ.get("SARCLI_CACHE_DIR") or Path(os.environ.get("XDG_CACHE_HOME") or
                                                      Path.home() / ".cache") / "sarcli"
    key = hashlib.blake2b(json.dumps(machine(), sort_keys=True).encode(), digest_size=6).hexdigest()
    return Path(root) / f"cost_model-{key}.json"


def _read(path: Path) -> dict | None:
    try:
        return json.loads(Path(path).read_text())["seconds_per_op"]
    except (OSError, ValueError, KeyError, TypeError):
        return None


def is_calibrated() -> bool:
    """Whether this machine has a calibration of its own."""
    return _read(user_cost_model_path()) is not None


def load_cost_model() -> dict:
    """The constants: this machine's calibration if there is one, else the shipped reference
    machine's, with :data:`DEFAULT_COSTS` for any missing; ``calibrated`` says which."""
    costs = dict(DEFAULT_COSTS)
    own = _read(user_cost_model_path())
    costs.update(_read(COST_MODEL_PATH) or {})
    costs.update(own or {})
    costs["calibrated"] = own is not None
    return costs


def _best(fn, repeat):
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return min(ts)


def _command_costs(repeat) -> dict:
    """Start-up of a fresh interpreter importing what ``sar form-image`` does, and HDF5 read and
    write seconds per byte (a 32 MiB complex array)."""
    import tempfile

    import h5py

    startup = _best(lambda: subprocess.run([sys.executable, "-c", _STARTUP_IMPORTS], check=True,
                                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL), repeat)
    a = np.zeros((2048, 1024), np.complex128)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "io.h5"

        def write():
            with h5py.File(path, "w") as f:
                f["a"] = a

        def read():
            with h5py.File(path, "r") as f:
                f["a"][()]

        w = _best(write, repeat)
        r = _best(read, repeat)
    return {"startup": startup, "read_per_byte": r / a.nbytes, "write_per_byte": w / a.nbytes}


def calibrate(path=None, *, repeat: int = 3) -> dict:
    """Measure the constants on this machine and write them to ``path`` (default: this machine's
    file in the user's cache, :func:`user_cost_model_path`); returns them.

    Small instances of every former (a few seconds in all); each constant is its measured time
    (best of ``repeat``) divided by its operation count, except ffbp's four
    (``planner._FFBP_TERMS``), fitted by non-negative least squares to six settings with
    different shares of each; then the whole command's start-up, planning, reading and writing.
    """
    from ..core import geometry
    from .planner import _FFBP_TERMS, _ffbp_counts, _nufft_width
    from . import ffbp as fb
    from .backprojection import backproject, profile_length
    from .direct import direct_spherical
    from .nufft import nufft_farfield
    from .subimage import subimage_nufft

    def best(fn):
        fn()
        ts = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            fn()
            ts.append(time.perf_counter() - t0)
        return min(ts)

    P, M, N = 256, 256, 256
    freq = 9.6e9 + 2e6 * np.arange(M)
    az = np.radians(np.linspace(-3, 3, P))
    a = geometry.antenna_positions_circle(az, np.radians(30), 10e3)
    r0 = np.linalg.norm(a, axis=1)
    rng = np.random.default_rng(0)
    d = rng.normal(size=(P, M)) + 1j * rng.normal(size=(P, M))
    grid = Grid(N, N, 0.25, 0.25)
    thr = 2
    c = {"threads": thr}
    L = profile_length(M, 8)
    c["bp_fft"] = DEFAULT_COSTS["bp_fft"]
    c["bp"] = best(lambda: backproject(d, freq, a, r0, grid)) * thr / (P * N * N)
    small = Grid(32, 32, 0.5, 0.5)
    c["direct"] = best(lambda: direct_spherical(d, freq, a, r0, small)) * thr / (P * M * 32 * 32)
    # ffbp: settings whose shares of stage 0 (per pulse-node tap and per node), interpolation taps
    # and (node, child) pairs differ; non-negative least squares gives the four constants
    rows, rhs = [], []
    for knobs in ({}, {"base": 8}, {"base": 32}, {"base": 4}, {"os_range": 2.0, "os_angle": 2.0},
                  {"base": 8, "os_range": 3.0, "os_angle": 3.0}):
        plan = fb.plan_stages(a, freq, grid, **knobs)
        lf = profile_length(M, plan.knobs["upsample"])
        t = best(lambda: fb.ffbp(d, freq, a, r0, grid, **knobs)) * thr
        rows.append(_ffbp_counts(plan.ops))
        rhs.append(max(t - c["bp_fft"] * P * lf * math.log2(lf), 0.0))
    from scipy.optimize import nnls
    scale = np.max(np.array(rows), axis=0)
    sol = nnls(np.array(rows) / scale, np.array(rhs))[0] / scale
    if not np.any(sol > 0):
        # ill-posed on this machine's timings: split the default setting's time in the default ratio
        o = rows[0]
        ref = sum(DEFAULT_COSTS[name] * n for (name, _), n in zip(_FFBP_TERMS, o))
        sol = [DEFAULT_COSTS[name] * rhs[0] / ref for name, _ in _FFBP_TERMS]
    for (name, _), v in zip(_FFBP_TERMS, sol):
        c[name] = float(v)
    kx, ky = geometry.kspace_coordinates(freq, az, np.radians(30))
    w = _nufft_width(1e-6)
    t = best(lambda: nufft_farfield(d, kx, ky, grid, eps=1e-6)) * thr
    n_fft = 4.0 * N * N
    c["nufft_fft"] = DEFAULT_COSTS["nufft_fft"]
    c["nufft_spread"] = max(1e-11, (t - c["nufft_fft"] * n_fft * math.log2(n_fft)) / (P * M * w * w))
    tile = 16
    t = best(lambda: subimage_nufft(d, freq, a, r0, grid, tile=tile, eps=1e-3)) * thr
    n_tiles = (N // tile) ** 2
    c["subimage_point"] = t / (n_tiles * P * M * _nufft_width(1e-3) ** 2)
    c.update(_command_costs(repeat))
    from .planner import recommend
    from ..core.acquisition import Acquisition
    from ..core.types import PhaseHistory

    ph = PhaseHistory(d, Acquisition(freq, az, np.full(P, np.radians(30)), grid, antenna_position_m=a,
                                     range_to_center_m=r0, model="spherical"))
    c["planning"] = _best(lambda: recommend(ph, grid, 1e-3, costs=dict(DEFAULT_COSTS, **c)), repeat)
    path = Path(path) if path is not None else user_cost_model_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(json.dumps({"note": "seconds per operation x threads, measured by "
                                       "sarcli.formers.calibration.calibrate on this machine",
                               "machine": machine(), "measured": time.strftime("%Y-%m-%d"),
                               "seconds_per_op": c}, indent=1) + "\n")
    tmp.replace(path)
    return c
