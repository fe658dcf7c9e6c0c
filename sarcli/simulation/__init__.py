"""Simulated collections: point targets in closed form and extended scenes synthesised on a fine
grid, far-field or exact spherical wavefront (:func:`simulate`, :func:`simulate_file` by blocks)."""

from .simulator import simulate, simulate_file

__all__ = ["simulate", "simulate_file"]
