"""Shared machinery of the commands: error mapping, warnings as one line, and the options several
commands share, built from the library's own constants (window kinds, Taylor ranges, methods) so
that a choice or a range is written once, where the library defines it."""

from __future__ import annotations

import errno
import functools
import math
import os
import sys
import warnings

import click

from ..core import windows
from ..errors import NumericalError, SarcliInputError, SarcliWarning

__all__ = ["handle_errors", "grid_options", "export_options", "write_side_outputs", "parse_pair", "echo_info",
           "window_options", "window_choice", "wrote", "prepare_outputs", "threads_option", "knob_options",
           "method_options", "MAX_MESSAGE"]

#: longest error line printed (a value quoted in a message is cut well before this)
MAX_MESSAGE = 400


def window_choice(default="none", help="Window in range and cross-range (peak of a unit point stays 1)."):
    """``--window`` with the kinds of :data:`sarcli.core.windows.WINDOW_KINDS`."""
    return click.option("--window", type=click.Choice(windows.WINDOW_KINDS), default=default,
                        show_default=default is not None, help=help)


def window_options(func=None, *, nbar_dest="taylor_nbar", sll_dest="taylor_sll_db"):
    """``--window``, ``--taylor-nbar`` and ``--taylor-sll-db``, with the ranges the window module
    accepts (:func:`sarcli.core.windows.check_taylor`)."""
    def decorate(f):
        lo, hi = windows.TAYLOR_SLL_DB_RANGE
        f = click.option("--taylor-sll-db", sll_dest, type=click.FloatRange(lo, hi), default=windows.TAYLOR_SLL_DB,
                         show_default=True, help="Taylor window peak sidelobe level (dB, negative).")(f)
        lo, hi = windows.TAYLOR_NBAR_RANGE
        f = click.option("--taylor-nbar", nbar_dest, type=click.IntRange(lo, hi), default=windows.TAYLOR_NBAR,
                         show_default=True, help="Taylor window number of nearly constant sidelobes.")(f)
        return window_choice()(f)

    return decorate if func is None else decorate(func)


def _knob_type(specs):
    """The click type of a knob name several formers may share (:func:`sarcli.formers.former.knob`):
    every former's choices, or the range that holds each former's (each former checks its own)."""
    meta = specs[0].metadata
    choices = list(dict.fromkeys(c for f in specs for c in (f.metadata["choices"] or ())))
    if choices:
        return click.Choice(choices)
    if meta["kind"] is str:
        return click.STRING
    ranges = [f.metadata["range"] or (None, None) for f in specs]
    lo = None if any(r[0] is None for r in ranges) else min(r[0] for r in ranges)
    hi = None if any(r[1] is None for r in ranges) else max(r[1] for r in ranges)
    if meta["kind"] is int:
        return click.IntRange(lo, hi)
    return click.FloatRange(lo, hi)


def _knob_default(f) -> str:
    text = f.metadata["default_text"]
    if text is None:
        from ..formers.former import flag_text

        text = flag_text(f.default)
    return text


def knob_options(func):
    """One option per knob name of every former's options dataclass
    (:data:`sarcli.formers.options.OPTIONS`), generated from its fields: type, range or choices
    (a name several formers share takes every choice), and help naming each former with its
    default. Not given, an option is None (the former's default); the command receives them as
    keyword arguments (:func:`method_options`)."""
    from dataclasses import fields

    from ..formers.options import OPTIONS

    by_name: dict = {}
    for method, cls in OPTIONS.items():
        for f in fields(cls):
            by_name.setdefault(f.name, []).append((method, f))
    for name in reversed(list(by_name)):
        specs = by_name[name]
        helps = [f"{method}: {f.metadata['help']} (default {_knob_default(f)})" for method, f in specs]
        func = click.option(f"--{name.replace('_', '-')}", name, type=_knob_type([f for _, f in specs]),
                            default=None, help="; ".join(helps) + ".")(func)
    return func


