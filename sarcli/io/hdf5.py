"""Phase-history, image and k-grid files (HDF5), exactly as the file contract (docs/conventions.md) specifies.

Readers validate the whole contract (format, version, datasets, dtypes, shapes, finiteness)
and raise :class:`~sarcli.errors.InputFileError` with one line naming the file and what is wrong;
writers go through a temporary file renamed at the end, so no partial file is ever left.

Public API
----------
read_phase_history(path) -> PhaseHistory
write_phase_history(path, ph)
read_image(path) -> Image
write_image(path, img, dtype=None)
stored_image_dtype(samples_dtype, tolerance=None, complex128=False)
read_kgrid(path) -> KGrid
write_kgrid(path, kgrid)
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from .._util.atomic import atomic_path, open_held
from . import h5output
from .h5output import allocated_dataset, h5_output, write_chunked
from .._version import __version__
from ..core.acquisition import MODELS, Acquisition
from ..core.grid import Grid, derive_grid
from ..core.types import Image, KGrid, PhaseHistory, Truth, to_json
from ..errors import InputFileError

__all__ = [
    "read_phase_history",
    "write_phase_history",
    "read_image",
    "stored_image_dtype",
    "COMPLEX64_TOLERANCE",
    "write_image",
    "read_kgrid",
    "write_kgrid",
    "PH_FORMAT",
    "IMAGE_FORMAT",
]

PH_FORMAT = "sarcli-phase-history"
IMAGE_FORMAT = "sarcli-image"
KGRID_FORMAT = "sarcli-kgrid"
FILE_VERSION = 1


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------
def _open(path, kind: str) -> h5py.File:
    p = Path(path)
    if not p.exists():
        raise InputFileError(path, f"no such file (expected a {kind} HDF5 file)")
    if p.is_dir():
        raise InputFileError(path, f"is a directory, expected a {kind} HDF5 file")
    try:
        return h5py.File(p, "r")
    except OSError as exc:
        raise InputFileError(path, f"not a readable HDF5 file ({str(exc).splitlines()[0]})") from None


def _attr_str(f, name):
    v = f.attrs.get(name)
    if isinstance(v, bytes):
        v = v.decode()
    return v


def _check_format(path, f, expected):
    fmt = _attr_str(f, "format")
    if fmt != expected:
        raise InputFileError(path, f"root attribute 'format' is {fmt!r}, expected {expected!r}")
    ver = f.attrs.get("version")
    try:
        ver = int(ver)
    except (TypeError, ValueError):
        raise InputFileError(path, f"root attribute 'version' is {ver!r}, expected an integer") from None
    if ver != FILE_VERSION:
        raise InputFileError(path, f"{expected} version {ver} is not supported (this sarcli reads {FILE_VERSION})")


def _write_attrs(f, attrs, *, skip=()):
    """Further root attributes: plain values as they are, anything else as JSON."""
    for k, v in attrs.items():
        if k not in skip:
            f.attrs[k] = v if isinstance(v, (str, int, float, np.number)) else to_json(v)


def _dataset(path, f, name, *, kind, ndim, shape=None, required=True, finite=True):
    if name not in f:
        if required:
            raise InputFileError(path, f"missing dataset '{name}'")
        return None
    obj = f[name]
    if not isinstance(obj, h5py.Dataset):
        raise InputFileError(path, f"'{name}' is not a dataset")
    try:
        arr = obj[()]
    except (OSError, KeyError) as exc:
        raise InputFileError(path, f"dataset '{name}' cannot be read (truncated or corrupt file: {exc})") from None
    arr = np.asarray(arr)
    dims = ndim if isinstance(ndim, tuple) else (ndim,)
    if arr.ndim not in dims:
        raise InputFileError(path, f"dataset '{name}' has {arr.ndim} dimensions, expected {' or '.join(map(str, dims))}")
    if kind == "complex" and not np.iscomplexobj(arr):
        raise InputFileError(path, f"dataset '{name}' has dtype {arr.dtype}, expected complex64 or complex128")
    if kind == "float" and not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise InputFileError(path, f"dataset '{name}' has dtype {arr.dtype}, expected float64")
    if shape is not None:
        for axis, n in enumerate(shape):
            if n is not None and arr.shape[axis] != n:
                raise InputFileError(path, f"dataset '{name}' has shape {arr.shape}, expected {tuple('*' if s is None else s for s in shape)}")
    if finite and arr.size and not np.all(np.isfinite(arr)):
        bad = int(np.size(arr) - np.count_nonzero(np.isfinite(arr)))
        raise InputFileError(path, f"dataset '{name}' holds {bad} NaN/Inf values")
    return arr


# --------------------------------------------------------------------------------------------
# phase history
# --------------------------------------------------------------------------------------------
def write_phase_history(path, ph: PhaseHistory, *, blocks=None) -> Path:
    """Write a phase history file (atomic: a temporary name renamed at the end).

    Parameters
    ----------
    path : str or Path
    ph : PhaseHistory
    blocks : iterable of (slice, ndarray), optional
        The samples by blocks of pulses, written as they come into a dataset of ``ph.data``'s shape
        and dtype (``ph.data`` then needs only those two); ``ph.attrs`` is written after the last
        block, so a producer may add to it (:func:`sarcli.simulation.simulate_file`).

    Returns
    -------
    Path
    """
    acq = ph.acquisition
    nbytes = int(np.prod(ph.data.shape)) * np.dtype(ph.data.dtype).itemsize
    if ph.truth is not None and ph.truth.scene is not None:
        nbytes += 3 * np.asarray(ph.truth.scene).nbytes
    nbytes += 8 * sum(np.size(a) for a in (acq.frequency_hz, acq.azimuth_rad, acq.elevation_rad, acq.antenna_position_m,
                                           acq.range_to_center_m, acq.transmit_position_m, acq.receive_position_m)
                      if a is not None) + len(acq.config_text or "")
    with atomic_path(path) as tmp:
        with h5_output(tmp, nbytes) as f:
            f.attrs["format"] = PH_FORMAT
            f.attrs["version"] = FILE_VERSION
            f.attrs["model"] = acq.model
            f.attrs["sarcli_version"] = __version__
            f.attrs["name"] = acq.name or ""
            if acq.config_text is not None:
                f.attrs["config_yaml"] = acq.config_text
            if acq.source is not None:
                f.attrs["config_source"] = str(acq.source)
            if acq.snr_db is not None:
                f.attrs["snr_db"] = float(acq.snr_db)
            if h5output.in_place(nbytes):   # the samples by our own writes, into space HDF5 allocates
                _samples_in_place(tmp, f, ph.data, blocks)
            elif blocks is None:
                f.create_dataset("phase_history", data=ph.data)
            else:
                dset = f.create_dataset("phase_history", shape=ph.data.shape, dtype=ph.data.dtype)
                for rows, block in blocks:
                    dset[rows] = block
            _write_attrs(f, ph.attrs, skip=("format", "version", "model", "autofocus_phase_rad", "autofocus_method"))
            f.create_dataset("frequency_hz", data=np.asarray(acq.frequency_hz, np.float64))
            f.create_dataset("azimuth_rad", data=np.asarray(acq.azimuth_rad, np.float64))
            f.create_dataset("elevation_rad", data=np.asarray(acq.elevation_rad, np.float64))
            if acq.antenna_position_m is not None:
                f.create_dataset("antenna_position_m", data=np.asarray(acq.antenna_position_m, np.float64))
                f.create_dataset("range_to_center_m", data=np.asarray(acq.range_to_center_m, np.float64))
            if acq.transmit_position_m is not None:
                f.create_dataset("transmit_position_m", data=np.asarray(acq.transmit_position_m, np.float64))
                f.create_dataset("receive_position_m", data=np.asarray(acq.receive_position_m, np.float64))
            af = ph.attrs.get("autofocus_phase_rad") if isinstance(ph.attrs, dict) else None
            if af is not None:
                g_af = f.create_group("autofocus")
                g_af.create_dataset("phase_rad", data=np.asarray(af, np.float64))
                g_af.attrs["method"] = str(ph.attrs.get("autofocus_method", ""))
            g = f.create_group("grid")
            for k, v in acq.grid.as_dict().items():
                g.attrs[k] = v
            if ph.truth is not None:
                t = f.create_group("truth")
                t.create_dataset("point_position_m", data=np.asarray(ph.truth.point_position_m, np.float64).reshape(-1, 3))
                t.create_dataset("point_amplitude", data=np.asarray(ph.truth.point_amplitude, np.complex128).reshape(-1))
                if ph.truth.scene is not None:
                    t.create_dataset("scene", data=ph.truth.scene, compression="gzip", shuffle=True)
                    t.create_dataset("x_m", data=np.asarray(ph.truth.x_m, np.float64))
                    t.create_dataset("y_m", data=np.asarray(ph.truth.y_m, np.float64))
                    if ph.truth.magnitude is not None:
                        t.create_dataset("magnitude", data=np.asarray(ph.truth.magnitude, np.float64),
                                         compression="gzip", shuffle=True)
    return Path(path)


def _samples_in_place(tmp, f, data, blocks) -> None:
    """Write ``/phase_history`` of the file ``f`` (its temporary path ``tmp``) into space HDF5
    allocates for it, by :func:`~sarcli.io.h5output.write_chunked`: ``blocks`` (pairs of a slice of
    pulses and their samples) as they come, else ``data`` by blocks of rows."""
    dtype = np.dtype(data.dtype)
    offset = allocated_dataset(f, "phase_history", data.shape, dtype)
    row = int(data.shape[1]) * dtype.itemsize
    if blocks is None:
        step = max(1, _CAST_ROWS_BYTES // max(1, row))
        blocks = ((slice(r, r + step), data[r:r + step]) for r in range(0, data.shape[0], step))
    with open_held(tmp, "r+b") as fh:
        for rows, block in blocks:
            write_chunked(fh.fileno(), np.ascontiguousarray(block, dtype=dtype), offset + (rows.start or 0) * row)


def read_phase_history(path, *, truth: bool = True, lazy: bool = False) -> PhaseHistory:
    """Read and validate a phase-history file.

    Parameters
    ----------
    path : str or Path
    truth : bool
        Read ``/truth`` (the simulated scene) too. Image formation and regularisation pass False:
        they never use it, and an extended scene's dense truth can dwarf the data.
    lazy : bool
        Leave the samples on disk: ``data`` is a :class:`sarcli.io.pulses.PulseArray` read by
        blocks of pulses (checked for NaN/Inf as they are read), so formers that work pulse by
        pulse (backprojection, the spherical matched filter) hold one block at a time.

    Raises
    ------
    InputFileError
        Foreign format or version, a missing dataset, a wrong dtype or shape, NaN/Inf,
        non-positive frequencies, or a truncated file; the message names the file and the fault.
    """
    try:
        with _open(path, PH_FORMAT) as f:
            return _read_ph(path, f, truth=truth, lazy=lazy)
    except InputFileError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise InputFileError(path, f"broken phase-history file ({exc})") from None


def _read_ph(path, f, *, truth=True, lazy=False) -> PhaseHistory:
    _check_format(path, f, PH_FORMAT)
    model = _attr_str(f, "model")
    if model not in MODELS:
        raise InputFileError(path, f"root attribute 'model' is {model!r}, expected one of {MODELS}")
    if lazy:
        data = _lazy_samples(path, f, "phase_history")
    else:
        data = _dataset(path, f, "phase_history", kind="complex", ndim=2)
    P, M = data.shape
    if P < 1 or M < 1:
        raise InputFileError(path, f"dataset 'phase_history' is empty (shape {data.shape})")
    freq = _dataset(path, f, "frequency_hz", kind="float", ndim=(1, 2))
    if freq.ndim == 1 and freq.shape != (M,) or freq.ndim == 2 and freq.shape != (P, M):
        raise InputFileError(path, f"dataset 'frequency_hz' has shape {freq.shape}, expected ({M},) or ({P}, {M}) to match 'phase_history' {data.shape}")
    if np.any(freq <= 0):
        raise InputFileError(path, f"dataset 'frequency_hz' holds non-positive values (min {freq.min():g} Hz)")
    az = _dataset(path, f, "azimuth_rad", kind="float", ndim=1, shape=(P,))
    el = _dataset(path, f, "elevation_rad", kind="float", ndim=1, shape=(P,))
    if np.any(np.abs(el) >= np.pi / 2):
        raise InputFileError(path, "dataset 'elevation_rad' holds |φ| >= 90°")
    _check_duplicate_pulses(path, az, el)
    need = model == "spherical"
    pos = _dataset(path, f, "antenna_position_m", kind="float", ndim=2, shape=(P, 3), required=need)
    r0 = _dataset(path, f, "range_to_center_m", kind="float", ndim=1, shape=(P,), required=need or pos is not None)
    tx = _dataset(path, f, "transmit_position_m", kind="float", ndim=2, shape=(P, 3), required=False)
    rcv = _dataset(path, f, "receive_position_m", kind="float", ndim=2, shape=(P, 3),
                   required=tx is not None)
    if rcv is not None and tx is None:
        raise InputFileError(path, "dataset 'receive_position_m' needs 'transmit_position_m' as well")
    if "grid" in f:
        g = f["grid"].attrs
        grid = Grid(int(g["nx"]), int(g["ny"]), float(g["dx"]), float(g["dy"]), float(g["cx"]), float(g["cy"]))
    else:
        grid = _default_grid(freq, az, el)
    attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
    snr = attrs.get("snr_db")
    acq = Acquisition(
        frequency_hz=freq.astype(np.float64), azimuth_rad=az.astype(np.float64),
        elevation_rad=el.astype(np.float64), grid=grid,
        antenna_position_m=None if pos is None else pos.astype(np.float64),
        range_to_center_m=None if r0 is None else r0.astype(np.float64),
        model=model, snr_db=None if snr is None else float(snr), name=str(attrs.get("name", "")),
        source=str(path), config_text=attrs.get("config_yaml"),
        transmit_position_m=None if tx is None else tx.astype(np.float64),
        receive_position_m=None if rcv is None else rcv.astype(np.float64),
    )
    if "autofocus" in f and "phase_rad" in f["autofocus"]:
        attrs["autofocus_phase_rad"] = _dataset(path, f, "autofocus/phase_rad", kind="float", ndim=1, shape=(P,))
        attrs["autofocus_method"] = _attr_str(f["autofocus"], "method") or ""
    read_truth, truth = truth, None
    if read_truth and "truth" in f:
        pp = _dataset(path, f, "truth/point_position_m", kind="float", ndim=2, required=False)
        pa = _dataset(path, f, "truth/point_amplitude", kind="any", ndim=1, required=False)
        if pp is not None and pa is not None and pp.shape[0] != pa.shape[0]:
            raise InputFileError(path, "datasets 'truth/point_position_m' and 'truth/point_amplitude' differ in length")
        scene = _dataset(path, f, "truth/scene", kind="any", ndim=2, required=False)
        tx = ty = mag = None
        if scene is not None:
            tx = _dataset(path, f, "truth/x_m", kind="float", ndim=1, shape=(scene.shape[1],))
            ty = _dataset(path, f, "truth/y_m", kind="float", ndim=1, shape=(scene.shape[0],))
            mag = _dataset(path, f, "truth/magnitude", kind="float", ndim=2, shape=scene.shape, required=False)
        truth = Truth(
            point_position_m=np.zeros((0, 3)) if pp is None else pp,
            point_amplitude=np.zeros(0, complex) if pa is None else pa.astype(np.complex128),
            scene=scene, x_m=tx, y_m=ty, magnitude=mag,
        )
    return PhaseHistory(data=data, acquisition=acq, truth=truth, attrs=attrs)


def _lazy_samples(path, f, name):
    """A :class:`PulseArray` over dataset ``name`` after checking what can be checked unread."""
    from .pulses import PulseArray

    if name not in f:
        raise InputFileError(path, f"missing dataset '{name}'")
    obj = f[name]
    if not isinstance(obj, h5py.Dataset):
        raise InputFileError(path, f"'{name}' is not a dataset")
    if obj.ndim != 2:
        raise InputFileError(path, f"dataset '{name}' has {obj.ndim} dimensions, expected 2")
    if not np.issubdtype(obj.dtype, np.complexfloating):
        raise InputFileError(path, f"dataset '{name}' has dtype {obj.dtype}, expected complex64 or complex128")
    return PulseArray(path, name, obj.shape, obj.dtype)


def _check_duplicate_pulses(path, az, el):
    """Refuse two pulses looking from the same azimuth and elevation (a duplicated pulse)."""
    if az.size < 2:
        return
    key = np.round(np.column_stack([np.mod(az, 2 * np.pi), el]) * 1e12)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 1):
        i = int(first[np.argmax(counts > 1)])
        same = np.flatnonzero(np.all(key == key[i], axis=1))
        raise InputFileError(path, f"pulses {int(same[0])} and {int(same[1])} look from the same azimuth and "
                                   f"elevation ({np.degrees(az[i]):.6g}°, {np.degrees(el[i]):.6g}°): duplicated pulses")


def _default_grid(freq, az, el) -> Grid:
    """A grid derived from the sampling for files written by other tools (no /grid group)."""
    return derive_grid(freq, az, el)


# --------------------------------------------------------------------------------------------
# image
# --------------------------------------------------------------------------------------------
#: Below this tolerance (relative error against the exact matched filter) an image formed from
#: complex64 samples is still stored complex128: complex64 rounds each value by up to 6e-8.
COMPLEX64_TOLERANCE = 1e-6


def stored_image_dtype(samples_dtype, *, tolerance=None, complex128=False) -> np.dtype:
    """The type ``sar form-image`` stores an image in: complex64 when the samples it is formed from
    are complex64 (or narrower) and ``tolerance`` (where given) is at least
    :data:`COMPLEX64_TOLERANCE`, else complex128; ``complex128``: complex128 whatever the samples."""
    narrow = np.dtype(samples_dtype).itemsize <= np.dtype(np.complex64).itemsize
    if complex128 or not narrow or (tolerance is not None and tolerance < COMPLEX64_TOLERANCE):
        return np.dtype(np.complex128)
    return np.dtype(np.complex64)


#: Rows of the image cast and written at once when it is stored in another dtype than it has.
_CAST_ROWS_BYTES = 16 * 2 ** 20


def write_image(path, img: Image, dtype=None) -> Path:
    """Write an image file (atomic). ``parameters`` is stored as a JSON string.

    ``dtype``: complex64 or complex128, the stored type of ``/image`` (default: the image's own);
    an image of another type is cast by blocks of rows as it is written (no whole copy in memory).
    An image above :data:`~sarcli.io.h5output.IN_MEMORY_MAX_BYTES` goes by blocks of rows straight
    into its file's space, allocated by HDF5, by our own writes
    (:func:`~sarcli.io.h5output.write_chunked`).
    """
    data = np.asarray(img.image)
    stored = np.dtype(data.dtype if dtype is None else dtype)
    if stored not in (np.dtype(np.complex64), np.dtype(np.complex128)):
        raise ValueError(f"an image is stored complex64 or complex128, not {stored}")
    step = max(1, _CAST_ROWS_BYTES // max(1, data[:1].nbytes))

    def blocks():
        for r in range(0, data.shape[0], step):
            yield np.ascontiguousarray(data[r:r + step], dtype=stored)

    with atomic_path(path) as tmp:
        nbytes = data.size * stored.itemsize + 8 * (np.size(img.x_m) + np.size(img.y_m)) \
            + 8 * sum(np.size(v) for v in (img.history or {}).values())
        in_place = h5output.in_place(nbytes)
        with h5_output(tmp, nbytes) as f:
            f.attrs["format"] = IMAGE_FORMAT
            f.attrs["version"] = FILE_VERSION
            f.attrs["method"] = img.method
            f.attrs["parameters"] = to_json(img.parameters)
            f.attrs["runtime_s"] = float(img.runtime_s)
            f.attrs["sarcli_version"] = __version__
            _write_attrs(f, img.attrs, skip=("format", "version", "method", "parameters", "runtime_s"))
            if in_place:
                offset = allocated_dataset(f, "image", data.shape, stored)
            elif data.dtype == stored:
                f.create_dataset("image", data=data)
            else:
                ds = f.create_dataset("image", shape=data.shape, dtype=stored)
                for r, block in zip(range(0, data.shape[0], step), blocks()):
                    ds[r:r + step] = block
            f.create_dataset("x_m", data=np.asarray(img.x_m, np.float64))
            f.create_dataset("y_m", data=np.asarray(img.y_m, np.float64))
            if img.history:
                h = f.create_group("history")
                for k, v in img.history.items():
                    h.create_dataset(k, data=np.asarray(v, np.float64))
        if in_place:
            with open_held(tmp, "r+b") as fh:
                for block in blocks():
                    offset = write_chunked(fh.fileno(), block, offset)
    return Path(path)


def read_image(path) -> Image:
    """Read and validate an image file."""
    try:
        with _open(path, IMAGE_FORMAT) as f:
            _check_format(path, f, IMAGE_FORMAT)
            im = _dataset(path, f, "image", kind="complex", ndim=2, finite=False)
            x = _dataset(path, f, "x_m", kind="float", ndim=1, shape=(im.shape[1],))
            y = _dataset(path, f, "y_m", kind="float", ndim=1, shape=(im.shape[0],))
            if x.size > 1 and np.any(np.diff(x) <= 0) or y.size > 1 and np.any(np.diff(y) <= 0):
                raise InputFileError(path, "datasets 'x_m'/'y_m' must be increasing")
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
            try:
                params = json.loads(attrs.get("parameters", "{}"))
            except json.JSONDecodeError:
                raise InputFileError(path, "root attribute 'parameters' is not valid JSON") from None
            history = None
            if "history" in f:
                history = {k: np.asarray(v[()]) for k, v in f["history"].items()}
            return Image(image=im, x_m=x, y_m=y, method=str(attrs.get("method", "")),
                         parameters=params, runtime_s=float(attrs.get("runtime_s", 0.0)),
                         history=history, attrs=attrs)
    except InputFileError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise InputFileError(path, f"broken image file ({exc})") from None


# --------------------------------------------------------------------------------------------
# k-grid (the polar format algorithm's Cartesian samples)
# --------------------------------------------------------------------------------------------
def write_kgrid(path, kgrid: KGrid) -> Path:
    """Write a k-grid (format ``sarcli-kgrid``, version 1), atomically."""
    with atomic_path(path) as tmp, h5_output(tmp, np.size(kgrid.samples) * 16) as h5:
        h5.attrs["format"] = KGRID_FORMAT
        h5.attrs["version"] = FILE_VERSION
        h5.create_dataset("samples", data=np.asarray(kgrid.samples, dtype=np.complex128))
        for name in ("kx0", "ky0", "dkx", "dky", "weights_sum"):
            h5.attrs[name] = float(getattr(kgrid, name))
        h5.attrs["kc"] = np.asarray(kgrid.kc, dtype=np.float64)
        h5.attrs["parameters"] = json.dumps(kgrid.parameters)
    return Path(path)


def read_kgrid(path) -> KGrid:
    """Read a k-grid; a missing, broken or foreign file raises :class:`InputFileError`."""
    try:
        with _open(path, KGRID_FORMAT) as h5:
            fmt = _attr_str(h5, "format")
            if fmt != KGRID_FORMAT:
                raise InputFileError(path, f"not a k-grid file (format {fmt!r}, expected {KGRID_FORMAT!r})")
            version = int(h5.attrs.get("version", -1))
            if version != FILE_VERSION:
                raise InputFileError(path, f"k-grid version {version} is not supported (expected {FILE_VERSION})")
            samples = h5["samples"][()]
            attrs = {n: float(h5.attrs[n]) for n in ("kx0", "ky0", "dkx", "dky", "weights_sum")}
            kc = tuple(float(v) for v in h5.attrs["kc"])
            parameters = json.loads(h5.attrs["parameters"])
    except InputFileError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise InputFileError(path, f"cannot read k-grid: {exc}") from exc
    if samples.ndim != 2 or not np.iscomplexobj(samples):
        raise InputFileError(path, f"k-grid samples must be a complex 2-D array, got {samples.dtype} {samples.shape}")
    for key in ("kernel", "width", "pixel_m", "shape", "center_m", "n_fft"):
        if key not in parameters:
            raise InputFileError(path, f"k-grid parameters lack {key!r}")
    return KGrid(samples.astype(np.complex128), kc=kc, parameters=parameters, **attrs)
