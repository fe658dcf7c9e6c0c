"""sarcli: spotlight SAR image formation, regularised reconstruction and accuracy analysis.

Public API (function-first; the ``sar`` CLI only calls these):

- :func:`load_acquisition` — YAML acquisition file -> :class:`Acquisition`
- :func:`simulate` — acquisition -> :class:`PhaseHistory`
- :func:`read_phase_history`, :func:`write_phase_history` — the HDF5 phase-history contract
- :func:`read_image`, :func:`write_image` — the HDF5 image contract
- :func:`open_input` — any file sarcli reads, recognised by its content
- :func:`form_image` — phase history -> :class:`Image` (direct, nufft, pfa, backprojection); with
  ``dem=`` a map image on terrain (:func:`read_dem`: a GeoTIFF of heights)
- :func:`export_image` — an image to GeoTIFF, PNG, SICD or SIDD
- :func:`geolocate`, :func:`pixel_of` — image pixel -> latitude, longitude, height, and back
- :func:`sarcli.regularize.regularize` — phase history -> regularised :class:`Image` (TV, HOTV, ℓ1,
  ptv, Tikhonov; λ chosen automatically by default)

The layers, bottom up (each imports only those below it; ``tests/test_architecture.py`` holds
the ranks and fails on any upward import): :mod:`sarcli.core` (geometry, sampling, acquisition,
grid, windows, data types; no I/O) < :mod:`sarcli.io` (every file format) <
:mod:`sarcli.simulation` < :mod:`sarcli.formers` < :mod:`sarcli.linops` < :mod:`sarcli.solvers` <
:mod:`sarcli.analysis` (measurements of images) < :mod:`sarcli.regularize` (the driver and the
choice of λ) and :mod:`sarcli.autofocus` < :mod:`sarcli.viz` (every figure) < :mod:`sarcli.batch`
(many formations: dask batches, ``sar bench``) < :mod:`sarcli.cli`.

Names and subpackages are imported lazily so ``import sarcli`` stays cheap.
"""

from __future__ import annotations

import importlib

from ._version import __version__

_LAZY = {
    "Acquisition": "core.acquisition",
    "Collection": "core.collection",
    "Grid": "core.grid",
    "resolve_grid": "core.grid",
    "PhaseHistory": "core.types",
    "Image": "core.types",
    "Truth": "core.types",
    "KGrid": "core.types",
    "load_acquisition": "io.config",
    "parse_acquisition": "io.config",
    "read_phase_history": "io.hdf5",
    "write_phase_history": "io.hdf5",
    "read_image": "io.hdf5",
    "write_image": "io.hdf5",
    "open_input": "io",
    "simulate": "simulation.simulator",
    "form_image": "formers.formation",
    "regrid": "formers.formation",
    "geolocate": "io.geolocate",
    "pixel_of": "io.geolocate",
    "read_dem": "io.dem",
    "export_image": "io.export",
}

_SUBPACKAGES = ("core", "io", "simulation", "formers", "linops", "solvers", "regularize", "analysis", "autofocus",
                "batch", "cli", "viz", "errors")

__all__ = ["__version__", *_LAZY]


def __getattr__(name):
    if name in _LAZY:
        module = importlib.import_module(f".{_LAZY[name]}", __name__)
        return getattr(module, name)
    if name in _SUBPACKAGES:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'sarcli' has no attribute {name!r}")


def __dir__():
    return sorted({*__all__, *_SUBPACKAGES})
