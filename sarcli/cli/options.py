"""Shared machinery of the commands: error mapping, warnings as one line, and the options several
commands share, built from the library's own constants (window kinds, Taylor ranges, methods) so
that a choice or a range is written once, where the library defines it."""

from __future__ import annotations

import functools
import sys
import warnings

import click

from ..core import windows as _windows
from ..errors import NumericalError, SarcliInputError, SarcliWarning

__all__ = ["handle_errors", "grid_options", "export_options", "write_side_outputs", "parse_pair", "echo_info",
           "window_options", "window_choice"]


def window_choice(default="none", help="Window in range and cross-range (peak of a unit point stays 1)."):
    """``--window`` with the kinds of :data:`sarcli.core.windows.WINDOW_KINDS`."""
    return click.option("--window", type=click.Choice(_windows.WINDOW_KINDS), default=default,
                        show_default=default is not None, help=help)


def window_options(func=None, *, nbar_dest="taylor_nbar", sll_dest="taylor_sll_db"):
    """``--window``, ``--taylor-nbar`` and ``--taylor-sll-db``, with the ranges the window module
    accepts (:func:`sarcli.core.windows.check_taylor`)."""
    def decorate(f):
        lo, hi = _windows.TAYLOR_SLL_DB_RANGE
        f = click.option("--taylor-sll-db", sll_dest, type=click.FloatRange(lo, hi), default=_windows.TAYLOR_SLL_DB,
                         show_default=True, help="Taylor window peak sidelobe level (dB, negative).")(f)
        lo, hi = _windows.TAYLOR_NBAR_RANGE
        f = click.option("--taylor-nbar", nbar_dest, type=click.IntRange(lo, hi), default=_windows.TAYLOR_NBAR,
                         show_default=True, help="Taylor window number of nearly constant sidelobes.")(f)
        return window_choice()(f)

    return decorate if func is None else decorate(func)


def _show_warning(message, category, filename, lineno, file=None, line=None):
    name = "warning" if not issubclass(category, SarcliWarning) else f"warning ({category.__name__})"
    click.echo(f"{name}: {message}", err=True)


def handle_errors(func):
    """Decorate a command: user mistakes -> one line + exit 2; numerical failure -> exit 1.

    Library warnings are printed as a single ``warning: ...`` line each (no source lines).
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        old = warnings.showwarning
        warnings.showwarning = _show_warning
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("default", SarcliWarning)
                warnings.showwarning = _show_warning
                return func(*args, **kwargs)
        except SarcliInputError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)
        except NumericalError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(1)
        finally:
            warnings.showwarning = old

    return wrapper


def parse_pair(text, name):
    """Parse ``"a"`` or ``"a,b"`` into a float pair (``(a, a)`` for one number)."""
    if text is None:
        return None
    try:
        parts = [float(p) for p in str(text).split(",")]
    except ValueError:
        raise click.BadParameter(f"expected a number or two numbers 'A,B', got {text!r}",
                                 param_hint=name) from None
    if len(parts) == 1:
        parts = parts * 2
    if len(parts) != 2:
        raise click.BadParameter(f"expected one or two comma-separated numbers, got {text!r}",
                                 param_hint=name)
    return tuple(parts)


def grid_options(func):
    """The grid overrides shared by ``form-image``, ``regularize`` and friends.

    Adds ``--center X,Y``, ``--extent W[,H]`` and ``--pixel-size H``; the command receives
    ``center``, ``extent`` and ``pixel_size`` (None when not given) and passes them to
    :func:`sarcli.grid_for`.
    """
    func = click.option("--pixel-size", "pixel_size", type=float, default=None,
                        help="Pixel size in metres (default: from the acquisition).")(func)
    func = click.option("--extent", "extent", default=None,
                        help="Full side lengths W or W,H in metres (default: the acquisition's scene).")(func)
    func = click.option("--center", "center", default=None,
                        help="Grid centre X,Y in metres (default 0,0).")(func)
    return func


def echo_info(ctx, text):
    """Print informational output unless ``--quiet``."""
    if not (ctx.obj or {}).get("quiet"):
        click.echo(text)


def export_options(func):
    """``--png F`` and ``--geotiff F``: also export the image written by the command."""
    func = click.option("--geotiff", "tif_path", type=click.Path(dir_okay=False), default=None,
                        help="Also write a GeoTIFF of the magnitude.")(func)
    func = click.option("--png", "png_path", type=click.Path(dir_okay=False), default=None,
                        help="Also write a dB PNG (50 dB, north up).")(func)
    return func


def write_side_outputs(img, png_path=None, tif_path=None):
    """Write the ``--png`` / ``--geotiff`` shortcuts of a command (atomic, like every output)."""
    if png_path or tif_path:
        from ..io.export import export_image

        if png_path:
            export_image(img, png_path, kind="db")
        if tif_path:
            export_image(img, tif_path, kind="magnitude")