def method_options(method: str, knobs: dict):
    """The options of ``method`` (:mod:`sarcli.formers.options`) from the command's knob options
    (:func:`knob_options`; None: not given). A knob given that is no knob of ``method`` is a usage
    error naming its flag."""
    from ..formers.options import OPTIONS

    cls = OPTIONS[method]
    given = {k: v for k, v in knobs.items() if v is not None}
    extra = [k for k in given if k not in cls.names()]
    if extra:
        flag = f"--{extra[0].replace('_', '-')}"
        if method == "auto":   # auto picks every knob itself: a knob given by hand belongs to one method
            raise click.UsageError(f"{flag} sets a knob of one method; give --method too "
                                   "(auto picks its own knobs: see `sar plan`)")
        have = ", ".join(f"--{n.replace('_', '-')}" for n in cls.names()) or "none"
        raise click.UsageError(f"{flag} is no option of --method {method} (its options: {have})")
    for name, value in given.items():   # each knob against its own range: the message names its flag
        try:
            cls(**{name: value})
        except SarcliInputError as exc:
            raise click.BadParameter(str(exc), param_hint=f"--{name.replace('_', '-')}") from None
    return cls(**given)


def _show_warning(message, category, filename, lineno, file=None, line=None):
    from .._util.progress import message as say

    name = "warning" if not issubclass(category, SarcliWarning) else f"warning ({category.__name__})"
    say(f"{name}: {message}")


def _one_line(prefix, exc) -> str:
    """``prefix: message``, each line cut at :data:`MAX_MESSAGE` characters (a message that lists
    several mistakes, like a bad batch plan's, keeps one line per mistake, at most 20)."""
    lines = [ln for ln in str(exc).splitlines() if ln.strip()] or [type(exc).__name__]
    lines = [ln if len(ln) <= MAX_MESSAGE else ln[:MAX_MESSAGE] + "..." for ln in lines[:20]]
    return f"{prefix}: " + "\n".join(lines)


