"""The one YAML loader of sarcli (acquisitions and batch plans): strict and bounded.

On top of :class:`yaml.SafeLoader` it refuses duplicate keys (naming the key and both lines),
anchors and aliases (no expansion bombs), NaN and infinities wherever a number is written, files
larger than :data:`MAX_BYTES` and nesting deeper than :data:`MAX_DEPTH`. Like every YAML 1.1
reader it reads ``1e12`` (no dot) as text; the schema checks say so (write ``1.0e12``). Every message quotes at most ~200 characters of a value
(:func:`short_repr`).
"""

from __future__ import annotations

import math
import reprlib
from pathlib import Path

import yaml

from ..errors import ConfigError

__all__ = ["load_yaml", "load_yaml_text", "short_repr", "MAX_BYTES", "MAX_DEPTH"]

#: largest YAML file read (bytes); positions of 1e6 pulses fit in about 60 MB
MAX_BYTES = 64 << 20
#: deepest nesting of lists and mappings
MAX_DEPTH = 64
_REPR = reprlib.Repr()
_REPR.maxstring = _REPR.maxother = 160
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = 8
_REPR.maxlevel = 3


def short_repr(value, limit: int = 200) -> str:
    """``repr(value)`` cut to about ``limit`` characters without building the full repr."""
    text = _REPR.repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


class _Refused(Exception):
    def __init__(self, mark, message):
        self.line = None if mark is None else mark.line + 1
        super().__init__(message)


class StrictLoader(yaml.SafeLoader):
    """SafeLoader without aliases, duplicate keys or non-finite numbers."""

    yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}

    def compose_node(self, parent, index):
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
            kind = "alias" if isinstance(event, yaml.AliasEvent) else "anchor"
            raise _Refused(event.start_mark, f"{kind} '{str(event.anchor)[:40]}' refused: anchors and aliases are "
                                             "not supported (write the values out)")
        self._depth = getattr(self, "_depth", 0) + 1
        try:
            if self._depth > MAX_DEPTH:
                raise _Refused(event.start_mark, f"nested deeper than {MAX_DEPTH} levels")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        seen = {}
        if isinstance(node, yaml.MappingNode):
            for key_node, _ in node.value:
                if isinstance(key_node, yaml.ScalarNode):
                    key = self.construct_object(key_node, deep=True)
                    try:
                        first = seen.get(key)
                        seen.setdefault(key, key_node.start_mark.line + 1)
                    except TypeError:  # an unhashable key: SafeLoader refuses it
                        continue
                    if first is not None:
                        raise _Refused(key_node.start_mark,
                                       f"duplicate key '{short_repr(key, 60).strip(chr(39))}' (lines {first} "
                                       f"and {key_node.start_mark.line + 1})")
        return super().construct_mapping(node, deep=deep)

    def construct_yaml_float(self, node):
        value = super().construct_yaml_float(node)
        if not math.isfinite(value):
            raise _Refused(node.start_mark, f"value {short_repr(node.value, 40)} is not a finite number "
                                            "(NaN and infinities are refused)")
        return value


StrictLoader.add_constructor("tag:yaml.org,2002:float", StrictLoader.construct_yaml_float)
StrictLoader.add_constructor("tag:yaml.org,2002:map", StrictLoader.construct_yaml_map)


def load_yaml_text(text: str, *, source: str = "<yaml>"):
    """Parse YAML text with :class:`StrictLoader`; every problem is one :class:`ConfigError`."""
    if len(text) > MAX_BYTES:
        raise ConfigError(f"{len(text)} characters is more than the {MAX_BYTES >> 20} MiB a YAML file may hold",
                          source=source)
    try:
        return yaml.load(text, Loader=StrictLoader)  # noqa: S506 - StrictLoader is a SafeLoader
    except _Refused as exc:
        where = f"line {exc.line}: " if exc.line else ""
        raise ConfigError(f"{where}{exc}", source=source) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(f"not valid YAML{where}: {short_repr(problem, 120).strip(chr(39))}", source=source) from None
    except RecursionError:
        raise ConfigError(f"nested too deeply (more than {MAX_DEPTH} levels)", source=source) from None


def load_yaml(path, *, what: str = "YAML file"):
    """Read and parse a YAML file; missing, unreadable or oversized files are one ConfigError."""
    p = Path(path)
    if not p.exists():
        raise ConfigError("no such file", source=str(path))
    if p.is_dir():
        raise ConfigError(f"is a directory, expected a {what}", source=str(path))
    try:
        size = p.stat().st_size
        if size > MAX_BYTES:
            raise ConfigError(f"{size} bytes is more than the {MAX_BYTES >> 20} MiB a {what} may hold",
                              source=str(path))
        text = p.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read as text ({short_repr(str(exc), 120)})", source=str(path)) from None
    return load_yaml_text(text, source=str(path)), text
