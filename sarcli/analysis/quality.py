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


#: Targets whose predicted positions are closer than this many resolution cells (distance
#: normalised by the range and cross-range cells) are flagged ``close``: each is matched to its own
#: peak, but its cuts cross the neighbour's main lobe, so IRW, PSLR and ISLR are not reported.
CLOSE_CELLS = 3.0
#: A peak matches a target predicted from the truth when within this many cells of the prediction
#: (the first sidelobes of a uniform aperture lie 1.43 cells out; with half a pixel of quantisation
#: at two pixels a cell the gate reaches 1.15 cells, so they never match).
MATCH_CELLS = 0.8
#: A peak matches a position given with ``at`` when within this many cells (the user's estimate).
MATCH_CELLS_AT = 3.0


def _targets(at, truth, x, y, acq):
    """[(name, truth (x, y, z) or None, expected image (x, y), |amplitude| or None)].

    Positions given with ``at`` are where the peaks are expected in the image. Truth points are
    moved to where they focus in the image plane (:func:`sarcli.core.geometry.image_plane_position`:
    the layover of points off the plane) and kept when that lies inside the image.
    """
    from ..core.geometry import image_plane_position

    if at is not None:
        pts = np.atleast_2d(np.asarray(at, dtype=np.float64))
        if pts.shape[-1] != 2:
            raise SarcliInputError(f"target positions must be (x, y) pairs, got shape {pts.shape}")
        return [(f"T{i + 1}", None, (float(p[0]), float(p[1])), None) for i, p in enumerate(pts)]
    if truth is None or np.size(truth.point_position_m) == 0:
        raise SarcliInputError("no targets to measure: give positions (--at X,Y) or a phase history "
                               "whose truth holds point targets")
    pos = np.asarray(truth.point_position_m, dtype=np.float64).reshape(-1, 3)
    amp = np.asarray(truth.point_amplitude).reshape(-1)
    spherical = acq.model == "spherical" and acq.has_positions
    tx, rcv = (None, None)
    if spherical:
        tx, rcv, _ = acq.range_geometry()
        rcv = rcv if acq.is_bistatic else None
    focus = image_plane_position(pos, model="spherical" if spherical else "farfield", antenna_position_m=tx,
                                 range_to_center_m=acq.range_to_center_m, receive_position_m=rcv)
    out = []
    for i, (p, f, a) in enumerate(zip(pos, focus, amp)):
        if x[0] <= f[0] <= x[-1] and y[0] <= f[1] <= y[-1]:
            out.append((f"T{i + 1}", tuple(float(v) for v in p), (float(f[0]), float(f[1])), float(abs(a))))
    if not out:
        raise SarcliInputError(f"none of the {len(pos)} truth points lies inside the image "
                               f"(x {x[0]:g}..{x[-1]:g}, y {y[0]:g}..{y[-1]:g} m)")
    return out


def _cells(dxy, theta_c, rho):
    """Distance in resolution cells of offsets ``dxy`` (..., 2): range along ξ_θc, cross-range across."""
    dxy = np.asarray(dxy, dtype=np.float64)
    u = np.array([np.cos(theta_c), np.sin(theta_c)])
    v = np.array([-u[1], u[0]])
    return np.hypot(dxy @ u / rho[0], dxy @ v / rho[1])


def _match_peaks(image, x, y, expected, theta_c, rho, *, by_brightness):
    """One image peak per target, none used twice: ``[(row, col) or None]`` in target order.

    Peaks are the local maxima of ``|f|`` (3 x 3 neighbourhoods); a target's candidates lie within
    :data:`MATCH_CELLS` (``by_brightness``: :data:`MATCH_CELLS_AT`) resolution cells of its expected
    position. The assignment minimises the total distance in cells (``by_brightness``: prefers the
    brightest peaks) over all targets at once (:func:`scipy.optimize.linear_sum_assignment`).
    """
    from scipy import ndimage
    from scipy.optimize import linear_sum_assignment

    mag = np.abs(np.asarray(image))
    peak = (mag == ndimage.maximum_filter(mag, size=3, mode="nearest")) & (mag > 0)
    rows, cols = np.nonzero(peak)
    if rows.size == 0:
        return [None] * len(expected)
    xy = np.stack([x[cols], y[rows]], axis=1)
    exp = np.asarray(expected, dtype=np.float64).reshape(-1, 2)
    gate = MATCH_CELLS_AT if by_brightness else MATCH_CELLS
    # half a pixel of slack: the peak pixel is up to half a pixel from the true peak
    slack = 0.5 * np.hypot(x[1] - x[0], y[1] - y[0]) / min(rho)
    d = _cells(xy[None, :, :] - exp[:, None, :], theta_c, rho)  # (T, K)
    near = d <= gate + slack
    keep = np.any(near, axis=0)
    d, near = d[:, keep], near[:, keep]
    rows, cols, mags = rows[keep], cols[keep], mag[rows[keep], cols[keep]]
    out = [None] * len(exp)
    if rows.size == 0:
        return out
    cost = d.copy()
    if by_brightness:
        cost = d / (gate + slack) - 10.0 * np.log10(mags / mags.max())[None, :]
    big = 1e6
    ti, ki = linear_sum_assignment(np.where(near, cost, big))
    for t, k in zip(ti, ki):
        if near[t, k]:
            out[t] = (int(rows[k]), int(cols[k]))
    return out


