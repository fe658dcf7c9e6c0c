"""Parts of the CPHD reader (:mod:`sarcli.io.cphd`): the signal array read by rows, and the image grid.

:class:`CphdSignal` is the one reader of CPHD samples: the lazy phase history of
``read_cphd(path, lazy=True)`` is one, and the eager reader reads one whole.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..core.grid import Grid
from ..errors import InputFileError
from .georef import GeometryWarning, ReferencePoint, enu_basis
from .pulses import PulseSource, row_indices

__all__ = ["READ_BLOCK", "AXES_TOLERANCE_RAD", "CphdSignal", "read_signal_blocks", "grid_from_xml"]

#: Pulses read from the signal array at a time (bounds the temporary of integer formats).
READ_BLOCK = 1024
#: Angle (rad) between the file's image-area axes (uIAX, uIAY) and local East/North above which
#: its ImageGrid cannot be used as our east/north-aligned grid (a GeometryWarning says so).
AXES_TOLERANCE_RAD = 1e-6


class CphdSignal(PulseSource):
    """Lazy complex64 ``[P, M]`` view of one channel's signal array in a CPHD file.

    Row ``p`` is file vector ``vectors[p]`` (vectors with ``SIGNAL = 0`` are left out), converted
    from its storage format (CI2, CI4, CI8 integer I/Q or CF8, CF16 float; CF16 is rounded to
    complex64), multiplied by its ``AmpSF`` PVP when the file has one, and conjugated when the
    file's ``SGN`` is +1. Indexing reads just the rows asked for, through sarkit's reader, at most
    :data:`READ_BLOCK` vectors at a time, and checks them for NaN/Inf; a fault found then (a file
    truncated or changed since it was opened, a NaN) is an :class:`~sarcli.errors.InputFileError`
    naming the file.

    Parameters
    ----------
    path : str or Path
    channel : str
        The channel's identifier.
    n_vectors, n_samples : int
        ``NumVectors`` and ``NumSamples`` of the channel.
    vectors : array of int, optional
        File vectors kept, increasing (default: all).
    amp_sf : array of float, optional
        ``AmpSF`` of every file vector.
    conjugate : bool
        The file's ``SGN`` is +1.
    """

    def __init__(self, path, channel, n_vectors, n_samples, *, vectors=None, amp_sf=None, conjugate=False):
        self.channel = str(channel)
        self.n_vectors = int(n_vectors)
        self.vectors = None if vectors is None else np.asarray(vectors, dtype=np.intp)
        self.amp_sf = None if amp_sf is None else np.asarray(amp_sf, dtype=np.float64)
        self.conjugate = bool(conjugate)
        rows = self.n_vectors if self.vectors is None else self.vectors.size
        super().__init__(path, (rows, int(n_samples)), np.complex64)

    def __repr__(self) -> str:
        return f"CphdSignal({str(self.path)!r}, channel={self.channel!r}, shape={self.shape})"

    def _what(self) -> str:
        return f"CPHD signal array (channel '{self.channel}')"

    def _read(self, key) -> np.ndarray:
        rows, squeeze, rest = row_indices(key, self.shape[0])
        out = np.empty((rows.size, self.shape[1]), dtype=np.complex64)
        if rows.size:
            self._read_rows(rows if self.vectors is None else self.vectors[rows], out)
        if squeeze:
            out = out[0]
        return out[(Ellipsis, *rest)] if rest else out

    def _read_rows(self, vec, out):
        """Fill ``out`` with file vectors ``vec``, one sarkit read per run of consecutive vectors."""
        import lxml.etree
        import sarkit.cphd as skcphd

        breaks = np.flatnonzero(np.diff(vec) != 1) + 1
        first, last = int(vec.min()), int(vec.max())
        try:
            with open(self.path, "rb") as f, skcphd.Reader(f) as r:
                for lo, hi in zip(np.r_[0, breaks], np.r_[breaks, vec.size]):
                    for o in range(int(lo), int(hi), READ_BLOCK):
                        n = min(READ_BLOCK, int(hi) - o)
                        start = int(vec[o])
                        raw = r.read_signal(self.channel, start_vector=start, stop_vector=start + n)
                        out[o:o + n] = _to_complex64(raw, None if self.amp_sf is None
                                                     else self.amp_sf[start:start + n])
        except (OSError, ValueError, KeyError, TypeError, IndexError, RuntimeError,
                lxml.etree.LxmlError) as exc:
            msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise InputFileError(self.path, f"truncated or corrupt CPHD file: signal vectors {first}-{last} of "
                                            f"channel '{self.channel}' cannot be read ({msg[:120]})") from None
        if self.conjugate:
            np.conjugate(out, out=out)


def _to_complex64(raw, amp) -> np.ndarray:
    """Stored vectors as complex samples: integer I/Q pairs become float32, AmpSF multiplies.

    The product with ``AmpSF`` is taken in float64 and rounded once to complex64 by the caller's
    assignment.
    """
    blk = np.asarray(raw)
    if blk.dtype.names:  # integer I/Q formats
        names = blk.dtype.names
        blk = blk[names[0]].astype(np.float32) + 1j * blk[names[1]].astype(np.float32)
    blk = blk.astype(np.complex64)
    if amp is not None:
        blk = blk * amp[:, None]
    return blk


def read_signal_blocks(path, channel: str, n_vectors: int, n_samples: int, pvp, *, conjugate=False,
                       lazy=False):
    """The channel's signal as a :class:`CphdSignal` (``lazy``) or a complex64 ``[P, M]`` array.

    Vectors whose ``SIGNAL`` PVP is 0 are left out; an ``AmpSF`` PVP scales each vector (CPHD:
    multiply). Read whole, the array is filled :data:`READ_BLOCK` vectors at a time (no
    full-size temporary of an integer format).
    """
    names = pvp.dtype.names
    vectors = None
    if "SIGNAL" in names and np.any(pvp["SIGNAL"] == 0):
        vectors = np.flatnonzero(pvp["SIGNAL"] != 0)
    src = CphdSignal(path, channel, n_vectors, n_samples, vectors=vectors,
                     amp_sf=pvp["AmpSF"] if "AmpSF" in names else None, conjugate=conjugate)
    return src if lazy else np.asarray(src)


def grid_from_xml(xml, ref: ReferencePoint) -> Grid | None:
    """Our grid from ``SceneCoordinates/ImageGrid`` when its axes are local East and North.

    Our frame is east-north-up at the IARP (CONVENTIONS.md). A planar image area whose
    uIAX/uIAY are East/North (to :data:`AXES_TOLERANCE_RAD`) gives the grid exactly; other axes
    (a rotated or tilted image plane, or a HAE surface) cannot be an east/north-aligned grid, so
    a :class:`~sarcli.io.georef.GeometryWarning` says so and None is returned (the grid is then
    derived from the sampling, east/north aligned and centred on the IARP).
    """
    g = xml.find("{*}SceneCoordinates/{*}ImageGrid")
    if g is None:
        return None
    planar = xml.find("{*}SceneCoordinates/{*}ReferenceSurface/{*}Planar")
    if planar is not None:
        uiax = np.array([float(planar.findtext(f"{{*}}uIAX/{{*}}{c}")) for c in "XYZ"])
        uiay = np.array([float(planar.findtext(f"{{*}}uIAY/{{*}}{c}")) for c in "XYZ"])
        basis = enu_basis(ref)
        ang = max(float(np.arccos(np.clip(uiax @ basis[0] / np.linalg.norm(uiax), -1, 1))),
                  float(np.arccos(np.clip(uiay @ basis[1] / np.linalg.norm(uiay), -1, 1))))
    else:
        ang = np.inf
    if not ang <= AXES_TOLERANCE_RAD:
        what = ("its image area is not planar" if planar is None else
                f"its image-area axes (uIAX, uIAY) are {np.degrees(ang):.4g} deg from East/North")
        warnings.warn(f"CPHD ImageGrid not used: {what}; sarcli images on an east/north-aligned grid "
                      "at the IARP, derived from the sampling (give --extent/--pixel-size to change it)",
                      GeometryWarning, stacklevel=4)
        return None
    dx = float(g.findtext("{*}IAXExtent/{*}LineSpacing"))
    dy = float(g.findtext("{*}IAYExtent/{*}SampleSpacing"))
    nx = int(g.findtext("{*}IAXExtent/{*}NumLines"))
    ny = int(g.findtext("{*}IAYExtent/{*}NumSamples"))
    line0 = float(g.findtext("{*}IARPLocation/{*}Line")) - int(g.findtext("{*}IAXExtent/{*}FirstLine"))
    samp0 = float(g.findtext("{*}IARPLocation/{*}Sample")) - int(g.findtext("{*}IAYExtent/{*}FirstSample"))
    return Grid(nx, ny, dx, dy, (nx // 2 - line0) * dx, (ny // 2 - samp0) * dy)
