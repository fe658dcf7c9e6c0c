"""A phase history left on disk and read in blocks of pulses.

:class:`PulseSource` stands in for the ``[P, M]`` sample array of a
:class:`~sarcli.core.types.PhaseHistory`: it has ``shape``, ``dtype`` and ``ndim``, and indexing it
with a slice of pulses reads just those rows from the file (checked for NaN/Inf as they arrive).
Formers that visit the pulses in blocks (backprojection, ffbp, the spherical matched filter)
therefore hold one block at a time, so their peak memory does not grow with the pulse count;
formers that need every sample at once (NUFFT, PFA) call ``np.asarray`` and read it whole.

Two sources exist: :class:`PulseArray` (a dataset of a sarcli HDF5 phase history) and
:class:`sarcli.io.cphd.CphdSignal` (one channel of a CPHD signal array).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputFileError

__all__ = ["PulseSource", "PulseArray", "as_samples", "pulse_blocks", "row_indices"]

#: Pulses read per block by :func:`pulse_blocks` when the caller does not say.
DEFAULT_BLOCK = 64


class PulseSource:
    """Lazy ``[P, M]`` array of complex samples whose rows (pulses) are read on demand.

    A subclass says how rows are read (:meth:`_read`) and what it reads (:meth:`_what`, for
    messages); this class gives the array interface and checks every block it returns for
    NaN/Inf, raising :class:`~sarcli.errors.InputFileError` naming the file.

    Parameters
    ----------
    path : str or Path
    shape : (int, int)
    dtype : numpy dtype
    """

    ndim = 2

    def __init__(self, path, shape, dtype):
        self.path = Path(path)
        self.shape = tuple(int(n) for n in shape)
        self.dtype = np.dtype(dtype)

    @property
    def size(self) -> int:
        return self.shape[0] * self.shape[1]

    @property
    def nbytes(self) -> int:
        return self.size * self.dtype.itemsize

    def __len__(self) -> int:
        return self.shape[0]

    def _what(self) -> str:
        """What is read, for messages (``"dataset 'phase_history'"``)."""
        raise NotImplementedError

    def _read(self, key) -> np.ndarray:
        """The samples ``self[key]`` as an in-memory array (errors as InputFileError)."""
        raise NotImplementedError

    def __getitem__(self, key) -> np.ndarray:
        return self._checked(self._read(key), key)

    def read_into(self, rows: slice, out: np.ndarray) -> np.ndarray:
        """Read the pulses of slice ``rows`` into ``out`` (shape ``[len(rows), M]``, this dtype), checked.

        A former reading block after block passes the same buffer each time, so no block's array is
        allocated anew. Returns ``out``.
        """
        self._read_into(rows, out)
        return self._checked(out, rows)

    def _read_into(self, rows: slice, out: np.ndarray) -> None:
        """Fill ``out`` with pulses ``rows`` (a subclass may read straight into it)."""
        out[...] = self._read(rows)

    def _checked(self, block, key):
        """``block`` after checking it for NaN/Inf: a sum in float64 (no temporary array) is finite
        when every sample is; only when it is not are the bad samples counted."""
        if block.size and not np.isfinite(np.sum(block.real, dtype=np.float64) + np.sum(block.imag, dtype=np.float64)):
            bad = int(block.size - np.count_nonzero(np.isfinite(block)))
            if bad:
                raise InputFileError(self.path, f"{self._what()} holds {bad} NaN/Inf values (in rows {_describe(key)})")
        return block

    def __array__(self, dtype=None, copy=None):
        whole = self[()]
        return whole if dtype is None else whole.astype(dtype, copy=False)


class PulseArray(PulseSource):
    """Lazy ``[P, M]`` view of an HDF5 dataset of complex samples.

    Parameters
    ----------
    path : str or Path
    name : str
        Dataset path inside the file (``'phase_history'``).
    shape : (int, int)
    dtype : numpy dtype

    Examples
    --------
    >>> import h5py, tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "d.h5"
    >>> with h5py.File(p, "w") as f:
    ...     _ = f.create_dataset("d", data=np.arange(12).reshape(4, 3) + 0j)
    >>> a = PulseArray(p, "d", (4, 3), np.complex128)
    >>> a[1:3].real.tolist()
    [[3.0, 4.0, 5.0], [6.0, 7.0, 8.0]]
    """

    def __init__(self, path, name, shape, dtype):
        super().__init__(path, shape, dtype)
        self.name = str(name)

    def __repr__(self) -> str:
        return f"PulseArray({str(self.path)!r}, {self.name!r}, shape={self.shape}, dtype={self.dtype})"

    def _what(self) -> str:
        return f"dataset '{self.name}'"

    def _read(self, key) -> np.ndarray:
        import h5py

        try:
            with h5py.File(self.path, "r") as f:
                return np.asarray(f[self.name][key])
        except (OSError, KeyError, ValueError, TypeError) as exc:
            raise InputFileError(self.path, f"dataset '{self.name}' cannot be read ({exc})") from None

    def _read_into(self, rows: slice, out: np.ndarray) -> None:
        import h5py

        try:
            with h5py.File(self.path, "r") as f:
                dset = f[self.name]
                if out.dtype == dset.dtype and out.flags.c_contiguous:
                    dset.read_direct(out, np.s_[rows.start:rows.stop])
                else:
                    out[...] = dset[rows.start:rows.stop]
        except (OSError, KeyError, ValueError, TypeError) as exc:
            raise InputFileError(self.path, f"dataset '{self.name}' cannot be read ({exc})") from None


def _describe(key) -> str:
    """The rows of an index, for messages."""
    if isinstance(key, tuple) and key:
        key = key[0]
    if isinstance(key, slice):
        return f"{key.start or 0}:{'' if key.stop is None else key.stop}"
    if isinstance(key, tuple) and not key:
        return "all"
    return str(key) if np.ndim(key) == 0 else f"{len(key)} selected"


def row_indices(key, n_rows: int):
    """Split an index of a ``[P, M]`` array into rows and the rest.

    Parameters
    ----------
    key : int, slice, sequence of int or bool, tuple, Ellipsis or ()
    n_rows : int
        ``P``.

    Returns
    -------
    rows : ndarray of intp
        The rows selected, in the order asked for.
    squeeze : bool
        True when ``key`` picked a single row by an integer (the result loses its first axis).
    rest : tuple
        The index of the remaining axis (``()`` for all of it).

    Raises
    ------
    IndexError
        A row outside ``[-P, P)`` or a boolean mask of the wrong length.
    """
    rest = ()
    if isinstance(key, tuple):
        key, rest = (key[0], key[1:]) if key else (slice(None), ())
    if key is Ellipsis:
        key = slice(None)
    if isinstance(key, slice):
        return np.arange(*key.indices(n_rows), dtype=np.intp), False, rest
    idx = np.asarray(key)
    if idx.dtype == bool:
        if idx.shape != (n_rows,):
            raise IndexError(f"boolean index of shape {idx.shape} for {n_rows} rows")
        return np.flatnonzero(idx).astype(np.intp), False, rest
    if not np.issubdtype(idx.dtype, np.integer) or idx.ndim > 1:
        raise IndexError(f"rows must be selected by a slice, integers or a boolean mask, not {key!r}")
    if idx.size and (idx.min() < -n_rows or idx.max() >= n_rows):
        raise IndexError(f"row index out of range for {n_rows} rows")
    rows = np.where(idx < 0, idx + n_rows, idx).astype(np.intp).reshape(-1)
    return rows, idx.ndim == 0, rest


def as_samples(data) -> np.ndarray:
    """The samples as an in-memory array (reads a :class:`PulseSource` whole)."""
    return np.asarray(data)


def pulse_blocks(n_pulses: int, block: int = DEFAULT_BLOCK):
    """Slices of at most ``block`` pulses covering ``range(n_pulses)``."""
    block = max(1, int(block))
    return [slice(b, min(b + block, n_pulses)) for b in range(0, n_pulses, block)]
