"""Shared helpers of the paper-reproduction scripts: results, configs, figure saving.

Every figure module ``figNN_*.py`` exposes ``compute(...)`` (the numbers, at a size given by its
arguments, so the tests can run them small) and ``run(out_dir) -> Result`` (full size, with the
figure). :mod:`run_all` collects the results into ``docs/paper.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import yaml  # noqa: E402

import sarcli  # noqa: E402
from sarcli.io.gotcha import gotcha_dir  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
CONFIGS = REPO / "configs"
GOTCHA_DIR = gotcha_dir()
_MERGED = ("frequencies", "azimuths", "image", "noise")


@dataclass
class Result:
    """One figure or result of the paper, as reproduced.

    Attributes
    ----------
    key : str
        File stem of the figure (``fig04_kernel``).
    label : str
        The paper's LaTeX label (``fig: kernel``).
    title : str
    claim : str
        What the paper claims (quoted or paraphrased, markdown).
    measured : list of str
        Our numbers, one markdown bullet each.
    passed : bool or None
        None: not reproduced (``measured`` says why).
    figure : matplotlib Figure, optional
    notes : str
        Anything a reader should know about how we differ from the paper.
    headline : str
        The key number(s), for the summary table.
    kind : str
        'reproduced', 'analogue (why)' or 'not reproducible (why)'.
    """

    key: str
    label: str
    title: str
    claim: str
    measured: list = field(default_factory=list)
    passed: bool | None = None
    figure: object = None
    notes: str = ""
    headline: str = ""
    kind: str = "reproduced"


def load_config(name: str, **changes) -> dict:
    """A config of ``configs/`` as a dict, with top-level sections updated by ``changes``.

    A dict for ``frequencies``, ``azimuths``, ``image`` or ``noise`` updates that section key by
    key; any other value replaces the section.
    """
    cfg = yaml.safe_load((CONFIGS / f"{name}.yaml").read_text())
    for key, value in changes.items():
        if key in _MERGED and isinstance(value, dict) and isinstance(cfg.get(key), dict):
            cfg[key] = {**cfg[key], **value}
        else:
            cfg[key] = value
    return cfg


def acquisition(name: str, **changes):
    """``sarcli.parse_acquisition`` of a (modified) config of ``configs/``."""
    return sarcli.parse_acquisition(load_config(name, **changes))


def db(values, floor_db: float = -80.0) -> np.ndarray:
    """``20 log10 |v| / max|v|``, clipped at ``floor_db``."""
    a = np.abs(np.asarray(values))
    peak = float(a.max()) if a.size and a.max() > 0 else 1.0
    with np.errstate(divide="ignore"):
        out = 20.0 * np.log10(a / peak)
    return np.maximum(out, floor_db)


def fmt(x: float, digits: int = 3) -> str:
    """A number for the markdown page (``1.23e-14``, ``0.456``)."""
    x = float(x)
    if x == 0 or (1e-3 <= abs(x) < 1e5):
        return f"{x:.{digits}g}"
    return f"{x:.{max(digits - 1, 1)}e}"