def image_quality(img, ph_or_acq, *, at=None, truth=None, window=None, nbar=None, sll_db=None,
                  oversample=8, sidelobe_extent_cells=10.0) -> list[dict]:
    """Measure every point target of an image and put the predicted figures beside them.

    Each target is matched to its own peak of the image (one to one, no peak used twice; see
    :func:`_match_peaks`), expected where the geometry focuses it: a truth point off the image plane
    (z ≠ 0) lies over by its layover (:func:`sarcli.core.geometry.image_plane_position`). Targets
    closer than :data:`CLOSE_CELLS` resolution cells to another are flagged ``close``: their
    positions and peaks are measured, their cut figures (IRW, PSLR, ISLR) are not.

    Parameters
    ----------
    img : sarcli.core.types.Image
    ph_or_acq : sarcli.core.types.PhaseHistory or sarcli.core.acquisition.Acquisition
        Geometry (range direction, resolution, prediction, layover) and, for a phase history, the
        truth point targets.
    at : (x, y) or sequence of (x, y), optional
        Expected peak positions (m) in the image; default: every truth point that focuses inside
        the image.
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
        One per target: ``name``, ``status`` (``ok``; ``close``: another target within
        :data:`CLOSE_CELLS` cells, named in ``neighbour`` with ``neighbour_cells``; ``no peak``: no
        peak of its own within reach, e.g. merged with a neighbour's), ``truth_at_m`` (x, y, z of
        the truth point, None for ``at``), ``expected_at_m`` (where it should focus),
        ``layover_m`` (expected minus truth x, y), ``expected_peak_magnitude`` (|a_s| of the
        truth, the normalised matched filter's peak), ``measured`` (the :func:`measure_ipr` result
        at its peak, with ``requested_at_m`` = ``expected_at_m`` and ``peak_position_error_m`` the
        distance between the two; None for ``no peak``), ``predicted`` (the
        :func:`sarcli.analysis.psf.predicted_ipr` cut figures), ``irw_ratio`` = measured /
        predicted per direction, ``undersampled`` (pixel larger than the predicted resolution
        cell; also an :class:`AliasingWarning`). Plain JSON types.
    """

    acq = getattr(ph_or_acq, "acquisition", ph_or_acq)
    truth = getattr(ph_or_acq, "truth", None) if truth is None else truth
    x, y = np.asarray(img.x_m, dtype=np.float64), np.asarray(img.y_m, dtype=np.float64)
    targets = _targets(at, truth, x, y, acq)
    theta_c, rho, predicted = _predicted(acq, img, (window, nbar, sll_db), sidelobe_extent_cells)
    pixel = max(float(x[1] - x[0]), float(y[1] - y[0]))
    undersampled = _undersampled(pixel, rho)
    cells = rho or (4 * pixel, 4 * pixel)
    expected = np.array([t[2] for t in targets])
    sep = _cells(expected[:, None, :] - expected[None, :, :], theta_c, cells)
    np.fill_diagonal(sep, np.inf)
    peaks = _match_peaks(img.image, x, y, expected, theta_c, cells, by_brightness=at is not None)
    ipr_options = dict(range_direction_rad=theta_c, resolution_m=rho, oversample=oversample,
                       search_radius_m=0.75 * np.hypot(x[1] - x[0], y[1] - y[0]),
                       sidelobe_extent_cells=sidelobe_extent_cells)
    results = []
    for (name, p3, pos, amp), pk, row in zip(targets, peaks, sep):
        j = int(np.argmin(row)) if row.size > 1 else None
        close = j is not None and row[j] < CLOSE_CELLS
        status = "no peak" if pk is None else ("close" if close else "ok")
        m, ratio = _measured(img, pk, pos, close, predicted, ipr_options)
        results.append({"name": name, "status": status,
                        "neighbour": targets[j][0] if close else None,
                        "neighbour_cells": float(row[j]) if close else None,
                        "truth_at_m": None if p3 is None else list(p3),
                        "expected_at_m": list(pos),
                        "layover_m": None if p3 is None else [pos[0] - p3[0], pos[1] - p3[1]],
                        "expected_peak_magnitude": amp,
                        "measured": m, "predicted": predicted, "irw_ratio": ratio,
                        "undersampled": undersampled,
                        "image_method": getattr(img, "method", "")})
    return results


