"""A phase history left on disk and read in blocks of pulses.

:class:`PulseArray` stands in for the ``[P, M]`` sample array of a
:class:`~sarcli.core.types.PhaseHistory`: it has ``shape``, ``dtype`` and ``ndim``, and indexing it
with a slice of pulses reads just those rows from the HDF5 file (checked for NaN/Inf as they
arrive). Formers that visit the pulses in blocks (backprojection, the spherical matched filter)
therefore hold one block at a time, so their peak memory does not grow with the pulse count;
formers that need every sample at once (NUFFT, PFA) call ``np.asarray`` and read it whole.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputFileError

__all__ = ["PulseArray", "as_samples", "pulse_blocks"]

#: Pulses read per block by :func:`pulse_blocks` when the caller does not say.
DEFAULT_BLOCK = 64


class PulseArray:
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

    ndim = 2

    def __init__(self, path, name, shape, dtype):
        self.path = Path(path)
        self.name = str(name)
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

    def __repr__(self) -> str:
        return f"PulseArray({str(self.path)!r}, {self.name!r}, shape={self.shape}, dtype={self.dtype})"

    def __getitem__(self, key) -> np.ndarray:
        import h5py

        try:
            with h5py.File(self.path, "r") as f:
                block = np.asarray(f[self.name][key])
        except (OSError, KeyError, ValueError, TypeError) as exc:
            raise InputFileError(self.path, f"dataset '{self.name}' cannot be read ({exc})") from None
        if block.size and not np.all(np.isfinite(block)):
            bad = int(block.size - np.count_nonzero(np.isfinite(block)))
            raise InputFileError(self.path, f"dataset '{self.name}' holds {bad} NaN/Inf values (in rows {key})")
        return block

    def __array__(self, dtype=None, copy=None):
        whole = self[()]
        return whole if dtype is None else whole.astype(dtype, copy=False)


def as_samples(data) -> np.ndarray:
    """The samples as an in-memory array (reads a :class:`PulseArray` whole)."""
    return np.asarray(data)


def pulse_blocks(n_pulses: int, block: int = DEFAULT_BLOCK):
    """Slices of at most ``block`` pulses covering ``range(n_pulses)``."""
    block = max(1, int(block))
    return [slice(b, min(b + block, n_pulses)) for b in range(0, n_pulses, block)]
