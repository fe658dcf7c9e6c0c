"""Every file sarcli reads or writes, and one door in: :func:`open_input`.

Formats (each module reads and/or writes one):

========================  ===========================  ========================================
format                    module                       what it holds
========================  ===========================  ========================================
``phase-history``         :mod:`.hdf5`                 sarcli HDF5 phase history (the contract)
``image``                 :mod:`.hdf5`                 sarcli HDF5 complex image
``kgrid``                 :mod:`.hdf5`                 PFA's Cartesian k-space samples
``config``                :mod:`.config`               YAML acquisition parameters
``gotcha``                :mod:`.gotcha`               AFRL GOTCHA ``.mat`` pass files
``cphd``                  :mod:`.cphd`                 CPHD 1.x phase history (sarkit)
``sicd``                  :mod:`.sicd`                 SICD complex image in NITF (sarkit)
``geotiff``               :mod:`.geotiff`              GeoTIFF raster (tifffile)
``png``                   :mod:`.png`                  8-bit picture (written only)
========================  ===========================  ========================================

:func:`detect_format` recognises a file by its first bytes (and, for HDF5, its ``format``
attribute), never by its suffix alone; :func:`open_input` reads it with the matching reader.
Every reader reports a fault the same way: :class:`~sarcli.errors.InputFileError`, one line
naming the file and what is wrong.

The submodules are imported on first use, so ``import sarcli.io`` costs nothing.
"""

from __future__ import annotations

import importlib
from pathlib import Path

from ..errors import InputFileError

__all__ = ["detect_format", "open_input", "FORMATS", "read_phase_history", "write_phase_history",
           "read_image", "write_image", "read_kgrid", "write_kgrid", "load_acquisition", "read_gotcha",
           "read_cphd", "write_cphd", "read_sicd", "write_sicd", "read_geotiff", "write_geotiff",
           "write_png", "export_image", "load_image"]

#: format name -> (module, reader) used by :func:`open_input`
FORMATS = {
    "phase-history": ("hdf5", "read_phase_history"),
    "image": ("hdf5", "read_image"),
    "kgrid": ("hdf5", "read_kgrid"),
    "config": ("config", "load_acquisition"),
    "gotcha": ("gotcha", "read_gotcha"),
    "cphd": ("cphd", "read_cphd"),
    "sicd": ("sicd", "read_sicd"),
    "geotiff": ("geotiff", "read_geotiff"),
}

_LAZY = {
    "read_phase_history": "hdf5", "write_phase_history": "hdf5", "read_image": "hdf5",
    "write_image": "hdf5", "read_kgrid": "hdf5", "write_kgrid": "hdf5",
    "load_acquisition": "config", "parse_acquisition": "config", "read_gotcha": "gotcha",
    "read_cphd": "cphd", "write_cphd": "cphd", "read_sicd": "sicd", "write_sicd": "sicd",
    "read_geotiff": "geotiff", "write_geotiff": "geotiff", "write_png": "png",
    "export_image": "export", "load_image": "export",
}

_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
_HDF5_FORMATS = {"sarcli-phase-history": "phase-history", "sarcli-image": "image", "sarcli-kgrid": "kgrid"}


def _hdf5_format(path: Path) -> str:
    import h5py

    try:
        with h5py.File(path, "r") as f:
            fmt = f.attrs.get("format")
    except OSError as exc:
        raise InputFileError(path, f"not a readable HDF5 file ({str(exc).splitlines()[0]})") from None
    fmt = fmt.decode() if isinstance(fmt, bytes) else fmt
    if fmt in _HDF5_FORMATS:
        return _HDF5_FORMATS[fmt]
    raise InputFileError(path, f"HDF5 file with root attribute 'format' {fmt!r}; sarcli reads "
                               f"{', '.join(map(repr, _HDF5_FORMATS))}")