def _undersampled(pixel, rho) -> bool:
    """Whether the pixel is larger than the finest predicted resolution cell (then an
    :class:`AliasingWarning` to the caller of :func:`image_quality`)."""
    finest = min(c for c in (rho or (np.inf,)))
    if pixel > finest:
        warnings.warn(f"pixel {pixel:.4g} m exceeds the resolution cell {finest:.4g} m of the predicted "
                      "PSF: the image undersamples its main lobe and the measured widths follow the grid",
                      AliasingWarning, stacklevel=3)
    return bool(pixel > finest)


def _predicted(acq, img, taper, sidelobe_extent_cells):
    """The range direction, the resolution cells (None where one is unknown) and the predicted
    cut figures of :func:`image_quality` (:func:`~sarcli.analysis.psf.predicted_ipr`); ``taper``
    is the window, nbar and sidelobe level asked for (None: those recorded in ``img``)."""
    rec_win, rec_nbar, rec_sll = _window_from_parameters(getattr(img, "parameters", {}))
    window, nbar, sll_db = taper
    window = rec_win if window is None else window
    nbar = rec_nbar if nbar is None else int(nbar)
    sll_db = rec_sll if sll_db is None else float(sll_db)
    pred = predicted_ipr(acq, window=window, nbar=nbar, sll_db=sll_db,
                         sidelobe_extent_cells=sidelobe_extent_cells)
    rho = (pred["range"].get("cell_m"), pred["cross_range"].get("cell_m"))
    rho = None if None in rho else rho
    keep = ("irw_m", "pslr_db", "islr_db", "first_nulls_m", "resolution_m", "cell_m", "sidelobe_extent_m")
    predicted = {d: {k: pred[d].get(k) for k in keep} for d in ("range", "cross_range")}
    predicted.update(method=pred.get("method"), window=pred["window"], textbook=pred.get("textbook"))
    return pred["range_direction_rad"], rho, predicted


def _measured(img, pk, pos, close, predicted, ipr_options):
    """One target's :func:`measure_ipr` at its peak ``pk`` (row, col; None: no peak, nothing
    measured), against its expected position ``pos``, without cut figures when ``close``; and
    the measured over predicted IRW per direction."""
    ratio = {"range": None, "cross_range": None}
    if pk is None:
        return None, ratio
    x, y = np.asarray(img.x_m, dtype=np.float64), np.asarray(img.y_m, dtype=np.float64)
    m = measure_ipr(img.image, x, y, at=(x[pk[1]], y[pk[0]]), **ipr_options)
    m["requested_at_m"] = list(pos)
    m["peak_position_error_m"] = float(np.hypot(m["x_m"] - pos[0], m["y_m"] - pos[1]))
    if close:
        for d in ("range", "cross_range"):
            m[d].update(irw_m=None, pslr_db=None, islr_db=None)
    for d in ("range", "cross_range"):
        mi, pi = m[d]["irw_m"], predicted[d]["irw_m"]
        ratio[d] = None if mi is None or not pi else float(mi / pi)
    return m, ratio


def load_reference(path):
    """Geometry and point targets from a YAML acquisition or a phase-history file.

    Parameters
    ----------
    path : str or Path
        A YAML acquisition (truth = the scene's points) or a sarcli phase history (truth = its
        ``/truth``), recognised by :func:`sarcli.io.open_input`.

    Returns
    -------
    acquisition : Acquisition
    truth : sarcli.core.types.Truth or None
    """
    from ..core.types import Truth
    from ..io import open_input

    fmt, src = open_input(path, expect=("config", "phase-history"))
    if fmt == "config":
        from ..io.scene_spec import point_targets

        acq = src
        pos, amp = point_targets(acq.scene)
        return acq, Truth(point_position_m=np.asarray(pos, dtype=np.float64).reshape(-1, 3),
                          point_amplitude=np.asarray(amp, dtype=np.complex128).reshape(-1))
    return src.acquisition, src.truth
