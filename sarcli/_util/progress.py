"""Progress bars: tqdm on a terminal, silent with ``--quiet`` or when stderr is not a tty."""

from __future__ import annotations

import sys

from tqdm.auto import tqdm

__all__ = ["progress", "set_quiet", "is_quiet"]

_QUIET = False


def set_quiet(quiet: bool) -> None:
    """Silence (or re-enable) every progress bar of this process (the CLI's ``-q``)."""
    global _QUIET
    _QUIET = bool(quiet)


def is_quiet() -> bool:
    return _QUIET


def progress(iterable=None, *, total=None, desc=None, unit="it", disable=None, **kwargs):
    """A tqdm bar that shows only on an interactive terminal and never under ``--quiet``.

    Parameters
    ----------
    iterable : iterable, optional
        Wrapped as by ``tqdm(iterable)``; omit it and call ``update`` by hand.
    disable : bool, optional
        Force the bar off (True) or follow the defaults (None).
    """
    if disable is None:
        disable = _QUIET or not sys.stderr.isatty()
    return tqdm(iterable, total=total, desc=desc, unit=unit, disable=disable, leave=False,
                dynamic_ncols=True, **kwargs)