def handle_errors(func):
    """Decorate a command: user mistakes -> one line + exit 2; numerical failure -> exit 1.

    Library warnings are printed as a single ``warning: ...`` line each (no source lines). An
    operating-system error (permission, full disk) or an allocation that fails is a user-side
    problem: one line, exit 2. Ctrl-C: ``interrupted``, exit 130. Whatever happens, the temporary
    files this command reserved or started are removed (:func:`sarcli._util.atomic.release_all`).
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        from .._util.atomic import WriteError, release_all
        from .._util.interrupt import installed as interrupt_installed

        old = warnings.showwarning
        warnings.showwarning = _show_warning
        try:
            _guard_params(click.get_current_context(silent=True))
            with warnings.catch_warnings():
                warnings.simplefilter("default", SarcliWarning)
                warnings.showwarning = _show_warning
                return func(*args, **kwargs)
        except WriteError as exc:
            click.echo(_one_line("error", exc), err=True)
            release_all()
            if interrupt_installed():  # a real process: h5py may crash freeing the failed file at exit
                sys.stdout.flush()
                sys.stderr.flush()
                os._exit(2)
            sys.exit(2)
        except SarcliInputError as exc:
            click.echo(_one_line("error", exc), err=True)
            sys.exit(2)
        except NumericalError as exc:
            click.echo(_one_line("error", exc), err=True)
            sys.exit(1)
        except OSError as exc:
            if exc.errno == errno.EPIPE:  # `sar info X | head`: the reader left; no message
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, sys.stdout.fileno())
                sys.exit(1)
            name = getattr(exc, "filename", None)
            what = f"{name}: {exc.strerror}" if name and exc.strerror else exc
            click.echo(_one_line("error", what), err=True)
            sys.exit(2)
        except MemoryError:
            click.echo("error: out of memory (the estimate before the allocation was too low; "
                       "lower the sizes or sar --max-memory)", err=True)
            sys.exit(2)
        except KeyboardInterrupt:
            release_all()
            click.echo("interrupted", err=True)
            sys.exit(130)
        finally:
            release_all()
            warnings.showwarning = old

    return wrapper


#: parameter names that are files a command writes (``-o``, ``--png``, ``--geotiff``, ``--history-png``)
OUTPUT_PARAMS = ("output", "png_path", "tif_path", "history_png", "png")


def _guard_params(ctx) -> None:
    """The safety net of every command: its file outputs (:data:`OUTPUT_PARAMS`) against every
    other file-path parameter, before the command body runs (a command that calls
    :func:`prepare_outputs` itself gets more precise labels)."""
    if ctx is None:
        return
    inputs, outputs = [], []
    for param in ctx.command.params:
        value = ctx.params.get(param.name)
        if value is None or not isinstance(param.type, click.Path):
            continue
        values = value if isinstance(value, (tuple, list)) else (value,)
        label = param.opts[-1] if isinstance(param, click.Option) and param.name != "output" else None
        if param.name in OUTPUT_PARAMS and param.type.file_okay:
            outputs += [(label or "output", v) for v in values]
        elif param.type.file_okay:
            inputs += [(label or "input", v) for v in values]
    if outputs:
        prepare_outputs(inputs, outputs)


def output_folder(path):
    """The output folder of a command that writes several files (``sar batch``, ``sar bench``):
    created when missing if its parent exists; a missing parent is one line (as for any output),
    so a typo in a folder name is not silently created a level deep."""
    from pathlib import Path

    out = Path(path)
    if not out.is_dir():
        if not out.parent.is_dir():
            raise SarcliInputError(f"{out}: the folder {out.parent} does not exist (create it first)")
        out.mkdir()
    return out


def prepare_outputs(inputs, outputs) -> None:
    """Before any work: refuse an output that is an input, then reserve every output.

    Parameters
    ----------
    inputs, outputs : iterable of (label, path)
        ``None`` paths are skipped. Reserving creates each output's temporary file now
        (:func:`sarcli._util.atomic.reserve`), so an unwritable folder is found before computing.
    """
    from .._util.atomic import reserve
    from .._util.guard import refuse_overwrite

    inputs = [(label, p) for label, p in inputs if p is not None]
    outputs = [(label, p) for label, p in outputs if p is not None]
    refuse_overwrite(inputs, outputs)
    for _, path in outputs:
        reserve(path)


def _threads(ctx, param, value):
    return None if value in (None, 0) else value


def threads_option(func):
    """``--threads N``: N >= 1 threads, or 0 for all cores (the default)."""
    return click.option("--threads", "nthreads", type=click.IntRange(min=0), default=None, callback=_threads,
                        help="Threads, >= 1 (0 or unset: all cores).")(func)


def parse_pair(text, name):
    """Parse ``"a"`` or ``"a,b"`` into a float pair (``(a, a)`` for one number)."""
    if text is None:
        return None
    try:
        parts = [float(p) for p in str(text).split(",")]
    except ValueError:
        raise click.BadParameter(f"expected a number or two numbers 'A,B', got {str(text)[:60]!r}",
                                 param_hint=name) from None
    if len(parts) == 1:
        parts = parts * 2
    if len(parts) != 2:
        raise click.BadParameter(f"expected one or two comma-separated numbers, got {str(text)[:60]!r}",
                                 param_hint=name)
    if not all(math.isfinite(p) for p in parts):
        raise click.BadParameter(f"expected finite numbers, got {str(text)[:60]!r}", param_hint=name)
    return tuple(parts)


def grid_options(func):
    """The grid overrides shared by ``form-image``, ``regularize`` and friends.

    Adds ``--center X,Y``, ``--extent W[,H]`` and ``--pixel-size H``; the command receives
    ``center``, ``extent`` and ``pixel_size`` (None when not given) and passes them to
    :func:`sarcli.grid_for`.
    """
    func = click.option("--pixel-size", "pixel_size", type=click.FloatRange(min=0, min_open=True), default=None,
                        help="Pixel size in metres (default: from the acquisition).")(func)
    func = click.option("--extent", "extent", default=None,
                        help="Full side lengths W or W,H in metres (default: the acquisition's scene).")(func)
    func = click.option("--center", "center", default=None,
                        help="Grid centre X,Y in metres (default 0,0).")(func)
    return func


def wrote(path, detail: str = "") -> None:
    """The one line every writing command prints on success, ``wrote PATH (detail)``, unless -q."""
    ctx = click.get_current_context(silent=True)
    if ctx is not None and (ctx.find_root().obj or {}).get("quiet"):
        return
    click.echo(f"wrote {path}" + (f" ({detail})" if detail else ""))


def echo_info(ctx, text):
    """Print informational output unless ``--quiet``."""
    if not (ctx.obj or {}).get("quiet"):
        click.echo(text)


def cphd_options(func):
    """``--channel``, ``--sgn`` and ``--troposphere``: how a CPHD input is read
    (:func:`sarcli.io.cphd.read_cphd`); they reach the reader as the ``cphd`` argument."""
    from ..io.cphd.corrections import TROPOSPHERE_MODES

    func = click.option("--troposphere", type=click.Choice(TROPOSPHERE_MODES), default=None,
                        help="CPHD: auto (default: trust TDTropoSRP, unless a known vendor leaves the delay in "
                             "the data), file (trust TDTropoSRP), model (remove a standard atmosphere's delay "
                             "less TDTropoSRP).")(func)
    func = click.option("--sgn", type=click.Choice(["-1", "+1", "1"]), default=None,
                        help="CPHD: the phase sign to use, whatever the file and the data say.")(func)
    func = click.option("--channel", default=None, metavar="NAME|INDEX",
                        help="CPHD: the channel to read, by identifier or 0-based index (default the first; "
                             "sar info lists them).")(func)
    return func


def cphd_arguments(channel=None, sgn=None, troposphere=None) -> dict | None:
    """The ``cphd`` argument of :func:`sarcli.io.open_input` from :func:`cphd_options` (None: none given)."""
    given = {k: v for k, v in (("channel", channel), ("sgn", None if sgn is None else int(sgn)),
                               ("troposphere", troposphere)) if v is not None}
    return given or None


def echo_notes(ph) -> None:
    """Print the reader's one-line notes (``attrs['cphd_notes']``: a channel chosen, a sign or a
    troposphere correction applied) as ``note: ...`` on stderr, unless ``--quiet``."""
    from .._util.progress import message

    ctx = click.get_current_context(silent=True)
    if ctx is not None and (ctx.find_root().obj or {}).get("quiet"):
        return
    for note in (getattr(ph, "attrs", None) or {}).get("cphd_notes", []) or []:
        message(f"note: {note}")


def _remember_bare(ctx, param, value):
    ctx.meta["sarcli.png_bare"] = bool(value)
    return value


def export_options(func):
    """``--png F``, ``--bare`` and ``--geotiff F``: also export the image written by the command."""
    func = click.option("--bare", is_flag=True, expose_value=False, callback=_remember_bare,
                        help="--png: the raw raster (one pixel per image pixel) instead of the annotated figure.")(func)
    func = click.option("--geotiff", "tif_path", type=click.Path(dir_okay=False), default=None,
                        help="Also write a GeoTIFF of the magnitude.")(func)
    func = click.option("--png", "png_path", type=click.Path(dir_okay=False), default=None,
                        help="Also write a dB picture (50 dB, north up): a figure with metre axes, title "
                             "and colour bar (--bare: the raw raster).")(func)
    return func


def write_side_outputs(img, png_path=None, tif_path=None):
    """Write the ``--png`` / ``--geotiff`` shortcuts of a command (atomic, like every output)."""
    if png_path or tif_path:
        from ..io.export import export_image

        if png_path:
            ctx = click.get_current_context(silent=True)
            bare = bool(ctx and ctx.meta.get("sarcli.png_bare"))
            if bare:
                export_image(img, png_path, kind="db")
            else:
                from ..viz import image_figure

                image_figure(img, png_path, kind="db")
            wrote(png_path, "dB picture, raw raster" if bare else "dB figure")
        if tif_path:
            export_image(img, tif_path, kind="magnitude")
            wrote(tif_path, "GeoTIFF, magnitude")
