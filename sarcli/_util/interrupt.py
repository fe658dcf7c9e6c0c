"""SIGINT / SIGTERM for the command line: end within a second, remove temporary files, one line.

:func:`install` (called by the ``sar`` entry point, never by the library) makes the C-level signal
handler write the signal number to a pipe (:func:`signal.set_wakeup_fd`); a watchdog thread
blocked on that pipe removes every temporary output file (:mod:`sarcli._util.atomic`), stops
child processes (a local dask cluster), prints ``interrupted`` and leaves with ``128 + signal``
(130 for SIGINT, 143 for SIGTERM). The watchdog runs as soon as the main thread lets go of the
GIL, so native code that releases it (sarcli's C++ kernels, FFTs, FINUFFT, file I/O, sleeps) is
interrupted at once.
The rename that commits an output is taken under :data:`sarcli._util.atomic.LOCK`: an
interruption lands either before it (previous output untouched) or after it (new output complete).
"""

from __future__ import annotations

import os
import signal
import sys
import threading

__all__ = ["install", "installed", "descendants", "EXIT_CODES"]

#: signal -> exit status
EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}
_state = {"installed": False}


def descendants(pid: int) -> list[int]:
    """Every process below ``pid``, parents before their children (Linux: ``/proc/PID/task/TID/children``;
    elsewhere none)."""
    found, todo = [], [pid]
    while todo:
        p = todo.pop(0)
        try:
            tasks = os.listdir(f"/proc/{p}/task")
        except OSError:
            continue
        for t in tasks:
            try:
                with open(f"/proc/{p}/task/{t}/children") as fh:
                    kids = [int(k) for k in fh.read().split()]
            except (OSError, ValueError):
                continue
            found += kids
            todo += kids
    return found


def _stop_children(timeout=0.3):
    # the grandchildren first (a dask nanny's worker, perhaps still starting): were its parent gone
    # first, a starting worker would read end-of-file from it and print a traceback on our stderr
    # after "interrupted"; SIGTERM ends it where it stands, silently
    try:
        below = descendants(os.getpid())
    except Exception:  # noqa: BLE001 - best effort while exiting
        below = []
    for pid in reversed(below):
        try:
            os.kill(pid, signal.SIGTERM)
        except OSError:
            pass
    try:
        import multiprocessing

        children = multiprocessing.active_children()
    except Exception:  # noqa: BLE001 - best effort while exiting
        return
    for ch in children:
        try:
            ch.terminate()
        except Exception:  # noqa: BLE001
            pass
    for ch in children:
        try:
            ch.join(timeout / max(1, len(children)))
        except Exception:  # noqa: BLE001
            pass


def _terminate(signum: int) -> None:
    from . import atomic

    with atomic.LOCK:
        atomic.release_all()
        _stop_children()
        atomic.release_all()
        prefix = b"\r\x1b[K" if sys.stderr is not None and sys.stderr.isatty() else b""
        try:
            os.write(2, prefix + b"interrupted\n")
        finally:
            os._exit(EXIT_CODES.get(signum, 128 + signum))


def _watch(fd: int) -> None:
    while True:
        try:
            data = os.read(fd, 1)
        except InterruptedError:
            continue
        if data and data[0] in EXIT_CODES:
            _terminate(data[0])


def _ignore(signum, frame):  # the watchdog acts; the main thread keeps going until it is stopped
    pass


def installed() -> bool:
    """True in a process whose handlers :func:`install` set (the ``sar`` command line)."""
    return _state["installed"]


def install() -> bool:
    """Install the handlers (main thread only; idempotent). Returns True when installed."""
    if _state["installed"] or threading.current_thread() is not threading.main_thread():
        return _state["installed"]
    r, w = os.pipe()
    os.set_blocking(w, False)
    signal.set_wakeup_fd(w, warn_on_full_buffer=False)
    for sig in EXIT_CODES:
        signal.signal(sig, _ignore)
    threading.Thread(target=_watch, args=(r,), name="sarcli-interrupt", daemon=True).start()
    _state["installed"] = True
    return True
