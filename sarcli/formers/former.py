"""One interface for every image former: options, plan, form.

Each family of former (``direct``, ``nufft``, ``pfa``, ``backprojection``, ``ffbp``,
``subimage``) is a :class:`Former`: an options dataclass (its knobs, their defaults, ranges and
help, :class:`Options`) and ``plan(ph, grid, options, settings) -> Plan``. A :class:`Plan` is
made from the collection's geometry and the grid alone, as FINUFFT's plan is made before its
points' strengths are known: it resolves what the options leave open (a tile side, ffbp's
stages), and carries the predicted error against the exact matched filter, the predicted
seconds and the peak bytes, each from the one model of its family
(:mod:`sarcli.formers.planning.cost`, calibrated by :mod:`sarcli.formers.planning.calibration`). Its
:meth:`Plan.form` forms the image of the samples.

:func:`sarcli.formers.formation.form_image`, the planner (:mod:`sarcli.formers.planning.planner`),
``sar plan`` and ``sar form-image`` (whose options are generated from these dataclasses) and
autofocus's prepared backprojector are its clients.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field, fields
from typing import Callable, ClassVar

import numpy as np

from ..errors import SarcliInputError

__all__ = ["knob", "Options", "Settings", "Plan", "Former", "flag_text"]


def knob(default, help: str, *, kind=float, range=None, choices=None, default_text=None):
    """A dataclass field for one knob of a former: its default, its help (a phrase), its type
    (``float``, ``int`` or ``str``), its range ``(lo, hi)`` (``hi`` may be None) or its choices,
    and for a default of None the words that say what it then is."""
    return field(default=default, metadata={"help": help, "kind": kind, "range": range, "choices": choices,
                                            "default_text": default_text})


def flag_text(value) -> str:
    """A knob's value as a command-line flag writes it, read back exactly (floats by ``repr``;
    NumPy scalars as the Python numbers they equal)."""
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    if isinstance(value, np.integer):
        return str(int(value))
    return str(value)


def _checked(method: str, f, value):
    """``value`` of knob ``f`` checked against its kind, range and choices (one line naming it)."""
    if value is None:
        if f.default is None:
            return
        raise SarcliInputError(f"{method}: {f.name} must be given a value, not None")
    meta = f.metadata
    if meta["choices"] is not None:
        if value not in meta["choices"]:
            raise SarcliInputError(f"{method}: {f.name} must be one of {', '.join(meta['choices'])}, got {value!r}")
        return
    if meta["kind"] is str:
        return
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SarcliInputError(f"{method}: {f.name} must be a number, got {str(value)[:40]!r}") from None
    if isinstance(value, bool) or not math.isfinite(v) or (meta["kind"] is int and v != int(v)):
        raise SarcliInputError(f"{method}: {f.name} must be a finite {meta['kind'].__name__}, got {value!r}")
    lo, hi = meta["range"] or (None, None)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        span = f"in [{lo:g}, {hi:g}]" if hi is not None else f">= {lo:g}"
        raise SarcliInputError(f"{method}: {f.name} must be {span}, got {v:g}")


@dataclass(frozen=True)
class Options:
    """Base of every former's options: frozen, checked when made (one line naming the knob)."""

    method: ClassVar[str] = ""

    def __post_init__(self):
        for f in fields(self):
            _checked(self.method, f, getattr(self, f.name))

    @classmethod
    def names(cls) -> tuple:
        """The knobs' names, in declaration order."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def from_knobs(cls, knobs: dict) -> "Options":
        """The options with ``knobs`` set and the rest at their defaults (a knob given as None
        takes its default); a name that is no knob of this former is refused, naming it and the
        knobs there are."""
        unknown = [k for k in knobs if k not in cls.names()]
        if unknown:
            have = ", ".join(cls.names()) or "none"
            raise SarcliInputError(f"method {cls.method!r} has no knob {unknown[0]!r} (its knobs: {have})")
        return cls(**{k: v for k, v in knobs.items() if v is not None})

    def knobs(self) -> dict:
        """Every knob and its value (None: chosen by the plan)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def given(self) -> dict:
        """The knobs that differ from their defaults."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) != f.default}

    def flags(self) -> list:
        """The ``sar form-image`` flags that give these options: ``--method`` and every knob that
        differs from its default."""
        out = ["--method", self.method]
        for name, value in self.given().items():
            out += [f"--{name.replace('_', '-')}", flag_text(value)]
        return out


@dataclass(frozen=True)
class Settings:
    """What every former takes besides its knobs: the window (applied in range and cross-range,
    normalised by ``W = Σw``; Taylor's parameters) and the threads (None: all cores)."""

    window: str = "none"
    taylor_nbar: int = 4
    taylor_sll_db: float = -35.0
    nthreads: int | None = None

    def weights(self, shape):
        """Window weights ``[P, M]``, or None without a window (the formers then take ``W = P M``)."""
        from ..core.windows import window_weights

        if self.window == "none":
            return None
        try:
            return window_weights(*shape, self.window, nbar=self.taylor_nbar, sll_db=self.taylor_sll_db)
        except ValueError as exc:  # an unknown kind or Taylor parameters out of range
            raise SarcliInputError(str(exc)) from None

    def parameters(self) -> dict:
        """What an image records of these settings."""
        out = {"window": self.window}
        if self.window == "taylor":
            out.update({"taylor_nbar": self.taylor_nbar, "taylor_sll_db": self.taylor_sll_db})
        return out


@dataclass(eq=False)
class Plan:
    """A former made ready for one collection's geometry and one grid (FINUFFT's plan).

    ``options``: as asked (what :meth:`Options.flags` reproduces); ``knobs``: what runs, every
    knob resolved; ``predicted_error`` (relative, against the exact matched filter; nan where the
    family has no error model), ``seconds`` (the formation on this machine's cost model) and
    ``bytes`` (peak working memory) are computed when first read. :meth:`form` forms the image.
    """

    method: str
    options: Options
    knobs: dict
    ph: object = field(repr=False)
    grid: object = field(repr=False)
    settings: Settings = field(repr=False)
    run: Callable = field(repr=False)              # (plan, data, weights) -> (image, parameters)
    estimate: Callable = field(repr=False)         # () -> (predicted error, seconds)
    memory: Callable = field(repr=False)           # () -> bytes
    notes: str = ""
    #: ``auto``'s choice (tolerance, method, knobs, its prediction) where auto made the plan
    auto: dict | None = None
    #: ``(data=None) ->`` the former prepared for many images of ``data`` (default the
    #: collection's samples) on this grid, where the family has one (backprojection:
    #: :class:`sarcli.formers.backprojection.Backprojector`); else None
    prepare: Callable | None = field(default=None, repr=False)

    @functools.cached_property
    def _estimates(self):
        return self.estimate()

    @property
    def predicted_error(self) -> float:
        return float(self._estimates[0])

    @property
    def seconds(self) -> float:
        return float(self._estimates[1])

    @functools.cached_property
    def bytes(self) -> float:
        return float(self.memory())

    def flags(self) -> list:
        """The ``sar form-image`` flags that run this plan (:meth:`Options.flags`)."""
        return self.options.flags()

    def form(self, data=None):
        """The image of ``data`` (default: the collection's own samples; else an array of their
        shape, e.g. the samples with phase errors removed), as a :class:`~sarcli.core.types.Image`
        with ``method``, every setting in ``parameters`` and ``runtime_s`` (the formation alone)."""
        from ..core.types import Image

        ph = self.ph
        data = ph.data if data is None else data
        if tuple(np.shape(data)) != tuple(ph.data.shape):
            raise SarcliInputError(f"samples of shape {np.shape(data)} for a plan of {tuple(ph.data.shape)}")
        params = {"method": self.method, **self.settings.parameters(), "grid": self.grid.as_dict(),
                  "data_model": ph.model}
        t0 = time.perf_counter()
        img, extra = self.run(self, data, self.settings.weights(ph.data.shape))
        runtime = time.perf_counter() - t0
        params.update(extra)
        attrs = {k: v for k, v in ph.attrs.items() if str(k).startswith("scene_center")}
        attrs["source_name"] = ph.acquisition.name
        return Image(image=np.asarray(img), x_m=self.grid.x, y_m=self.grid.y, method=self.method,
                     parameters=params, runtime_s=runtime, attrs=attrs)


@dataclass(frozen=True)
class Former:
    """One family of image former: its options dataclass and its planner."""

    method: str
    options: type
    plan: Callable          # (ph, grid, options, settings, costs=None) -> Plan

    def make(self, ph, grid, settings: Settings | None = None, costs=None, **knobs) -> Plan:
        """:attr:`plan` with options from ``knobs`` (:meth:`Options.from_knobs`)."""
        return self.plan(ph, grid, self.options.from_knobs(knobs), settings or Settings(), costs)
