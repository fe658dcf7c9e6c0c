"""Never overwrite an input: compare every output of a command with every input it reads.

Two paths name the same file when they resolve to the same path (symbolic links, ``..``) or,
for files that exist, when they share ``(st_dev, st_ino)`` (hard links, bind mounts).
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import SarcliInputError

__all__ = ["same_file", "refuse_overwrite"]


def _key(path):
    p = Path(os.path.expanduser(str(path)))
    try:
        resolved = p.resolve()
    except (OSError, RuntimeError):  # a symlink loop: compare the name as given
        resolved = p.absolute()
    try:
        st = os.stat(p)
        ino = (st.st_dev, st.st_ino)
    except OSError:
        ino = None
    return resolved, ino


def same_file(a, b) -> bool:
    """True when ``a`` and ``b`` name the same file (same resolved path or same inode)."""
    (ra, ia), (rb, ib) = _key(a), _key(b)
    return ra == rb or (ia is not None and ia == ib)


def refuse_overwrite(inputs, outputs) -> None:
    """Refuse a command whose output is one of its inputs, or whose outputs coincide.

    Parameters
    ----------
    inputs : iterable of (label, path) or path
        Files the command reads (data file, config, init image, plan and its inputs).
    outputs : iterable of (label, path) or path
        Files the command writes; ``None`` entries are skipped.

    Raises
    ------
    SarcliInputError
        One line naming both paths, before any work is done.
    """
    def norm(items, default):
        out = []
        for it in items:
            label, path = it if isinstance(it, tuple) else (default, it)
            if path is not None:
                out.append((label, str(path), _key(path)))
        return out

    ins, outs = norm(inputs, "input"), norm(outputs, "output")

    def clash(a, b):
        return a[0] == b[0] or (a[1] is not None and a[1] == b[1])

    for olabel, opath, okey in outs:
        for ilabel, ipath, ikey in ins:
            if clash(okey, ikey):
                raise SarcliInputError(f"{olabel} {opath!r} is the {ilabel} {ipath!r} (the same file): "
                                       "refusing to overwrite an input; choose another output name")
    for i, (la, pa, ka) in enumerate(outs):
        for lb, pb, kb in outs[i + 1:]:
            if clash(ka, kb):
                raise SarcliInputError(f"{la} {pa!r} and {lb} {pb!r} are the same file; give distinct names")
