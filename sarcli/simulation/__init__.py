"""Simulated collections: point targets in closed form and extended scenes synthesised on a fine
grid, far-field or exact spherical wavefront (:func:`simulate`)."""

from .simulator import simulate

__all__ = ["simulate"]
