"""Image quality of point targets: the measured impulse response beside the predicted one.

:func:`image_quality` measures every point target (:func:`sarcli.analysis.ipr.measure_ipr`) and
puts the values predicted from the acquisition (Theorem ``main-theorem``,
:func:`sarcli.analysis.psf.predicted_ipr`) beside them. All outputs are plain JSON types.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import AliasingWarning, SarcliInputError
from .ipr import ISLR_DEFINITION, measure_ipr
from .psf import predicted_ipr

__all__ = ["image_quality", "load_reference", "measure_ipr", "ISLR_DEFINITION"]


# --------------------------------------------------------------------------------------------
# measured beside predicted
# --------------------------------------------------------------------------------------------
def _window_from_parameters(parameters: dict):
    """(kind, nbar, sll_db) recorded by an image former in ``Image.parameters``."""
    par = parameters or {}
    win = par.get("window", "none")
    nbar = par.get("taylor_nbar", par.get("nbar", 4))
    sll = par.get("taylor_sll_db", par.get("sll_db", -35.0))
    if isinstance(win, dict):
        nbar = win.get("nbar", nbar)
        sll = win.get("sll_db", sll)
        win = win.get("kind", win.get("name", "none"))
    return (win or "none"), int(nbar), float(sll)


def _targets(at, truth, x, y):
    """[(name, (x, y), expected |amplitude| or None)] from ``at`` or the truth points in the image."""
    if at is not None:
        pts = np.atleast_2d(np.asarray(at, dtype=np.float64))
        if pts.shape[-1] != 2:
            raise SarcliInputError(f"target positions must be (x, y) pairs, got shape {pts.shape}")
        return [(f"T{i + 1}", (float(p[0]), float(p[1])), None) for i, p in enumerate(pts)]
    if truth is None or np.size(truth.point_position_m) == 0:
        raise SarcliInputError("no targets to measure: give positions (--at X,Y) or a phase history "
                               "whose truth holds point targets")
    out = []
    pos = np.asarray(truth.point_position_m, dtype=np.float64).reshape(-1, 3)
    amp = np.asarray(truth.point_amplitude).reshape(-1)
    for i, (p, a) in enumerate(zip(pos, amp)):
        if x[0] <= p[0] <= x[-1] and y[0] <= p[1] <= y[-1]:
            out.append((f"T{i + 1}", (float(p[0]), float(p[1])), float(abs(a))))
    if not out:
        raise SarcliInputError(f"none of the {len(pos)} truth points lies inside the image "
                               f"(x {x[0]:g}..{x[-1]:g}, y {y[0]:g}..{y[-1]:g} m)")
    return out


def image_quality(img, ph_or_acq, *, at=None, truth=None, window=None, nbar=None, sll_db=None,
                  oversample=8, sidelobe_extent_cells=10.0) -> list[dict]:
    """Measure every point target of an image and put the predicted figures beside them.

    Parameters
    ----------
    img : sarcli.core.types.Image
    ph_or_acq : sarcli.core.types.PhaseHistory or sarcli.core.acquisition.Acquisition
        Geometry (range direction, resolution, prediction) and, for a phase history, the truth
        point targets.
    at : (x, y) or sequence of (x, y), optional
        Target positions (m); default: every truth point inside the image.
    truth : sarcli.core.types.Truth, optional
        Point targets to use instead of those of ``ph_or_acq`` (see :func:`load_reference`).
    window : str or array_like (P, M), optional
        Window of the prediction; default: the one recorded in ``img.parameters`` ('none'
        when absent).
    nbar, sll_db : optional
        Taylor parameters (default: those recorded, else 4 and -35 dB).
    oversample, sidelobe_extent_cells :
        As in :func:`measure_ipr`.

    Returns
    -------
    list of dict
        One per target: ``name``, ``expected_at_m``, ``expected_peak_magnitude`` (|a_s| of the
        truth, the normalised matched filter's peak), the :func:`measure_ipr` result under
        ``measured``, the :func:`sarcli.analysis.psf.predicted_ipr` cut figures under ``predicted``, and
        ``irw_ratio`` = measured / predicted per direction, ``undersampled`` (pixel larger
        than the predicted resolution cell; also an :class:`AliasingWarning`). Plain JSON types.
    """

    acq = getattr(ph_or_acq, "acquisition", ph_or_acq)
    truth = getattr(ph_or_acq, "truth", None) if truth is None else truth
    rec_win, rec_nbar, rec_sll = _window_from_parameters(getattr(img, "parameters", {}))
    window = rec_win if window is None else window
    nbar = rec_nbar if nbar is None else int(nbar)
    sll_db = rec_sll if sll_db is None else float(sll_db)
    x, y = np.asarray(img.x_m, dtype=np.float64), np.asarray(img.y_m, dtype=np.float64)
    targets = _targets(at, truth, x, y)
    pred = predicted_ipr(acq, window=window, nbar=nbar, sll_db=sll_db,
                         sidelobe_extent_cells=sidelobe_extent_cells)
    theta_c = pred["range_direction_rad"]
    rho = (pred["range"].get("cell_m"), pred["cross_range"].get("cell_m"))
    rho = None if None in rho else rho
    keep = ("irw_m", "pslr_db", "islr_db", "first_nulls_m", "resolution_m", "cell_m", "sidelobe_extent_m")
    predicted = {d: {k: pred[d].get(k) for k in keep} for d in ("range", "cross_range")}
    predicted.update(method=pred.get("method"), window=pred["window"], textbook=pred.get("textbook"))
    pixel = max(float(x[1] - x[0]), float(y[1] - y[0]))
    finest = min(c for c in (rho or (np.inf,)))
    undersampled = bool(pixel > finest)
    if undersampled:
        warnings.warn(f"pixel {pixel:.4g} m exceeds the resolution cell {finest:.4g} m of the predicted "
                      "PSF: the image undersamples its main lobe and the measured widths follow the grid",
                      AliasingWarning, stacklevel=2)
    results = []
    for name, pos, amp in targets:
        m = measure_ipr(img.image, x, y, at=pos, range_direction_rad=theta_c, resolution_m=rho,
                        oversample=oversample, sidelobe_extent_cells=sidelobe_extent_cells)
        ratio = {}
        for d in ("range", "cross_range"):
            mi, pi = m[d]["irw_m"], predicted[d]["irw_m"]
            ratio[d] = None if mi is None or not pi else float(mi / pi)
        results.append({"name": name, "expected_at_m": list(pos), "expected_peak_magnitude": amp,
                        "measured": m, "predicted": predicted, "irw_ratio": ratio,
                        "undersampled": undersampled,
                        "image_method": getattr(img, "method", "")})
    return results


def load_reference(path):
    """Geometry and point targets from a YAML acquisition or a phase-history file.

    Parameters
    ----------
    path : str or Path
        ``.yaml``/``.yml``: :func:`sarcli.io.config.load_acquisition`, truth = the scene's points;
        otherwise :func:`sarcli.io.hdf5.read_phase_history`.

    Returns
    -------
    acquisition : Acquisition
    truth : sarcli.core.types.Truth or None
    """
    from pathlib import Path

    from ..core.types import Truth
    from ..io.hdf5 import read_phase_history

    if Path(path).suffix.lower() in (".yaml", ".yml"):
        from ..io.config import load_acquisition
        from ..simulation.scenes import point_targets

        acq = load_acquisition(path)
        pos, amp = point_targets(acq.scene)
        return acq, Truth(point_position_m=np.asarray(pos, dtype=np.float64).reshape(-1, 3),
                          point_amplitude=np.asarray(amp, dtype=np.complex128).reshape(-1))
    ph = read_phase_history(path)
    return ph.acquisition, ph.truth
