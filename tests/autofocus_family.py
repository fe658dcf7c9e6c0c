"""A family of simulated collections with known phase errors, for autofocus (tests and bench).

Each case is one error kind × one scene × one flight path, all simulated by
:func:`sarcli.simulation.simulate` from an acquisition mapping (the YAML schema of
``docs/config.md``), small enough for a test:

- errors (per pulse, constant and linear part removed, seeded): ``smooth`` (four sinusoids of up
  to two cycles over the aperture, scaled to 0.5-1 rad rms), ``white`` (independent per pulse,
  0.2-0.4 rad rms) and ``mixed`` (a smooth error of 0.4-0.8 rad rms plus a white one of
  0.1-0.25);
- scenes: ``points`` (six points of amplitude 0.5-1 within ±4.5 m), ``extended`` (the ``disks``
  phantom with random phases: speckle, no dominant scatterer) and ``mixed`` (five points and a
  weaker disk phantom);
- paths: ``line`` (straight and level), ``circle`` (an arc at constant range) and ``curved``
  (the arc climbing 2° and weaving ±40 m across the track).

Ku band (16 GHz, 300 MHz in 64 frequencies), 30° elevation, 128 pulses over 3° at 8 km, an image
of 96 × 96 pixels of 0.125 m, 30 dB signal-to-noise per sample. :func:`user_case` is a user's
collection rebuilt from its description (Ku band, a straight path at 8 km, 3°, five points and a
disk phantom, a smooth error of 0.65 rad rms, 256 pulses).

A case's seed draws the scene (point positions and amplitudes, the phantom's phases, the noise)
and the error; the tests use seed 0, ``bench/bench_autofocus_family.py`` reports more seeds.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

ERRORS = ("smooth", "white", "mixed")
SCENES = ("points", "extended", "mixed")
PATHS = ("line", "circle", "curved")

#: A residual phase (rad rms) below which an autofocus result counts as reaching the truth.
GOOD_RAD = 0.2


@dataclass
class Case:
    """A collection with a known phase error: ``bad = clean · exp(i error)``."""

    name: str
    clean: object
    bad: object
    error: np.ndarray

    def residual(self, estimate) -> float:
        """rms of ``error - estimate`` (rad), its constant and linear part removed (unobservable)."""
        from sarcli.autofocus import remove_linear_phase

        r = remove_linear_phase(self.error - np.asarray(estimate), self.clean.acquisition.azimuth_rad)
        return float(np.sqrt(np.mean(r ** 2)))

    @property
    def injected(self) -> float:
        return self.residual(np.zeros_like(self.error))


def phase_error(kind: str, P: int, azimuth_rad, rng) -> np.ndarray:
    """A per-pulse phase error of ``kind`` (module docstring), constant and linear part removed."""
    from sarcli.autofocus import remove_linear_phase

    def scaled(e, rms):
        e = remove_linear_phase(e, azimuth_rad)
        return e * rms / np.sqrt(np.mean(e ** 2))

    u = np.linspace(-1.0, 1.0, P)
    smooth = sum(rng.normal(0.0, 1.0 / k) * np.sin(np.pi * k * u + rng.uniform(0, 2 * np.pi)) for k in range(1, 5))
    white = rng.standard_normal(P)
    if kind == "smooth":
        return scaled(smooth, rng.uniform(0.5, 1.0))
    if kind == "white":
        return scaled(white, rng.uniform(0.2, 0.4))
    if kind == "mixed":
        return scaled(smooth, rng.uniform(0.4, 0.8)) + scaled(white, rng.uniform(0.1, 0.25))
    raise ValueError(f"unknown error kind {kind!r}; choose one of {', '.join(ERRORS)}")


def _points(rng, n, half, amp=(0.5, 1.0)):
    xy = rng.uniform(-half, half, (n, 2))
    a = rng.uniform(*amp, n)
    ph = rng.uniform(0.0, 360.0, n)
    return [{"position_m": [float(x), float(y)], "amplitude": {"magnitude": float(m), "phase_deg": float(p)}}
            for (x, y), m, p in zip(xy, a, ph)]


def _scene(kind: str, rng) -> dict:
    if kind == "points":
        return {"points": _points(rng, 6, 4.5)}
    disks = {"name": "disks", "half_width_m": 5.5, "random_phase": True}
    if kind == "extended":
        return {"phantom": {**disks, "amplitude": 0.3}}
    if kind == "mixed":
        return {"points": _points(rng, 5, 4.5), "phantom": {**disks, "amplitude": float(rng.uniform(0.05, 0.2))}}
    raise ValueError(f"unknown scene {kind!r}; choose one of {', '.join(SCENES)}")


def _geometry(path: str, P: int, standoff: float, extent_deg: float, el_deg: float) -> dict:
    if path in ("line", "circle"):
        return {"path": path, "standoff_range_m": standoff}
    if path == "curved":
        from sarcli.core import geometry

        az = np.radians(np.linspace(-extent_deg / 2, extent_deg / 2, P))
        el = np.radians(el_deg + 2.0 * np.linspace(-1.0, 1.0, P) ** 2)
        pos = geometry.antenna_positions_circle(az, el, standoff)
        # the weave across the track (towards and away from the scene): the pulses stay evenly
        # spread in angle, as a constant pulse rate on a steady ground speed gives
        out = pos[:, :2] / np.linalg.norm(pos[:, :2], axis=1, keepdims=True)
        pos[:, :2] += 40.0 * np.sin(np.linspace(0.0, 2.0 * np.pi, P))[:, None] * out
        return {"path": "positions", "antenna_position_m": pos.tolist()}
    raise ValueError(f"unknown path {path!r}; choose one of {', '.join(PATHS)}")


def _collection(name, error_kind, scene, path, seed, P=128, M=64, pixels=96, half_width=6.0):
    from sarcli.core.types import PhaseHistory
    from sarcli.io.config import parse_acquisition
    from sarcli.simulation import simulate

    rng = np.random.default_rng([seed, ERRORS.index(error_kind) if error_kind in ERRORS else 9,
                                 SCENES.index(scene) if isinstance(scene, str) else 9, PATHS.index(path)])
    cfg = {"frequencies": {"center_frequency_ghz": 16.0, "bandwidth_mhz": 300.0, "count": M},
           "elevation_deg": 30.0, "azimuths": {"center_deg": 0.0, "extent_deg": 3.0, "count": P},
           "geometry": _geometry(path, P, 8000.0, 3.0, 30.0),
           "image": {"half_width_m": half_width, "pixels": pixels}, "noise": {"snr_db": 30.0},
           "scene": _scene(scene, rng) if isinstance(scene, str) else scene}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # none expected; a family case is not the place to report one
        acq = parse_acquisition(cfg, source=name)
    clean = simulate(acq, seed=int(rng.integers(2 ** 31)))
    err = error_kind(P, acq.azimuth_rad, rng) if callable(error_kind) else phase_error(error_kind, P,
                                                                                       acq.azimuth_rad, rng)
    bad = PhaseHistory(clean.data * np.exp(1j * err)[:, None].astype(clean.data.dtype), clean.acquisition,
                       clean.truth, dict(clean.attrs))
    return Case(name, clean, bad, err)


def family_case(error: str, scene: str, path: str, seed: int = 0) -> Case:
    """One case of the family (module docstring)."""
    return _collection(f"{error} error, {scene} scene, {path} path, seed {seed}", error, scene, path, seed)


def user_case(seed: int = 0) -> Case:
    """A user's collection rebuilt from its description: Ku band, a straight level path at 8 km,
    3° over 256 pulses, five points and a disk phantom of random phases, a smooth error of 0.65
    rad rms (``seed`` draws the points' phases, the phantom's, the noise and the error's shape)."""
    pts = [{"position_m": [0.0, 0.0], "amplitude": 1.0}, {"position_m": [-4.0, 3.0], "amplitude": 0.8},
           {"position_m": [4.5, -2.0], "amplitude": 1.0}, {"position_m": [2.0, 4.5], "amplitude": 0.6},
           {"position_m": [-4.5, -4.0], "amplitude": 0.9}]
    scene = {"points": pts, "phantom": {"name": "disks", "half_width_m": 5.5, "random_phase": True,
                                        "amplitude": 0.1}}

    def smooth(P, az, rng):
        from sarcli.autofocus import remove_linear_phase

        u = np.linspace(-1.0, 1.0, P)
        e = remove_linear_phase(sum(rng.normal(0.0, 1.0 / k) * np.sin(np.pi * k * u + rng.uniform(0, 2 * np.pi))
                                    for k in range(1, 5)), az)
        return e * 0.65 / np.sqrt(np.mean(e ** 2))

    return _collection(f"the user's case (Ku, line, 5 points + disks, smooth 0.65 rad), seed {seed}", smooth,
                       scene, "line", seed, P=256)


def all_cases():
    """``(error, scene, path)`` of every family case."""
    return [(e, s, p) for e in ERRORS for s in SCENES for p in PATHS]