def detect_format(path) -> str:
    """The format of a file, from its content.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    str
        One of the keys of :data:`FORMATS`.

    Raises
    ------
    InputFileError
        A missing file, a directory, or content sarcli does not read (the message lists what it reads).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "acq.yaml"
    >>> _ = p.write_text("frequencies: {list_ghz: [9.0]}")
    >>> detect_format(p)
    'config'
    """
    p = Path(path)
    if not p.exists():
        raise InputFileError(path, "no such file")
    if p.is_dir():
        raise InputFileError(path, "is a directory, expected a file")
    try:
        with open(p, "rb") as fh:
            head = fh.read(1024)
    except OSError as exc:
        raise InputFileError(path, f"cannot be read ({exc.strerror or exc})") from None
    if head.startswith(_HDF5_MAGIC):
        return _hdf5_format(p)
    if head.startswith(b"MATLAB"):
        return "gotcha"
    if head.startswith(b"CPHD/"):
        return "cphd"
    if head.startswith((b"NITF", b"NSIF")):
        return "sicd"
    if head.startswith((b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")):
        return "geotiff"
    if p.suffix.lower() in (".yaml", ".yml"):
        return "config"
    if head.startswith(b"\x89PNG"):
        raise InputFileError(path, "a PNG picture holds no complex image to read back; use the HDF5 "
                                   "image or a GeoTIFF/SICD export")
    if p.suffix.lower() in (".h5", ".hdf5", ".he5"):  # the name says HDF5, the content does not
        raise InputFileError(path, "not a readable HDF5 file (its first bytes are not an HDF5 signature)")
    readable = "sarcli HDF5 (phase history, image, k-grid), YAML config, GOTCHA .mat, CPHD, SICD, GeoTIFF"
    raise InputFileError(path, f"unrecognised file content; sarcli reads {readable}")


def open_input(path, *, expect=None, truth=True, lazy=False, cphd=None):
    """Read any file sarcli reads, recognised by :func:`detect_format`.

    Parameters
    ----------
    path : str or Path
    expect : str or sequence of str, optional
        The formats the caller can use; any other gives one :class:`InputFileError` line naming
        the format found and those expected.
    truth : bool
        For a sarcli phase history: read ``/truth`` too (False for image formation, which never
        uses it).
    lazy : bool
        For a sarcli phase history or a CPHD file: leave the samples on disk, read by blocks of
        pulses (:class:`sarcli.io.pulses.PulseSource`).
    cphd : dict, optional
        Keyword arguments of :func:`sarcli.io.cphd.read_cphd` (``channel``, ``sgn``,
        ``troposphere``); given for another format, one :class:`InputFileError` line.

    Returns
    -------
    (str, object)
        The format name and what its reader returns: a :class:`~sarcli.core.types.PhaseHistory`
        (phase-history, gotcha, cphd), an :class:`~sarcli.core.types.Image` (image, sicd,
        geotiff), a :class:`~sarcli.core.types.KGrid` or an
        :class:`~sarcli.core.acquisition.Acquisition` (config).
    """
    fmt = detect_format(path)
    if expect is not None:
        allowed = (expect,) if isinstance(expect, str) else tuple(expect)
        if fmt not in allowed:
            article = "an" if fmt[0] in "aeio" else "a"
            raise InputFileError(path, f"is {article} {fmt} file; expected {' or '.join(allowed)}")
    if cphd and fmt != "cphd":
        raise InputFileError(path, f"is {'an' if fmt[0] in 'aeio' else 'a'} {fmt} file: "
                                   f"{', '.join('--' + k for k in cphd)} apply to CPHD input only")
    module, reader = FORMATS[fmt]
    read = getattr(importlib.import_module(f".{module}", __name__), reader)
    if fmt == "gotcha":
        return fmt, read([path])
    if fmt == "phase-history":
        return fmt, read(path, truth=truth, lazy=lazy)
    return fmt, read(path, lazy=lazy, **(cphd or {})) if fmt == "cphd" else read(path)


def __getattr__(name):
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'sarcli.io' has no attribute {name!r}")
