"""How sarcli's HDF5 files reach the disk: small ones built in memory, large ones written in place.

A file of at most :data:`IN_MEMORY_MAX_BYTES` is built in memory and written by our own writes, so
a full disk or a file-size limit is an ordinary OSError (one line, exit 2) instead of a failure
inside HDF5's close, where h5py prints tracebacks from its destructors or crashes. A larger file is
written by HDF5 straight into the temporary file once its space is reserved
(:func:`reserve_space`): a copy in memory would cost as much again in fresh pages as the file
itself; an image's samples go into space HDF5 allocated for them (:func:`allocated_dataset`) by our
own writes (:func:`write_chunked`, :func:`sarcli.io.hdf5.write_image`). The atomic rename of
:func:`sarcli._util.atomic.atomic_path` protects the previous file either way.
"""

from __future__ import annotations

import contextlib
import io
import os

import h5py
import numpy as np

from .._util.atomic import open_held

__all__ = ["IN_MEMORY_MAX_BYTES", "RESERVE_SLACK_BYTES", "WRITE_CHUNK_BYTES", "in_place", "reserved_bytes",
           "reserve_space", "write_chunked", "allocated_dataset", "h5_output"]

#: Files up to this size are built in memory (see the module's docstring); larger ones are written in place.
IN_MEMORY_MAX_BYTES = 16 << 20
#: Bytes :func:`reserve_space` adds to a file's large datasets for the rest of it (HDF5's
#: metadata, attributes, the small datasets), besides 1/64 of the datasets' bytes.
RESERVE_SLACK_BYTES = 4 << 20
#: Bytes of each write call of our own. A buffered write gets file-cache pages of its own size: one
#: large write makes the kernel assemble large blocks of memory, which on a virtual machine whose
#: host backs memory on first use costs 30-45 times what writes of 128 KiB do, those taking single
#: pages (docs/performance.md, "Writing an image").
WRITE_CHUNK_BYTES = 128 << 10


def reserved_bytes(nbytes: int) -> int:
    """The bytes reserved for a file whose large datasets hold ``nbytes``: an upper bound of its size."""
    return int(nbytes) + int(nbytes) // 64 + RESERVE_SLACK_BYTES


def reserve_space(tmp, nbytes: int) -> None:
    """Allocate ``nbytes`` to the file ``tmp`` (``posix_fallocate``; where the system has none, the
    file is extended to that size), so a full disk, a quota or a file-size limit fails here, as one
    :class:`OSError` before HDF5 writes anything. HDF5 then truncates the file as it opens it and
    writes into the space just freed (only another writer filling the disk in that moment can still
    make HDF5 fail, the previous file untouched all the same)."""
    with open_held(tmp) as fh:
        allocate = getattr(os, "posix_fallocate", None)
        if allocate is not None:
            allocate(fh.fileno(), 0, int(nbytes))
        else:   # pragma: no cover - systems without posix_fallocate
            fh.truncate(int(nbytes))


def write_chunked(fd, data, offset: int) -> int:
    """Write the bytes of ``data`` (a buffer) to the file ``fd`` at ``offset`` in calls of
    :data:`WRITE_CHUNK_BYTES`; returns the offset after them. A write that cannot go on (a full
    disk) raises :class:`OSError`."""
    mv = memoryview(data).cast("B")
    done = 0
    while done < mv.nbytes:
        n = os.pwrite(fd, mv[done:done + WRITE_CHUNK_BYTES], offset + done)
        if n <= 0:
            raise OSError(28, os.strerror(28))   # ENOSPC
        done += n
    return offset + done


def allocated_dataset(f, name, shape, dtype) -> int:
    """Create the contiguous dataset ``name`` of ``f`` with its file space allocated at once and never
    filled by HDF5; returns its offset in the file, where :func:`write_chunked` puts its samples."""
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_layout(h5py.h5d.CONTIGUOUS)
    dcpl.set_alloc_time(h5py.h5d.ALLOC_TIME_EARLY)
    dcpl.set_fill_time(h5py.h5d.FILL_TIME_NEVER)
    ds = h5py.h5d.create(f.id, name.encode(), h5py.h5t.py_create(np.dtype(dtype)),
                         h5py.h5s.create_simple(tuple(int(n) for n in shape)), dcpl=dcpl)
    offset = ds.get_offset()
    ds.close()
    return int(offset)


def in_place(nbytes) -> bool:
    """Whether a file whose large datasets hold ``nbytes`` is written in place (not built in memory)."""
    return nbytes > IN_MEMORY_MAX_BYTES


@contextlib.contextmanager
def h5_output(tmp, nbytes):
    """An HDF5 file opened for writing whose bytes end up in ``tmp`` (see the module's docstring);
    ``nbytes``: the bytes of its large datasets."""
    if in_place(nbytes):
        reserve_space(tmp, reserved_bytes(nbytes))
        # created under the clean-up's lock: an interruption between the reservation and this open
        # must not find the file gone and then see HDF5 create it again (a temporary left behind)
        with open_held(tmp, "w", opener=h5py.File) as f:
            yield f
        return
    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        yield f
    with open_held(tmp) as fh:
        write_chunked(fh.fileno(), buf.getbuffer(), 0)
