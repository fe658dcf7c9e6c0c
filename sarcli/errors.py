"""Exceptions and warnings of sarcli.

Every error a *user* can cause (a bad config, a broken or foreign file, an impossible option) is a
:class:`SarcliInputError`; the command-line interface turns it into one line on stderr and exit
code 2. Numerical trouble that still yields a result (aliasing, defocus, slow convergence) is a
warning of a :class:`SarcliWarning` subclass whose message carries the number that matters.
The library never imports click: the CLI maps these classes to exit codes.
"""

from __future__ import annotations

__all__ = [
    "SarcliError",
    "SarcliInputError",
    "ConfigError",
    "InputFileError",
    "NumericalError",
    "SarcliWarning",
    "AliasingWarning",
    "DefocusWarning",
    "ConvergenceWarning",
    "ConditioningWarning",
]


class SarcliError(Exception):
    """Root of every exception raised on purpose by sarcli."""


class SarcliInputError(SarcliError, ValueError):
    """Something the user gave is wrong: the CLI prints the message alone and exits with 2."""


class ConfigError(SarcliInputError):
    """A YAML acquisition file (or an option standing in for one of its keys) is invalid.

    Parameters
    ----------
    message : str
        What is expected.
    source : str, optional
        The file the value came from.
    key : str, optional
        Dotted path of the offending key, e.g. ``frequencies.bandwidth_mhz``.
    """

    def __init__(self, message: str, *, source: str | None = None, key: str | None = None):
        self.source = source
        self.key = key
        parts = []
        if source:
            parts.append(str(source))
        if key:
            parts.append(f"key '{key}'")
        prefix = ": ".join(parts)
        super().__init__(f"{prefix}: {message}" if prefix else message)


class InputFileError(SarcliInputError):
    """An input data file is missing, foreign, truncated or breaks the HDF5 contract."""

    def __init__(self, path, message: str):
        self.path = str(path)
        super().__init__(f"{path}: {message}")


class NumericalError(SarcliError, ArithmeticError):
    """A computation could not produce a meaningful result (exit code 1 in the CLI)."""


class SarcliWarning(UserWarning):
    """Root of sarcli's warnings: numerical trouble that still yields a result."""


class AliasingWarning(SarcliWarning):
    """The scene or grid exceeds what the sampling can represent without aliasing."""


class DefocusWarning(SarcliWarning):
    """A far-field method is applied to spherical (near-field) data; message gives the phase error."""


class ConvergenceWarning(SarcliWarning):
    """An iterative method stopped at its iteration cap before meeting its tolerance."""


class ConditioningWarning(SarcliWarning):
    """A problem is (nearly) rank deficient or degenerate; message gives the measure."""
