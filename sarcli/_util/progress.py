"""Progress bars: tqdm on a terminal, silent with ``--quiet`` or when stderr is not a tty.

tqdm is imported on the first bar drawn (a command that draws none never imports it), and
:func:`message` prints a line to stderr above any live bar instead of through it, so a warning
never ends up on the same line as a bar.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager

__all__ = ["progress", "SilentBar", "set_quiet", "is_quiet", "message", "no_bars"]

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


class SilentBar:
    """What :func:`progress` hands back where no bar is drawn: the parts of tqdm's interface the
    package uses (iteration, ``update``, ``reset``, ``set_postfix``, ``set_description``, ``refresh``, ``close``,
    a context manager, ``n`` and ``total``), doing nothing, so that a command that draws no bar
    does not import tqdm (18 ms: its version lookup imports importlib.metadata)."""

    disable = True

    def __init__(self, iterable=None, total=None):
        self.iterable, self.n = iterable, 0
        self.total = total if total is not None or iterable is None else getattr(iterable, "__len__", lambda: None)()

    def __iter__(self):
        for item in self.iterable:
            yield item
            self.n += 1

    def __len__(self):
        return len(self.iterable) if self.iterable is not None else int(self.total or 0)

    def update(self, n=1):
        self.n += n

    def reset(self, total=None):
        self.n, self.total = 0, total

    def set_postfix(self, *args, **kwargs):
        pass

    def set_description(self, *args, **kwargs):
        pass

    def refresh(self, *args, **kwargs):
        pass

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def progress(iterable=None, *, total=None, desc=None, unit="it", disable=None, **kwargs):
    """A tqdm bar that shows only on an interactive terminal and never under ``--quiet``.

    Parameters
    ----------
    iterable : iterable, optional
        Wrapped as by ``tqdm(iterable)``; omit it and call ``update`` by hand.
    disable : bool, optional
        Force the bar off (True) or follow the defaults (None).

    Returns
    -------
    tqdm or SilentBar
        The bar; where none is drawn, a :class:`SilentBar` (tqdm is not imported).
    """
    if disable is None:
        disable = _QUIET or not sys.stderr.isatty()
    if disable:
        return SilentBar(iterable, total)
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, unit=unit, disable=disable, leave=False,
                dynamic_ncols=True, **kwargs)


def message(text: str) -> None:
    """Print ``text`` as one line on stderr, above any progress bar that is being drawn."""
    tqdm_module = sys.modules.get("tqdm")
    if tqdm_module is not None and getattr(tqdm_module.tqdm, "_instances", None):
        tqdm_module.tqdm.write(text, file=sys.stderr)
    else:
        print(text, file=sys.stderr, flush=True)
