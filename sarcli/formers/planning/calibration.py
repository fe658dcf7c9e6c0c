"""The planner's cost model: seconds per operation of every former, measured on this machine.

:mod:`sarcli.formers.planning.planner` predicts a former's time as its operation counts times these
constants; its ``calibrate`` measures them with small instances of every former (a few seconds)
and, for the whole command, the start-up (a fresh interpreter importing what ``sar form-image``
imports), reading and writing (images written to new files, :func:`write_costs`). Its result is
kept per machine in the user's cache folder (``$SARCLI_CACHE_DIR``, else ``$XDG_CACHE_HOME/sarcli``,
else ``~/.cache/sarcli``), named by a fingerprint of the CPU model, the processors this process may use, the kernels' SIMD level,
sarcli's version and the compiled kernels' build (:func:`sarcli._native.build_id`), so a
calibration never serves another machine, nor kernels rebuilt since. Until a machine is calibrated
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

__all__ = ["DEFAULT_COSTS", "COST_MODEL_PATH", "STARTUP_IMPORTS", "TOUCH_BYTES", "load_cost_model", "save_cost_model",
           "is_calibrated", "machine", "user_cost_model_path", "best_of", "touch_cost", "fft_cost", "WRITE_BYTES",
           "WRITE_FILES", "write_costs", "READ_ROWS", "command_costs"]

#: The reference machine's constants, shipped with the package.
COST_MODEL_PATH = Path(__file__).with_name("cost_model.json")
#: Per-operation seconds (one core) where neither a calibration nor the shipped file has one;
#: ``startup``, ``planning``: seconds; ``read_per_byte``, ``write_per_byte`` (a file's first
#: :data:`WRITE_BYTES`), ``write_per_byte_large`` (its bytes beyond): seconds per byte.
DEFAULT_COSTS = {"direct": 6e-9, "bp": 3e-9, "bp_fft": 4e-9, "ffbp_stage0": 4e-9, "ffbp_mac": 1.5e-9,
                 "ffbp_node0": 5e-9, "ffbp_pair": 5e-9, "ffbp_final": 1.5e-8, "ffbp_tone": 3e-9,
                 "ffbp_touch": 5e-10, "nufft_spread": 3e-9, "nufft_fft": 3e-9,
                 "subimage_point": 2e-9, "threads": 2, "startup": 0.5, "planning": 0.02,
                 "read_per_byte": 1e-9, "write_per_byte": 2e-9, "write_per_byte_large": 2e-9}
#: What a fresh ``sar form-image`` imports before it forms an image (the start-up it pays).
STARTUP_IMPORTS = ("import sarcli.cli.main, sarcli.cli.form_image, sarcli.formers.formation, "
                    "sarcli.formers.planning.planner, sarcli.io.hdf5, sarcli._native; sarcli._native.threads()")


@functools.lru_cache(maxsize=1)
def machine() -> dict:
    """What a calibration is valid for: CPU model, usable processors, SIMD level, sarcli version,
    kernel build."""
    from ... import __version__
    from ..._native import build_id, simd_level
    from ..._util.load import usable_cpus

    model = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            model = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), model)
    except OSError:
        pass
    return {"cpu": model, "cpus": usable_cpus(), "simd": simd_level(), "sarcli": __version__, "kernels": build_id()}


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


def save_cost_model(costs: dict, path=None) -> Path:
    """Write ``costs`` as this machine's calibration (default :func:`user_cost_model_path`), atomically."""
    path = Path(path) if path is not None else user_cost_model_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(json.dumps({"note": "seconds per operation x threads, measured by "
                                       "sarcli.formers.planning.planner.calibrate on this machine",
                               "machine": machine(), "measured": time.strftime("%Y-%m-%d"),
                               "seconds_per_op": costs}, indent=1) + "\n")
    tmp.replace(path)
    return path


def best_of(fn, repeat):
    """The least wall seconds of ``repeat`` calls of ``fn`` after one call to warm up."""
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return min(ts)


#: Bytes of each fresh array :func:`touch_cost` touches: above the largest block the C library
#: keeps for reuse, so every one is new memory.
TOUCH_BYTES = 64 * 2 ** 20


