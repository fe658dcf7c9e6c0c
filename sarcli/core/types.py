"""The data types every part of sarcli passes around: no file I/O here.

:class:`PhaseHistory` (samples and their geometry), :class:`Truth` (what a simulated scene was),
:class:`Image` (a complex image on a grid) and :class:`KGrid` (phase history gridded onto a
Cartesian k-grid by the polar format algorithm). Readers and writers live in :mod:`sarcli.io`;
this module imports only NumPy and the standard library, so anything that needs an ``Image`` can
have one without h5py.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .acquisition import Acquisition
from .grid import Grid

__all__ = ["PhaseHistory", "Truth", "Image", "KGrid", "to_json"]


@dataclass(frozen=True, eq=False)
class Truth:
    """What a simulated scene really was.

    Attributes
    ----------
    point_position_m : ndarray (S, 3)
    point_amplitude : ndarray (S,) complex
    scene : ndarray (ny, nx) complex, optional
        The scene at reconstruction resolution (block average of the fine synthesis grid).
    x_m, y_m : ndarray, optional
        Pixel-centre coordinates of ``scene``.
    magnitude : ndarray (ny, nx), optional
        Block average of the reflectivity magnitude (what a speckle-free image should show).
    """

    point_position_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    point_amplitude: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))
    scene: np.ndarray | None = None
    x_m: np.ndarray | None = None
    y_m: np.ndarray | None = None
    magnitude: np.ndarray | None = None

    @property
    def grid(self) -> Grid | None:
        return None if self.scene is None else Grid.from_axes(self.x_m, self.y_m)


@dataclass(frozen=True, eq=False)
class PhaseHistory:
    """A phase history ``d[p, j]`` with its acquisition geometry.

    Attributes
    ----------
    data : ndarray (P, M) complex
    acquisition : Acquisition
        Geometry; ``acquisition.model`` is the data model the samples follow.
    truth : Truth, optional
    attrs : dict
        Provenance read from or written to the file (``sarcli_version``, ``config_yaml``, ...).
    """

    data: np.ndarray
    acquisition: Acquisition
    truth: Truth | None = None
    attrs: dict[str, Any] = field(default_factory=dict)

    @property
    def model(self) -> str:
        return self.acquisition.model


@dataclass(eq=False)
class Image:
    """A complex image on a grid, normalised so a unit point scatterer peaks at 1.

    Attributes
    ----------
    image : ndarray (ny, nx) complex
    x_m, y_m : ndarray
        Increasing pixel-centre coordinates.
    method : str
    parameters : dict
        Every setting that shaped the image (JSON-serialisable).
    runtime_s : float
        Wall seconds of the formation itself (NaN when a file does not say, e.g. another tool's SICD).
    history : dict of str -> ndarray, optional
        Per-iteration logs of iterative methods.
    attrs : dict
        Further root attributes.
    """

    image: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    method: str = ""
    parameters: dict[str, Any] = field(default_factory=dict)
    runtime_s: float = 0.0
    history: dict[str, np.ndarray] | None = None
    attrs: dict[str, Any] = field(default_factory=dict)

    @property
    def grid(self) -> Grid:
        return Grid.from_axes(self.x_m, self.y_m)



@dataclass
class KGrid:
    """Phase history gridded onto a Cartesian k-grid (the product of :func:`regrid_polar`).

    Attributes
    ----------
    samples : ndarray, shape (nky, nkx), complex128
        Gridded (kernel-spread) samples, ``samples[iy, ix]`` at ``(kx0 + ix dkx, ky0 + iy dky)``.
    kx0, ky0 : float
        Absolute k of ``samples[0, 0]`` (rad/m).
    dkx, dky : float
        Grid spacing (rad/m).
    kc : (float, float)
        Centre of the sample support (rad/m), the baseband shift.
    weights_sum : float
        ``W = Σ ρ_s w_s``, the matched-filter normaliser.
    parameters : dict
        ``kernel``, ``width``, ``beta``, ``oversample``, ``density``, ``pixel_m`` (dx, dy),
        ``shape`` (ny, nx), ``center_m`` (cx, cy), ``n_fft`` (nfy, nfx), ``aperture_deg``.
    """

    samples: np.ndarray
    kx0: float
    ky0: float
    dkx: float
    dky: float
    kc: tuple
    weights_sum: float
    parameters: dict = field(default_factory=dict)

    @property
    def shape(self):
        return self.samples.shape


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, (np.bool_,)):
        return bool(o)
    if isinstance(o, complex):
        return [o.real, o.imag]
    if isinstance(o, Path):
        return str(o)
    return str(o)


def to_json(obj) -> str:
    return json.dumps(obj, default=_json_default, sort_keys=True)
