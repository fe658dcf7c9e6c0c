"""One channel of a CPHD signal array, read by rows and decoded into sarcli's convention.

:class:`CphdSignal` is the one reader of CPHD samples: the lazy phase history of
``read_cphd(path, lazy=True)`` is one, and the eager reader reads one whole. A row is decoded in
this order, block by block (never a full-size temporary):

1. storage format to complex (CI2, CI4, CI8 integer I/Q; CF8, CF16 float; CF16 is rounded to
   complex64), times the vector's ``AmpSF`` PVP when the file has one (CPHD: multiply);
2. conjugated when the phase sign used is +1, so that every row follows ``SGN = -1``: a
   scatterer whose time of arrival exceeds the SRP's by ``Δt`` contributes ``exp(-i 2π f Δt)``;
3. a TOA-domain (range-compressed) vector ``s_n`` at ``τ_n = SC0 + n SCSS`` becomes FX samples on
   the DFT grid ``f_k = FX1 + k Δf``, ``Δf = 1 / (N SCSS)``::

       d(f_k) = (1/N) Σ_n s_n exp(-i 2π f_k τ_n)

   (the inverse of range compression ``s(τ) = Σ_k d(f_k) exp(+i 2π f_k τ)``, exact when the
   vector holds the whole compressed response), keeping the bins inside ``[FX1, FX2]``;
4. a residual delay ``δ_p`` (the troposphere left in the data, :mod:`.corrections`) removed:
   ``d(f) exp(+i 2π f δ_p)``, which moves a scatterer's ``Δt`` to ``Δt - δ_p``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import InputFileError
from ..pulses import PulseSource, row_indices

__all__ = ["READ_BLOCK", "CphdSignal", "Decoding", "ToaToFx"]

#: Pulses read from the signal array at a time (in the file's storage format).
READ_BLOCK = 1024
#: Pulses decoded at a time (bounds the complex128 temporaries of AmpSF, TOA-to-FX and delay).
DECODE_BLOCK = 128


@dataclass(frozen=True)
class ToaToFx:
    """What turns TOA-domain vectors into FX samples (step 3 of the module docstring).

    Attributes
    ----------
    toa0_s, toa_step_s : ndarray [n_vectors]
        ``SC0`` and ``SCSS`` of every file vector (first TOA sample and spacing, s).
    fx1_hz : ndarray [n_vectors]
        ``FX1``: the first FX bin kept.
    m_out : int
        FX bins kept per vector (the band ``[FX1, FX2]`` on the DFT grid, the same for all).
    """

    toa0_s: np.ndarray
    toa_step_s: np.ndarray
    fx1_hz: np.ndarray
    m_out: int

    def convert(self, block: np.ndarray, vec: np.ndarray) -> np.ndarray:
        """FX samples ``[len(vec), m_out]`` of TOA rows ``block`` (file vectors ``vec``)."""
        n = block.shape[1]
        tau0, dtau, f0 = self.toa0_s[vec, None], self.toa_step_s[vec, None], self.fx1_hz[vec, None]
        idx = np.arange(n)[None, :]
        # exp(-i 2π f0 n dτ) in cycles reduced mod 1 before the exponential (f0 dτ n reaches 1e4)
        pre = np.exp(-2j * np.pi * np.mod(f0 * dtau * idx, 1.0))
        spec = np.fft.fft(block * pre, axis=1)[:, :self.m_out] / n
        f = f0 + np.arange(self.m_out)[None, :] / (n * dtau)
        return spec * np.exp(-2j * np.pi * np.mod(f * tau0, 1.0))


@dataclass(frozen=True)
class Decoding:
    """How the stored vectors become rows of the phase history (module docstring, steps 1-4).

    Attributes
    ----------
    vectors : ndarray of int or None
        File vectors kept, increasing (None: all).
    amp_sf : ndarray or None
        ``AmpSF`` of every file vector.
    conjugate : bool
        The phase sign used is +1.
    toa : ToaToFx or None
        Set for a TOA-domain channel.
    delay_s : ndarray or None
        Residual delay ``δ_p`` (s) of every file vector, removed from the data.
    fx0_hz, fx_step_hz : ndarray [n_vectors]
        The FX frequencies of every file vector's output samples, ``fx0 + k fx_step``.
    """

    vectors: np.ndarray | None = None
    amp_sf: np.ndarray | None = None
    conjugate: bool = False
    toa: ToaToFx | None = None
    delay_s: np.ndarray | None = None
    fx0_hz: np.ndarray | None = None
    fx_step_hz: np.ndarray | None = None


class CphdSignal(PulseSource):
    """Lazy complex64 ``[P, M]`` view of one channel's signal array in a CPHD file.

    Row ``p`` is file vector ``decoding.vectors[p]`` (vectors with ``SIGNAL = 0`` are left out),
    decoded as the module docstring says. Indexing reads just the rows asked for, through
    sarkit's reader, at most :data:`READ_BLOCK` vectors at a time, and checks them for NaN/Inf; a
    fault found then (a file truncated or changed since it was opened, a NaN) is an
    :class:`~sarcli.errors.InputFileError` naming the file.

    Parameters
    ----------
    path : str or Path
    channel : str
        The channel's identifier.
    n_vectors, n_samples : int
        ``NumVectors`` and ``NumSamples`` of the channel.
    decoding : Decoding, optional
    """

    def __init__(self, path, channel, n_vectors, n_samples, decoding: Decoding | None = None):
        self.channel = str(channel)
        self.n_vectors = int(n_vectors)
        self.n_stored = int(n_samples)
        self.decoding = decoding or Decoding()
        vectors = self.decoding.vectors
        self.vectors = None if vectors is None else np.asarray(vectors, dtype=np.intp)
        rows = self.n_vectors if self.vectors is None else self.vectors.size
        cols = self.n_stored if self.decoding.toa is None else self.decoding.toa.m_out
        super().__init__(path, (rows, int(cols)), np.complex64)

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
                        for c in range(0, n, DECODE_BLOCK):  # complex128 temporaries of DECODE_BLOCK rows
                            m = min(DECODE_BLOCK, n - c)
                            out[o + c:o + c + m] = self._decode(raw[c:c + m], np.arange(start + c, start + c + m))
        except (OSError, ValueError, KeyError, TypeError, IndexError, RuntimeError,
                lxml.etree.LxmlError) as exc:
            msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise InputFileError(self.path, f"truncated or corrupt CPHD file: signal vectors {first}-{last} of "
                                            f"channel '{self.channel}' cannot be read ({msg[:120]})") from None

    def _decode(self, raw, vec: np.ndarray) -> np.ndarray:
        """Steps 1-4 of the module docstring for the stored vectors ``raw`` (file vectors ``vec``).

        A float format without any other step is returned as complex64 (rounded once); the
        others are computed in complex128 and rounded once by the caller's assignment.
        """
        dec = self.decoding
        blk = np.asarray(raw)
        if blk.dtype.names:  # integer I/Q formats
            names = blk.dtype.names
            blk = blk[names[0]].astype(np.float32) + 1j * blk[names[1]].astype(np.float32)
        blk = blk.astype(np.complex64)
        if dec.amp_sf is not None:
            blk = blk * dec.amp_sf[vec, None]
        if dec.conjugate:
            blk = np.conjugate(blk)
        if dec.toa is not None:
            blk = dec.toa.convert(blk.astype(np.complex128), vec)
        if dec.delay_s is not None:
            k = np.arange(blk.shape[1])[None, :]
            f = dec.fx0_hz[vec, None] + k * dec.fx_step_hz[vec, None]
            blk = blk * np.exp(2j * np.pi * np.mod(f * dec.delay_s[vec, None], 1.0))
        return blk
