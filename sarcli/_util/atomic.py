"""Atomic file output: write to a temporary name in the same folder, rename at the end.

The temporary name of ``path`` is ``.<name>.tmp-<pid>`` beside it, and it exists only while the
output is being written (:func:`atomic_path`). A command may *reserve* its outputs before
computing (:func:`reserve`): the folder is probed (a file created and removed at once), so a
folder that cannot be written is found before any work, yet nothing is left on disk during the
computation. Every temporary file this process holds is listed in a registry, so an interruption
(:mod:`sarcli._util.interrupt`) or a failed command (:func:`release_all`) removes them all; the
rename onto the final name is the one commit point, taken under a lock. A process killed while
writing (SIGKILL, a crash) cannot clean up: the next :func:`reserve` or :func:`atomic_path` of the
same output removes the temporaries whose process no longer exists (:func:`remove_stale`).
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from pathlib import Path

from ..errors import SarcliInputError

__all__ = ["atomic_path", "reserve", "release_all", "temp_path", "open_held", "remove_stale", "LOCK",
           "WriteError"]

#: held while a temporary file is renamed onto its final name or removed by a clean-up
LOCK = threading.RLock()
_TEMPS: dict[Path, Path] = {}  # temporary path -> final path


class WriteError(SarcliInputError):
    """Writing an output failed (full disk, quota, permission): the previous file is untouched."""


def _quiet_unraisable(previous):
    """An unraisable-exception hook that drops h5py's complaints about a file whose write failed
    (its objects fail again when they are freed); anything else goes to ``previous``."""
    def hook(unraisable):
        exc = unraisable.exc_value
        if isinstance(exc, (OSError, RuntimeError)) and "errno" in str(exc):
            return
        previous(unraisable)
    hook.sarcli_quiet = True
    return hook


def temp_path(path) -> Path:
    """The temporary name used for ``path`` by this process."""
    final = Path(path)
    return final.with_name(f".{final.name}.tmp-{os.getpid()}")


def _process_exists(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists but belongs to another user (EPERM)
        return True
    return True


def remove_stale(path) -> list[Path]:
    """Remove the temporary files of ``path`` left by processes that no longer exist.

    A temporary ``.<name>.tmp-<pid>`` is stale when no process ``pid`` runs on this machine (a run
    killed while writing); one whose process still runs is left alone (it may be writing now).
    Process ids are those of this machine: in a folder that several machines write at once, a
    temporary of another machine's running process would be taken for stale.
    Returns the paths removed.
    """
    final = Path(path)
    prefix = f".{final.name}.tmp-"
    removed = []
    try:
        candidates = [p for p in final.parent.iterdir() if p.name.startswith(prefix)]
    except OSError:
        return removed
    for tmp in candidates:
        pid = tmp.name[len(prefix):]
        if not pid.isdigit() or int(pid) == os.getpid() or _process_exists(int(pid)):
            continue
        with contextlib.suppress(OSError):
            tmp.unlink()
            removed.append(tmp)
    return removed


def _first_line(exc: BaseException, limit: int = 200) -> str:
    code = getattr(exc, "errno", None)
    if isinstance(code, int) and code > 0:
        return os.strerror(code)  # "No space left on device", "Permission denied", ...
    text = (getattr(exc, "strerror", None) or str(exc) or type(exc).__name__).splitlines()[0]
    return text if len(text) <= limit else text[:limit] + "..."


def _os_error(exc: BaseException | None, depth: int = 4):
    """The operating-system error behind ``exc``: itself, or one it was raised while handling
    (h5py raises a RuntimeError on closing a file whose write failed with ENOSPC)."""
    while exc is not None and depth > 0:
        if isinstance(exc, OSError):
            return exc
        if not isinstance(exc, (RuntimeError, ValueError)) or isinstance(exc, SarcliInputError):
            return None
        exc, depth = exc.__context__, depth - 1
    return None


def _make_parent(final: Path) -> None:
    """Refuse an output whose folder does not exist: a typo in a folder name is one line, not a
    new folder created silently (create the folder first)."""
    parent = final.parent
    if parent and not parent.is_dir():
        if parent.exists():
            raise SarcliInputError(f"{final}: {parent} is not a folder")
        raise SarcliInputError(f"{final}: the output folder {parent} does not exist (create it first)")


def reserve(path) -> Path:
    """Check now, before any work, that ``path`` can be written (fail before computing).

    The temporary file of ``path`` is created and removed at once (nothing stays on disk while the
    command computes; :func:`atomic_path` creates it again when it writes) and is listed in the
    registry, so :func:`release_all` reports it. Temporaries of ``path`` left by killed processes
    are removed (:func:`remove_stale`).

    Returns
    -------
    Path
        The temporary name :func:`atomic_path` will write.

    Raises
    ------
    SarcliInputError
        The folder does not exist or cannot be written, or ``path`` is a folder.
    """
    final = Path(path)
    if final.is_dir():
        raise SarcliInputError(f"{final}: is a folder, expected a file name to write")
    _make_parent(final)
    remove_stale(final)
    tmp = temp_path(final)
    with LOCK:
        try:
            fd = os.open(tmp, os.O_CREAT | os.O_WRONLY | os.O_EXCL, 0o644)
        except FileExistsError:  # this process is writing it already
            pass
        except OSError as exc:
            raise SarcliInputError(f"{final}: cannot write in {final.parent or '.'} ({_first_line(exc)})") from None
        else:
            os.close(fd)
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        _TEMPS[tmp] = final
    return tmp


def _discard(tmp: Path) -> None:
    with LOCK:
        _TEMPS.pop(tmp, None)
        with contextlib.suppress(OSError):
            tmp.unlink()


def open_held(tmp, mode: str = "wb", opener=open):
    """Open the temporary file ``tmp`` of an :func:`atomic_path` for writing, only while it is still
    held: an interruption that already removed it must not see it created again behind its back.
    The open itself is taken under the lock; the writing that follows is not (a clean-up that
    removes the file meanwhile leaves the writes on an unlinked inode: nothing stays on disk).
    ``opener(tmp, mode)`` opens it (default :func:`open`; e.g. ``h5py.File``)."""
    with LOCK:
        if Path(tmp) not in _TEMPS:
            raise KeyboardInterrupt
        return opener(tmp, mode)


def release_all() -> list[Path]:
    """Remove every temporary file this process still holds (a failed or interrupted command)."""
    with LOCK:
        held = list(_TEMPS)
        for tmp in held:
            _discard(tmp)
    return held


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path next to ``path``; rename it onto ``path`` only on success.

    On any exception the temporary file is removed and ``path`` is left untouched, so a failing
    command never leaves a partial output file. An operating-system error while writing (a full
    disk, a permission or quota error) becomes one :class:`~sarcli.errors.SarcliInputError`.
    """
    final = Path(path)
    _make_parent(final)
    remove_stale(final)
    tmp = temp_path(final)
    with LOCK:
        _TEMPS[tmp] = final
    if not getattr(sys.unraisablehook, "sarcli_quiet", False):
        sys.unraisablehook = _quiet_unraisable(sys.unraisablehook)
    try:
        yield tmp
        with LOCK:
            if tmp not in _TEMPS:  # removed by an interruption in the meantime
                raise KeyboardInterrupt
            os.replace(tmp, final)
            _TEMPS.pop(tmp, None)
    except BaseException as exc:
        _discard(tmp)
        cause = _os_error(exc)
        if cause is None:
            raise
        raise WriteError(f"{final}: could not be written ({_first_line(cause)}); "
                         "any previous file is untouched") from None