def touch_cost(repeat) -> float:
    """Processor seconds per byte of writing memory first touched (page faults and the writes),
    best of ``repeat`` fresh arrays of :data:`TOUCH_BYTES`."""
    best = math.inf
    for _ in range(max(1, repeat)):
        t = time.process_time()
        a = np.empty(TOUCH_BYTES // 8)
        a.fill(1.0)
        best = min(best, time.process_time() - t)
        del a
    return best / TOUCH_BYTES


def fft_cost(repeat, thr) -> float:
    """``c["bp_fft"]``: processor seconds x ``thr`` of the range profiles (their FFTs split over the
    kernel threads, so processor seconds are the work) per pulse and ``L log2 L``, on long pulses (32 x 4096 samples, profiles of 2x), where the
    transforms of large collections spend their time; best of ``repeat``."""
    from ..backprojection import profile_length, profiles

    rng = np.random.default_rng(1)
    d = (rng.normal(size=(32, 4096)) + 1j * rng.normal(size=(32, 4096))).astype(np.complex64)
    L = profile_length(d.shape[1], 2.0)
    best = math.inf
    for _ in range(max(1, repeat) + 1):
        t = time.process_time()
        profiles(d, None, float(d.size), L, np.complex64)
        best = min(best, time.process_time() - t)
    return best * thr / (d.shape[0] * L * math.log2(L))


#: Bytes of each image :func:`write_costs` writes: above :data:`sarcli.io.h5output.IN_MEMORY_MAX_BYTES`,
#: so that it is written in place, as the images of large collections are.
WRITE_BYTES = 32 * 2 ** 20
#: Images :func:`write_costs` writes one after the other, each to a new file (160 MiB in all).
WRITE_FILES = 5


def write_costs(folder) -> tuple:
    """``(c["write_per_byte"], c["write_per_byte_large"])``: wall seconds per stored byte of writing
    an image file the way ``sar form-image`` does (:func:`sarcli.io.hdf5.write_image`: a complex128
    image stored complex64, cast by blocks of rows), for the first :data:`WRITE_BYTES` of a file and
    for those beyond (:func:`sarcli.formers.planning.cost.write_seconds`).

    :data:`WRITE_FILES` images of :data:`WRITE_BYTES` go to new files in ``folder``, the earlier
    ones kept, so their bytes take pages the kernel's file cache has not had, as an image written
    under a new name does: the first file's cost is the first constant, the others' the second. A
    file's first bytes may find memory freed a moment before, the rest not; where that costs more
    (on a virtual machine whose host backs memory on first use), the second constant carries it
    (docs/performance.md, "Writing an image"). Rewriting one cached file would measure neither."""
    from ...core.types import Image
    from ...io.hdf5 import write_image

    ny, nx = 4096, WRITE_BYTES // (4096 * 8)
    img = Image(image=np.zeros((ny, nx), np.complex128), x_m=np.arange(nx, dtype=float),
                y_m=np.arange(ny, dtype=float), method="calibration", parameters={}, runtime_s=0.0)
    ts = []
    for i in range(WRITE_FILES):
        t0 = time.perf_counter()
        write_image(Path(folder) / f"write-{i}.h5", img, np.complex64)
        ts.append(time.perf_counter() - t0)
    stored = ny * nx * 8
    return ts[0] / stored, float(np.mean(ts[1:])) / stored


#: Rows of each block :func:`command_costs` reads, as the formers read a phase history's pulses.
READ_ROWS = 128


def command_costs(repeat) -> dict:
    """Start-up of a fresh interpreter importing what ``sar form-image`` does, HDF5 read seconds per
    byte (a 32 MiB complex64 dataset of 512 x 8,192 read by blocks of :data:`READ_ROWS` rows into
    one buffer, as the formers read the pulses of a phase history left on disk,
    :class:`sarcli.io.pulses.PulseArray`; best of ``repeat``) and write seconds per byte
    (:func:`write_costs`)."""
    import tempfile

    import h5py

    from ...io.pulses import PulseArray

    startup = best_of(lambda: subprocess.run([sys.executable, "-c", STARTUP_IMPORTS], check=True,
                                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL), repeat)
    shape = (512, 8192)   # blocks of 8 MiB, as a long collection's (128 pulses of 8,192 samples)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "io.h5"
        with h5py.File(path, "w") as f:
            f["a"] = np.zeros(shape, np.complex64)
        src = PulseArray(path, "a", shape, np.complex64)
        buf = np.empty((READ_ROWS, shape[1]), np.complex64)

        def read():
            for r in range(0, shape[0], READ_ROWS):
                src.read_into(slice(r, r + READ_ROWS), buf)

        r = best_of(read, repeat)
        w, w_large = write_costs(tmp)
    return {"startup": startup, "read_per_byte": r / (shape[0] * shape[1] * 8), "write_per_byte": w,
            "write_per_byte_large": w_large}
