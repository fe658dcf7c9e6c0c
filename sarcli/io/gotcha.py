"""Reader for the AFRL GOTCHA volumetric SAR data set (MATLAB ``.mat`` files).

Each file holds one degree of azimuth of one pass and polarisation as a structure ``data`` with
fields (docs/conventions.md "Real data"; AFRL's read-me ``07_Readme.pdf``):

=================  ==========  ===============================================================
``fp``             [M, P]      complex phase history (spherical convention, motion-compensated
                               to ``r0``)
``freq``           [M]         frequencies (Hz)
``x, y, z``        [P]         antenna phase centre (m), scene centre at the origin
``r0``             [P]         range from the antenna to the scene centre (m)
``th``             [P]         azimuth of the *antenna* seen from the scene centre (deg, 0 = +x),
                               so the look azimuth is θ = th + 180°
``phi``            [P]         elevation (deg)
``af.r_correct``   [P]         autofocus range correction (m), HH and VV only
``af.ph_correct``  [P]         autofocus phase correction (rad), HH and VV only
=================  ==========  ===============================================================

The autofocus solution is applied as AFRL's MATLAB scripts do: ``r0 ← r0 + r_correct`` and
``fp ← fp · exp(+i ph_correct)`` (one phase per pulse).

Public API
----------
read_gotcha(paths, *, autofocus=False, grid=None) -> PhaseHistory
gotcha_dir() -> Path                      the local copy of the data set the tests, benchmarks and
                                          scripts use: ``$SARCLI_GOTCHA_DIR``, else
                                          ``../shared/data/gotcha`` beside the repository
gotcha_files(folder=None) -> list[Path]   the pass-1 HH files in that folder (sorted; may be empty)
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..core.acquisition import Acquisition
from ..errors import InputFileError
from ..core.grid import Grid
from ..core.types import PhaseHistory

__all__ = ["read_gotcha", "default_gotcha_grid", "gotcha_dir", "gotcha_files", "GOTCHA_FIELDS",
           "GOTCHA_DIR_ENV", "GOTCHA_PASS_FILES"]

#: Fields of ``data`` every GOTCHA file must have.
GOTCHA_FIELDS = ("fp", "freq", "x", "y", "z", "r0", "th", "phi")
#: Largest frequency disagreement (Hz) tolerated between files that are joined (float32 rounding).
_FREQ_ATOL_HZ = 1.0


#: The environment variable that names a local copy of the GOTCHA data set.
GOTCHA_DIR_ENV = "SARCLI_GOTCHA_DIR"
#: The files of pass 1, HH polarisation, one per degree of azimuth (``glob`` pattern).
GOTCHA_PASS_FILES = "data_3dsar_pass1_az00*_HH.mat"


def gotcha_dir() -> Path:
    """The folder of a local copy of the AFRL GOTCHA data set, for tests, benchmarks and scripts.

    ``$SARCLI_GOTCHA_DIR`` when set and not empty; otherwise ``../shared/data/gotcha`` beside the
    repository that holds this package (the folder may not exist: callers skip or say so).
    The data set is published by AFRL; docs/conventions.md says where.
    """
    folder = os.environ.get(GOTCHA_DIR_ENV)
    if folder:
        return Path(folder)
    return Path(__file__).resolve().parents[3] / "shared" / "data" / "gotcha"


def gotcha_files(folder=None) -> list[Path]:
    """The pass-1 HH files (:data:`GOTCHA_PASS_FILES`) in ``folder`` (default :func:`gotcha_dir`),
    sorted by name, which is by azimuth; an empty list when the folder is absent."""
    folder = gotcha_dir() if folder is None else Path(folder)
    return sorted(folder.glob(GOTCHA_PASS_FILES)) if folder.is_dir() else []


def default_gotcha_grid() -> Grid:
    """The default image grid of imported GOTCHA data: 100 m × 100 m, 0.25 m pixels, centred."""
    return Grid.from_extent(100.0, 0.25)


def _field(path, struct, name, parent="data"):
    """Field ``name`` of a 1 x 1 MATLAB structure loaded with ``struct_as_record=True``."""
    if struct.dtype.names is None or name not in struct.dtype.names:
        raise InputFileError(path, f"not a GOTCHA file: structure '{parent}' has no field '{name}'")
    value = struct[name]
    if value.dtype == object and value.size == 1:
        value = value.reshape(-1)[0]
    return np.asarray(value)


def _load_one(path: Path, autofocus: bool) -> dict:
    """Load and validate one file; return its arrays (pulse-major) in float64 / complex64."""
    import scipy.io

    if not path.exists():
        raise InputFileError(path, "no such file (expected a GOTCHA .mat file)")
    if path.is_dir():
        raise InputFileError(path, "is a directory, expected a GOTCHA .mat file")
    try:
        mat = scipy.io.loadmat(path, squeeze_me=False, struct_as_record=True)
    except (scipy.io.matlab.MatReadError, ValueError, OSError, TypeError, NotImplementedError,
            EOFError, KeyError, IndexError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputFileError(path, f"not a readable MATLAB v5 .mat file ({first})") from None
    if "data" not in mat:
        names = ", ".join(k for k in mat if not k.startswith("__")) or "none"
        raise InputFileError(path, f"not a GOTCHA file: no variable 'data' (variables: {names})")
    data = mat["data"]
    if not isinstance(data, np.ndarray) or data.dtype.names is None or data.size != 1:
        raise InputFileError(path, "not a GOTCHA file: 'data' is not a 1 x 1 structure")
    data = data.reshape(1, 1)
    out = {}
    try:
        fp = np.asarray(_field(path, data, "fp"))
        if fp.ndim != 2 or not np.iscomplexobj(fp):
            raise InputFileError(path, f"field 'data.fp' must be a complex [M, P] matrix, got {fp.dtype} {fp.shape}")
        m, p = fp.shape
        out["fp"] = np.ascontiguousarray(fp.T).astype(np.complex64)
        for name in GOTCHA_FIELDS[1:]:
            v = np.asarray(_field(path, data, name), dtype=np.float64).ravel()
            want = m if name == "freq" else p
            if v.size != want:
                raise InputFileError(path, f"field 'data.{name}' has {v.size} values, expected {want} "
                                     f"to match 'data.fp' {fp.shape}")
            out[name] = v
        if autofocus:
            if "af" not in data.dtype.names:
                raise InputFileError(path, "has no autofocus solution ('data.af'); GOTCHA provides one "
                                     "for HH and VV only: import without --autofocus")
            af = _field(path, data, "af")
            if af.dtype.names is None or af.size != 1:
                raise InputFileError(path, "has no autofocus solution ('data.af'); GOTCHA provides one "
                                     "for HH and VV only: import without --autofocus")
            af = af.reshape(1, 1)
            for name in ("r_correct", "ph_correct"):
                v = np.asarray(_field(path, af, name, "data.af"), dtype=np.float64).ravel()
                if v.size != p:
                    raise InputFileError(path, f"field 'data.af.{name}' has {v.size} values, expected {p}")
                out[name] = v
    except InputFileError:
        raise
    except (TypeError, ValueError) as exc:
        raise InputFileError(path, f"not a GOTCHA file: unexpected field type ({exc})") from None
    arrays = [out[k] for k in GOTCHA_FIELDS[1:]] + [out["fp"].view(np.float32)]
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise InputFileError(path, "holds NaN or Inf values")
    if np.any(out["freq"] <= 0):
        raise InputFileError(path, "field 'data.freq' holds non-positive frequencies")
    return out


def _azimuth_order(starts_deg: np.ndarray) -> np.ndarray:
    """Order of files by starting azimuth, continuing across the 360° → 0° seam."""
    s = np.mod(starts_deg, 360.0)
    if s.size > 1 and s.max() - s.min() > 180.0:
        s = np.where(s < 180.0, s + 360.0, s)
    return np.argsort(s, kind="stable")


def read_gotcha(paths, *, autofocus: bool = False, grid: Grid | None = None) -> PhaseHistory:
    """Read one or more AFRL GOTCHA ``.mat`` files into a spherical-model phase history.

    Parameters
    ----------
    paths : str, Path or sequence of them
        GOTCHA files of one pass and polarisation; they are joined in azimuth order (whatever
        the order given) and must share one frequency list.
    autofocus : bool
        Apply the files' autofocus solution (``r0 + af.r_correct``, ``fp · exp(i af.ph_correct)``).
    grid : Grid, optional
        Default image grid of the acquisition (default :func:`default_gotcha_grid`).

    Returns
    -------
    PhaseHistory
        ``data`` [P, M] complex64; model ``'spherical'``; antenna positions, ``r0``, look azimuth
        ``θ = th + 180°`` (wrapped to (-180°, 180°]) and elevation ``φ = phi`` in radians.

    Raises
    ------
    InputFileError
        A missing, foreign or broken file, a missing field, mismatched sizes, files whose
        frequencies differ, or ``autofocus`` on a file without an autofocus solution.
    """
    items = [paths] if isinstance(paths, (str, Path)) else list(paths)
    if not items:
        raise InputFileError("<none>", "no GOTCHA files given")
    files = [Path(p) for p in items]
    seen = set()
    for f in files:
        key = f.resolve()
        if key in seen:
            raise InputFileError(f, "given twice; each GOTCHA file may appear once")
        seen.add(key)
    loaded = [_load_one(p, autofocus) for p in files]
    order = _azimuth_order(np.array([d["th"][0] for d in loaded]))
    files = [files[i] for i in order]
    loaded = [loaded[i] for i in order]
    freq = loaded[0]["freq"]
    for path, d in zip(files[1:], loaded[1:]):
        if d["freq"].shape != freq.shape or np.max(np.abs(d["freq"] - freq)) > _FREQ_ATOL_HZ:
            raise InputFileError(path, f"its frequencies ({d['freq'].size} from {d['freq'][0]:.6g} Hz) differ "
                                 f"from those of {files[0]} ({freq.size} from {freq[0]:.6g} Hz); only "
                                 "files of one pass with one frequency list can be joined")

    def cat(name):
        return np.concatenate([d[name] for d in loaded])

    data = np.concatenate([d["fp"] for d in loaded], axis=0)
    a = np.column_stack([cat("x"), cat("y"), cat("z")])
    r0 = cat("r0")
    if autofocus:
        r0 = r0 + cat("r_correct")
        data = (data * np.exp(1j * cat("ph_correct"))[:, None]).astype(np.complex64)
    az = np.angle(np.exp(1j * np.radians(cat("th") + 180.0)))
    el = np.radians(cat("phi"))
    names = [f.name for f in files]
    acq = Acquisition(
        frequency_hz=freq, azimuth_rad=az, elevation_rad=el,
        grid=default_gotcha_grid() if grid is None else grid,
        antenna_position_m=a, range_to_center_m=r0, model="spherical",
        name=f"GOTCHA {names[0]}" + (f" .. {names[-1]}" if len(names) > 1 else ""),
        source=", ".join(str(f) for f in files),
        extra={"autofocus": bool(autofocus), "files": [str(f) for f in files]},
    )
    attrs = {"source_format": "AFRL GOTCHA volumetric .mat", "source_files": ", ".join(names),
             "autofocus": int(bool(autofocus))}
    return PhaseHistory(data=data, acquisition=acq, truth=None, attrs=attrs)
