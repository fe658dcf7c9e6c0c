"""Options objects: a dataclass of a procedure's knobs, given whole, as keyword arguments, or both."""

from __future__ import annotations

from dataclasses import fields, replace

__all__ = ["with_options"]


def with_options(cls, options, knobs: dict):
    """``options`` (an instance of the dataclass ``cls``; default ``cls()``) with the fields named in
    ``knobs`` replaced: how a procedure takes an options object, keyword arguments, or both
    (:func:`sarcli.autofocus.pga.pga`, :func:`sarcli.autofocus.entropy.min_entropy`,
    :func:`sarcli.batch.benchmark.run_benchmark`). A name that is no field of ``cls`` is a
    :class:`TypeError`, as an unknown keyword argument is."""
    unknown = sorted(set(knobs) - {f.name for f in fields(cls)})
    if unknown:
        raise TypeError(f"{cls.__name__} has no option {unknown[0]!r}")
    base = cls() if options is None else options
    return replace(base, **knobs) if knobs else base
