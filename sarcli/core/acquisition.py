"""The acquisition: what was (or will be) collected, and on which grid it is imaged.

An :class:`Acquisition` is frozen and holds SI arrays only; everything derived from it
(wavenumbers, k-space coordinates, sampling limits, ranges) is delegated to
:mod:`sarcli.core.geometry`. It is built from a YAML file by :func:`sarcli.io.config.load_acquisition`
or from a phase-history file by :func:`sarcli.io.hdf5.read_phase_history`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from . import geometry
from .collection import Collection
from .grid import Grid

__all__ = ["Acquisition", "MODELS"]

#: Data models a phase history can follow (docs/conventions.md "Data models").
MODELS = ("farfield", "spherical")


def _frozen(a, dtype=np.float64):
    if a is None:
        return None
    arr = np.array(a, dtype=dtype, copy=True)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class Acquisition:
    """Geometry of a spotlight collection and its default image grid.

    Parameters
    ----------
    frequency_hz : ndarray, shape (M,) or (P, M)
        Frequencies α_j.
    azimuth_rad, elevation_rad : ndarray, shape (P,)
        Look azimuth θ_p and elevation φ_p (docs/conventions.md "Geometry of a pulse").
    grid : Grid
        The default image grid (R, N of the config, or derived from the sampling).
    antenna_position_m : ndarray, shape (P, 3), optional
        Antenna phase centres; present for any flight path, absent for a pure far-field setup.
    range_to_center_m : ndarray, shape (P,), optional
        Reference ranges r0_p (default ``|a_p|``).
    model : {'farfield', 'spherical'}
        The data model the collection follows by default.
    snr_db : float, optional
        Requested signal-to-noise ratio of simulated data (None: noiseless).
    scene : dict, optional
        The validated ``scene`` section of the config (see :mod:`sarcli.simulation.scenes`).
    name, source, config_text : str, optional
        Provenance: a short name, the file it came from and its text.
    transmit_position_m, receive_position_m : ndarray, shape (P, 3), optional
        Separate transmit and receive phase centres t_p, q_p (docs/conventions.md "Spherical with
        separate transmit and receive positions"): the platform moves while the echo travels, or
        a bistatic collection. Given together; then ``antenna_position_m`` defaults to their
        midpoint and ``range_to_center_m`` to half the two-way path ``(|t_p| + |q_p|)/2``, and
        image formation uses the two-way range (:meth:`differential_range`).
    """

    frequency_hz: np.ndarray
    azimuth_rad: np.ndarray
    elevation_rad: np.ndarray
    grid: Grid
    antenna_position_m: np.ndarray | None = None
    range_to_center_m: np.ndarray | None = None
    model: str = "farfield"
    snr_db: float | None = None
    scene: dict | None = None
    name: str = ""
    source: str | None = None
    config_text: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    transmit_position_m: np.ndarray | None = None
    receive_position_m: np.ndarray | None = None

    def __post_init__(self):
        if (self.transmit_position_m is None) != (self.receive_position_m is None):
            raise ValueError("transmit and receive positions go together: give both or neither")
        if self.transmit_position_m is not None:
            t = _frozen(self.transmit_position_m)
            q = _frozen(self.receive_position_m)
            if t.shape != q.shape or t.ndim != 2 or t.shape[1] != 3:
                raise ValueError(f"transmit/receive positions must both be (P, 3), got {t.shape}, {q.shape}")
            object.__setattr__(self, "transmit_position_m", t)
            object.__setattr__(self, "receive_position_m", q)
            if self.antenna_position_m is None:
                object.__setattr__(self, "antenna_position_m", 0.5 * (t + q))
            if self.range_to_center_m is None:
                object.__setattr__(self, "range_to_center_m", geometry.bistatic_reference_range(t, q))
        object.__setattr__(self, "frequency_hz", _frozen(self.frequency_hz))
        object.__setattr__(self, "azimuth_rad", _frozen(np.atleast_1d(self.azimuth_rad)))
        el = np.broadcast_to(np.asarray(self.elevation_rad, dtype=np.float64), self.azimuth_rad.shape)
        object.__setattr__(self, "elevation_rad", _frozen(el))
        object.__setattr__(self, "antenna_position_m", _frozen(self.antenna_position_m))
        r0 = self.range_to_center_m
        if r0 is None and self.antenna_position_m is not None:
            r0 = np.linalg.norm(self.antenna_position_m, axis=1)
        object.__setattr__(self, "range_to_center_m", _frozen(r0))
        if self.model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, got {self.model!r}")
        if self.model == "spherical" and self.antenna_position_m is None:
            raise ValueError("the spherical model needs antenna positions (a flight path)")

    # -- sizes --------------------------------------------------------------------------------
    @property
    def n_pulses(self) -> int:
        """P, the number of pulses (looks)."""
        return int(self.azimuth_rad.size)

    @property
    def n_frequencies(self) -> int:
        """M, the number of frequencies per pulse."""
        return int(self.frequency_hz.shape[-1])

    @property
    def has_positions(self) -> bool:
        return self.antenna_position_m is not None

    @property
    def is_bistatic(self) -> bool:
        """True when separate transmit and receive positions are given and differ anywhere."""
        return self.transmit_position_m is not None and not np.array_equal(
            self.transmit_position_m, self.receive_position_m)

    def range_geometry(self):
        """``(t, q, r0)`` for the two-way range model: ``t = q = a`` for a monostatic collection."""
        if not self.has_positions:
            raise ValueError("this acquisition has no antenna positions (far-field only)")
        if self.is_bistatic:
            return self.transmit_position_m, self.receive_position_m, self.range_to_center_m
        return self.antenna_position_m, self.antenna_position_m, self.range_to_center_m

    def collection(self, weights=None) -> Collection:
        """The :class:`~sarcli.core.collection.Collection` of the range model with window ``weights``:
        frequencies, transmit (or antenna) positions, reference ranges and, when bistatic, the
        receive positions (:meth:`range_geometry`)."""
        t, q, r0 = self.range_geometry()
        return Collection(self.frequency_hz, t, r0, weights, q if self.is_bistatic else None)

    @property
    def frequencies_2d(self) -> np.ndarray:
        """Frequencies as a (P, M) array (a read-only broadcast view when shared)."""
        f = self.frequency_hz
        return np.broadcast_to(f, (self.n_pulses, f.size)) if f.ndim == 1 else f

    @property
    def center_frequency_hz(self) -> float:
        return 0.5 * float(self.frequency_hz.max() + self.frequency_hz.min())

    @property
    def bandwidth_hz(self) -> float:
        return float(self.frequency_hz.max() - self.frequency_hz.min())

    # -- derived quantities (all delegated to geometry) ------------------------------------------
    def wavenumbers(self) -> np.ndarray:
        """k[p, j] (rad/m), eq. ``k-values``."""
        return geometry.wavenumbers(self.frequency_hz, self.elevation_rad)

    def kspace(self):
        """Physical k-space coordinates ``(kx, ky)`` of every sample, each (P, M) in rad/m."""
        return geometry.kspace_coordinates(self.frequency_hz, self.azimuth_rad, self.elevation_rad)

    def alias_free_radii(self):
        """``(R_range, R_cross)`` in metres (section ``sec: size``)."""
        return geometry.alias_free_radii(self.frequency_hz, self.azimuth_rad, self.elevation_rad)

    def resolutions(self):
        """``(ρ_range, ρ_cross)`` in metres."""
        return geometry.resolutions(self.frequency_hz, self.azimuth_rad, self.elevation_rad)

    def total_aperture_rad(self) -> float:
        return geometry.total_aperture(self.azimuth_rad)

    def differential_range(self, points_m) -> np.ndarray:
        """``|a_p - x| - r0_p`` (or ``(|t_p - x| + |q_p - x|)/2 - r0_p``), shape (P, ...)."""
        t, q, r0 = self.range_geometry()
        return geometry.bistatic_differential_range(t, q, r0, points_m)

    def farfield_phase_error(self, radius_m: float | None = None) -> float:
        """Predicted far-field phase error (rad) at ``radius_m`` (default: the grid's corner)."""
        if not self.has_positions:
            return 0.0
        radius = self.grid.half_diagonal if radius_m is None else radius_m
        return geometry.farfield_phase_error(self.range_to_center_m, self.frequency_hz.max(), radius)

    def with_(self, **changes) -> "Acquisition":
        """A copy with some fields replaced (the object itself is frozen)."""
        return replace(self, **changes)

    def subset(self, pulses=None, frequencies=None) -> "Acquisition":
        """The acquisition restricted to some pulses and/or frequency indices."""
        p = slice(None) if pulses is None else pulses
        j = slice(None) if frequencies is None else frequencies
        f = self.frequency_hz[..., j] if self.frequency_hz.ndim == 1 else self.frequency_hz[p][:, j]
        return replace(
            self,
            frequency_hz=f,
            azimuth_rad=self.azimuth_rad[p],
            elevation_rad=self.elevation_rad[p],
            antenna_position_m=None if self.antenna_position_m is None else self.antenna_position_m[p],
            range_to_center_m=None if self.range_to_center_m is None else self.range_to_center_m[p],
            transmit_position_m=None if self.transmit_position_m is None else self.transmit_position_m[p],
            receive_position_m=None if self.receive_position_m is None else self.receive_position_m[p],
        )

    def summary(self) -> dict:
        """Numbers a user wants to see first (used by ``sar info``)."""
        r_rg, r_cr = self.alias_free_radii()
        rho_r, rho_cr = self.resolutions()
        k = self.wavenumbers()
        out = {
            "name": self.name,
            "model": self.model,
            "pulses": self.n_pulses,
            "frequencies": self.n_frequencies,
            "band_hz": [float(self.frequency_hz.min()), float(self.frequency_hz.max())],
            "center_frequency_hz": self.center_frequency_hz,
            "bandwidth_hz": self.bandwidth_hz,
            "elevation_deg": [float(np.degrees(self.elevation_rad.min())),
                              float(np.degrees(self.elevation_rad.max()))],
            "azimuth_deg": [float(np.degrees(self.azimuth_rad.min())),
                            float(np.degrees(self.azimuth_rad.max()))],
            "aperture_deg": float(np.degrees(self.total_aperture_rad())),
            "resolution_m": {"range": rho_r, "cross_range": rho_cr},
            "alias_free_radius_m": {"range": r_rg, "cross_range": r_cr},
            "k_range_rad_per_m": [float(k.min()), float(k.max())],
            "grid": self.grid.as_dict(),
            "grid_extent_m": list(self.grid.extent),
        }
        if self.has_positions:
            out["range_to_center_m"] = [float(self.range_to_center_m.min()),
                                        float(self.range_to_center_m.max())]
            out["farfield_phase_error_rad_at_grid_corner"] = self.farfield_phase_error()
        if self.snr_db is not None:
            out["snr_db"] = self.snr_db
        return out
