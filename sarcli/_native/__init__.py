"""sarcli's compiled kernels: C++17, built by CMake when the package is installed.

One extension module per kernel family, each from its source in ``src/native/`` of the
repository (``src/native/NAME.cpp`` is ``sarcli._native._NAME``), bound with nanobind in
``src/native/bindings/NAME.cpp``; :mod:`sarcli._native.layout` names the rows of the tables the
kernels read. The kernels hold only loops: planning, geometry, error models and I/O stay in
Python, in the module that wraps each family. They release the interpreter lock while they run (so dask threads and the
Ctrl-C watchdog run beside them), thread with OpenMP (static schedules, one parallel region per
call) and pick their SIMD width when loaded (AVX-512, AVX2 + FMA or baseline x86-64).

:func:`threads` sets the OpenMP thread count that kernels started from the calling thread use.
"""

from __future__ import annotations

import os

__all__ = ["load", "threads", "using_threads", "simd_level", "build_id"]

# Threads waiting at a barrier sleep rather than spin: on a machine shared with other work a
# spinning thread burns the time slice its sibling needs to reach the barrier. Read by OpenMP
# when the first kernel module loads; a user's own setting wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def load(family: str):
    """The compiled module of ``family`` (``"simulate"`` -> ``sarcli._native._simulate``).

    Raises an ImportError that says how to build it when the package was not installed with its
    kernels (a source checkout on ``sys.path`` without ``pip install``).
    """
    import importlib

    try:
        return importlib.import_module(f"._{family}", __name__)
    except ImportError as exc:
        raise ImportError(
            f"sarcli's compiled kernel module '_{family}' is missing: install the package "
            "(`pip install .`, or `make setup` in a checkout), which compiles src/native/ with a "
            f"C++17 compiler ({exc})") from exc


def threads(n: int | None = None) -> int:
    """Set (``n``) and return the thread count of kernels started from the calling thread.

    OpenMP keeps it per calling thread, so batch jobs running in threads of their own can each
    set theirs; ``OMP_NUM_THREADS`` sets the default.
    """
    rt = load("runtime")
    if n is not None:
        rt.set_num_threads(int(n))
    return rt.get_max_threads()


class using_threads:
    """``with using_threads(n) as used:`` the kernels' thread count set to ``n`` for the block (from
    the calling thread) and restored after it; ``None`` leaves it. ``used``: the count in force."""

    def __init__(self, n: int | None):
        self.n = None if n is None else max(1, int(n))

    def __enter__(self) -> int:
        self.old = threads()
        return threads(self.n)

    def __exit__(self, *exc):
        threads(self.old)


def simd_level() -> str:
    """The instruction set the kernels' SIMD clones run on here: avx512, avx2 or baseline."""
    return load("runtime").simd_level()


def build_id() -> str:
    """A fingerprint of the compiled kernel modules installed (names, sizes, modification times):
    it changes when they are rebuilt, so what was measured of the old kernels is not reused."""
    import hashlib
    from pathlib import Path

    h = hashlib.blake2b(digest_size=6)
    # beside the runtime module (in an editable install not beside this file)
    for f in sorted(Path(load("runtime").__file__).parent.glob("_*.*")):
        if f.suffix in (".so", ".pyd", ".dylib"):
            st = f.stat()
            h.update(f"{f.name}:{st.st_size}:{st.st_mtime_ns};".encode())
    return h.hexdigest()
