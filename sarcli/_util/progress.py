"""Progress bars: tqdm on a terminal, silent with ``--quiet`` or when stderr is not a tty.

tqdm is imported on the first bar (start-up of commands that draw none stays cheap), and
:func:`message` prints a line to stderr above any live bar instead of through it, so a warning
never ends up on the same line as a bar.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager

__all__ = ["progress", "set_quiet", "is_quiet", "message", "no_bars"]

_QUIET = False


def set_quiet(quiet: bool) -> None:
    """Silence (or re-enable) every progress bar of this process (the CLI's ``-q``)."""
    global _QUIET
    _QUIET = bool(quiet)


def is_quiet() -> bool:
    return _QUIET


@contextmanager
def no_bars():
    """No bars inside: for a step (an operator application) of an iteration that draws its own."""
    global _QUIET
    before = _QUIET
    _QUIET = True
    try:
        yield
    finally:
        _QUIET = before


def progress(iterable=None, *, total=None, desc=None, unit="it", disable=None, **kwargs):
    """A tqdm bar that shows only on an interactive terminal and never under ``--quiet``.

    Parameters
    ----------
    iterable : iterable, optional
        Wrapped as by ``tqdm(iterable)``; omit it and call ``update`` by hand.
    disable : bool, optional
        Force the bar off (True) or follow the defaults (None).
    """
    from tqdm import tqdm

    if disable is None:
        disable = _QUIET or not sys.stderr.isatty()
    return tqdm(iterable, total=total, desc=desc, unit=unit, disable=disable, leave=False,
                dynamic_ncols=True, **kwargs)


def message(text: str) -> None:
    """Print ``text`` as one line on stderr, above any progress bar that is being drawn."""
    tqdm_module = sys.modules.get("tqdm")
    if tqdm_module is not None and getattr(tqdm_module.tqdm, "_instances", None):
        tqdm_module.tqdm.write(text, file=sys.stderr)
    else:
        print(text, file=sys.stderr, flush=True)
