"""Image formation: the public :func:`form_image` over the kernels in :mod:`sarcli.formers`.

Every method computes the same quantity, the matched filter of docs/conventions.md (paper eq. ``mf``)
``f(x) = (1/W) Σ_pj w_pj d_pj e_pj(x)``, so a unit point scatterer peaks at 1 whatever the method,
window or grid:

========================  =====================  ==============================================
method                    data model             how
========================  =====================  ==============================================
``direct``                the file's own         exact sum, float64 (the reference)
``nufft``                 far-field              one type-1 NUFFT (FINUFFT), knob ``eps``
``pfa``                   far-field              gridding onto a Cartesian k-grid + FFT
``backprojection``        spherical (any path)   range-compress, interpolate, phase, accumulate
``ffbp``                  spherical (any path)   sub-aperture polar images merged in stages
``subimage``              spherical (any path)   one NUFFT per motion-compensated tile
``auto``                  either                 the cheapest of the above predicted to meet ``tolerance``
========================  =====================  ==============================================

A far-field method applied to spherical data warns with the predicted phase error at the grid's
corner; backprojection of far-field data uses virtual antennas on a circle of radius
``r_v = 5·10^7 · (grid half-diagonal)``, where the spherical model's curvature term
``(4π α/c)|x|²/(2 r_v)`` and the float64 rounding of ranges ``~(4π α/c)·r_v·2e-16`` balance
(both ~1e-5 rad at X band).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from ..core import geometry
from ..errors import DefocusWarning, SarcliInputError
from ..core.grid import Grid, resolve_grid
from ..core.types import Image, PhaseHistory
from ..core.windows import window_weights

__all__ = ["form_image", "regrid", "METHODS", "image_error"]

METHODS = ("direct", "nufft", "pfa", "backprojection", "ffbp", "subimage", "auto")
#: Relative error against the exact matched filter that ``method='auto'`` meets when no tolerance
#: is given.
DEFAULT_TOLERANCE = 1e-3
FARFIELD_METHODS = ("nufft", "pfa")
#: Virtual stand-off range per metre of grid half-diagonal used to backproject far-field data.
VIRTUAL_RANGE_PER_M = 5.0e7


def image_error(image, reference) -> float:
    """Relative error ``‖f − f_ref‖₂ / ‖f_ref‖₂`` (docs/conventions.md), the measure used everywhere."""
    ref = np.asarray(reference)
    return float(np.linalg.norm(np.asarray(image) - ref) / np.linalg.norm(ref))


def _weights(ph: PhaseHistory, window, nbar, sll_db):
    """Window weights [P, M], or None without a window (every former then takes W = P M and no
    P x M array of ones is ever made)."""
    if window == "none":
        return None
    P, M = ph.data.shape
    try:
        return window_weights(P, M, window, nbar=nbar, sll_db=sll_db)
    except ValueError as exc:  # an unknown kind or Taylor parameters out of range
        raise SarcliInputError(str(exc)) from None


#: The formers that model the spherical wavefront, as advice names them (auto picks among them).
SPHERICAL_ADVICE = "--method auto picks among ffbp, backprojection, subimage and direct"


def _warn_defocus(ph: PhaseHistory, grid: Grid, method: str):
    acq = ph.acquisition
    if ph.model != "spherical" or not acq.has_positions:
        return
    err = geometry.farfield_phase_error(acq.range_to_center_m, acq.frequency_hz.max(), grid.half_diagonal)
    if err > geometry.DEFOCUS_WARN_RAD:
        warnings.warn(f"far-field method '{method}' on spherical data: predicted phase error "
                      f"{err:.3g} rad at the grid corner ({grid.half_diagonal:.3g} m from the centre, "
                      f"r0 = {acq.range_to_center_m.min():.4g} m); use a spherical former ({SPHERICAL_ADVICE})",
                      DefocusWarning, stacklevel=3)


def _positions(ph: PhaseHistory, grid: Grid):
    """``(transmit, receive or None, r0)`` for the range-model formers: the acquisition's own
    (:meth:`Acquisition.range_geometry`; receive None when monostatic) for spherical data, a
    monostatic circle at a virtual range of :data:`VIRTUAL_RANGE_PER_M` × the grid's half-diagonal
    for far-field data."""
    acq = ph.acquisition
    if ph.model == "spherical":
        t, q, r0 = acq.range_geometry()
        return t, (q if acq.is_bistatic else None), r0
    r_v = VIRTUAL_RANGE_PER_M * max(grid.half_diagonal, 1e-3)
    pos = geometry.antenna_positions_circle(acq.azimuth_rad, acq.elevation_rad, r_v)
    return pos, None, np.full(acq.n_pulses, r_v)


def regrid(ph: PhaseHistory, *, grid: Grid | None = None, window="none", taylor_nbar=4, taylor_sll_db=-35.0,
           kernel="kaiser", oversample=2.0, width=6):
    """The polar format algorithm's first half: polar samples onto a Cartesian k-grid.

    Returns a :class:`sarcli.formers.pfa.KGrid` designed for ``grid`` (default: the
    acquisition's); :func:`form_image` with ``method='pfa'`` accepts it in place of the phase history.
    """
    from .pfa import regrid_polar

    grid = grid or ph.acquisition.grid
    _warn_defocus(ph, grid, "pfa")
    w = _weights(ph, window, taylor_nbar, taylor_sll_db)
    kx, ky = ph.acquisition.kspace()
    kg = regrid_polar(ph.data, kx, ky, w, pixel_m=(grid.dx, grid.dy), shape=grid.shape,
                      center_m=(grid.cx, grid.cy), kernel=kernel, oversample=oversample, width=width)
    kg.parameters.update({"window": window, "taylor_nbar": taylor_nbar, "taylor_sll_db": taylor_sll_db,
                          "design_grid": grid.as_dict()})
    return kg


def form_image(ph, method: str = "auto", *, grid: Grid | None = None, center=None, extent=None,
               pixel_size=None, window: str = "none", taylor_nbar: int = 4, taylor_sll_db: float = -35.0,
               eps: float = 1e-9, kernel: str = "kaiser", oversample: float = 2.0, width: int = 6,
               upsample: float | None = None, interp: str | None = None, precision: str | None = None,
               nthreads: int | None = None, base: int | None = None, merge: int | None = None,
               os_range: float | None = None, os_angle: float | None = None, tile: int | None = None,
               tolerance: float | None = None, dem=None, dem_datum: str | None = None, crs=None) -> Image:
    """Form the matched-filter image of a phase history.

    Parameters
    ----------
    ph : PhaseHistory or KGrid
        The data (a :class:`~sarcli.formers.pfa.KGrid` from :func:`regrid` only with ``method='pfa'``).
    method : {'auto', 'direct', 'nufft', 'pfa', 'backprojection', 'ffbp', 'subimage'}
        ``auto`` (the default): the cheapest former predicted to meet ``tolerance`` (default
        :data:`DEFAULT_TOLERANCE`) for these data and this grid (:mod:`sarcli.formers.planner`),
        with the knobs it picks (the method-specific arguments below are then not used); the
        choice, its predicted error and the tolerance are recorded in ``parameters['auto']``. A
        k-grid is imaged with ``pfa``.
    grid : Grid, optional
        Image grid; default the acquisition's, modified by ``center``/``extent``/``pixel_size``.
    center, extent, pixel_size : optional
        Grid overrides (m): centre ``(x, y)``, full side lengths ``W`` or ``(W, H)``, pixel size.
    window : {'none', 'hann', 'hamming', 'taylor'}
        Applied in range (over frequencies) and cross-range (over pulses); normalised by W = Σw.
    taylor_nbar, taylor_sll_db : Taylor window parameters.
    eps : float
        NUFFT accuracy (``nufft``).
    kernel, oversample, width :
        PFA gridding kernel ('kaiser' or 'linear'), field-of-view oversampling and kernel width.
    upsample, interp, precision, nthreads :
        Backprojection range-profile upsampling, interpolator ('linear', 'cubic', 'lanczos'),
        precision of its profiles and sums ('float32', the default
        :data:`~sarcli.formers.backprojection.DEFAULT_PRECISION`, or 'float64'), threads.
    base, merge, os_range, os_angle :
        Fast factorised backprojection (``ffbp``, :mod:`sarcli.formers.ffbp`): pulses per base
        sub-aperture, sub-apertures merged per stage, polar-grid oversampling in range and angle;
        with ``upsample`` and ``interp`` ('linear', 'cubic', 'lanczos', 'optimal'). All ``None``:
        the knobs ``auto`` picks for ffbp at ``tolerance`` (default :data:`DEFAULT_TOLERANCE`;
        spherical data), recorded as ``parameters['knobs_for_tolerance']``; some ``None``: ffbp's
        defaults for those.
    tile, tolerance :
        Sub-image NUFFT (``subimage``, :mod:`sarcli.formers.subimage`): tile side in pixels, or
        the largest predicted to meet ``tolerance`` (default 1e-2); its NUFFT runs at
        ``eps = tolerance/10`` unless ``eps`` is set to other than its default. ``ffbp``: the
        tolerance its knobs are picked for when none is given.
    dem, dem_datum, crs : optional
        A map image on terrain (:func:`sarcli.formers.points.form_map`): ``dem`` a GeoTIFF of
        heights (path, or a :class:`sarcli.io.dem.Dem`), ``dem_datum`` 'ellipsoid' or 'geoid'
        (default: the file's own), ``crs`` the map CRS ('EPSG:NNNN'; default the UTM zone of
        the scene centre). The grid then covers ``grid``'s rectangle; its pixels are the map
        CRS's, each formed at its DEM height. Only backprojection and direct form at heights
        (``auto`` takes backprojection); ``x_m``/``y_m`` are eastings/northings and
        ``parameters['map']`` records the CRS and the DEM.

    Returns
    -------
    Image
        With ``method``, every setting in ``parameters`` and ``runtime_s`` (the formation alone,
        one-time compilation included).
    """
    from ..core.types import KGrid

    if method not in METHODS:
        raise SarcliInputError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    params: dict = {"method": method}
    if isinstance(ph, KGrid):
        if method == "auto":
            method = params["method"] = "pfa"
        if method != "pfa":
            raise SarcliInputError(f"a k-grid file can only be imaged with method 'pfa', not {method!r}")
        return _form_from_kgrid(ph, grid, center, extent, pixel_size)
    if not isinstance(ph, PhaseHistory):
        raise TypeError(f"form_image expects a PhaseHistory or a KGrid, got {type(ph).__name__}")
    acq = ph.acquisition
    grid = resolve_grid(grid or acq.grid, center=center, extent=extent, pixel_size=pixel_size)
    if dem is not None:
        return _form_map_image(ph, method, grid, dem, dem_datum, crs, window, taylor_nbar, taylor_sll_db,
                               upsample, interp, precision, nthreads)
    if crs is not None:
        raise SarcliInputError("--crs sets a map grid's CRS: give --dem too (a plane image stays in the scene's "
                               "tangent plane)")
    if method == "auto":   # the cheapest former predicted to meet the tolerance (formers/planner.py)
        from .planner import recommend

        tol = DEFAULT_TOLERANCE if tolerance is None else float(tolerance)
        pick = recommend(ph, grid, tol, nthreads=nthreads)
        if pick.method == "direct" and pick.seconds > 60:
            from ..errors import SarcliWarning

            warnings.warn(f"no fast former is predicted to meet tolerance {tol:g} on these data; auto falls "
                          f"back to direct, estimated {pick.seconds:.3g} s (see `sar plan`)", SarcliWarning,
                          stacklevel=2)
        img = form_image(ph, pick.method, grid=grid, window=window, taylor_nbar=taylor_nbar,
                         taylor_sll_db=taylor_sll_db, nthreads=nthreads, **pick.knobs)
        img.parameters["auto"] = {"tolerance": tol, "choice": pick.method, "knobs": pick.knobs,
                                  "predicted_error": pick.predicted_error, "predicted_s": pick.seconds}
        img.parameters["predicted_error"] = pick.predicted_error
        return img
    if method == "backprojection" and precision is None:
        from .backprojection import DEFAULT_PRECISION

        precision = DEFAULT_PRECISION
    # memory (refused beyond the limit) and, for direct, time (a warning) before anything is allocated
    from .cost import check_form_image

    check_form_image(ph, method, grid, oversample=oversample, upsample=upsample,
                     eps=eps if method == "nufft" else None, width=width, precision=precision or "float64",
                     nthreads=nthreads)
    w = _weights(ph, window, taylor_nbar, taylor_sll_db)
    params.update({"window": window, "grid": grid.as_dict(), "data_model": ph.model})
    if window == "taylor":
        params.update({"taylor_nbar": taylor_nbar, "taylor_sll_db": taylor_sll_db})
    t0 = time.perf_counter()
    if method == "direct":
        from .direct import direct_farfield, direct_spherical

        if ph.model == "spherical":
            t, q, r0 = _positions(ph, grid)
            img = direct_spherical(ph.data, acq.frequency_hz, t, r0, grid, w, receive_position_m=q)
        else:
            kx, ky = acq.kspace()
            img = direct_farfield(ph.data, kx, ky, grid, w)
    elif method == "nufft":
        from .nufft import nufft_farfield

        _warn_defocus(ph, grid, method)
        kx, ky = acq.kspace()
        img = nufft_farfield(ph.data, kx, ky, grid, w, eps=eps, nthreads=nthreads)
        params["eps"] = eps
    elif method == "pfa":
        from .pfa import pfa_image

        kg = regrid(ph, grid=grid, window=window, taylor_nbar=taylor_nbar, taylor_sll_db=taylor_sll_db,
                    kernel=kernel, oversample=oversample, width=width)
        img = pfa_image(kg, grid)
        params.update({"kernel": kernel, "oversample": oversample, "width": width})
    elif method == "subimage" and ph.model == "spherical":
        from .subimage import subimage_nufft

        pos, rcv, r0 = _positions(ph, grid)
        tol = 1e-2 if tolerance is None else float(tolerance)
        img, info = subimage_nufft(ph.data, acq.frequency_hz, pos, r0, grid, w, tile=tile,
                                   tolerance=tol, eps=None if eps == 1e-9 else eps, nthreads=nthreads,
                                   receive_position_m=rcv, return_info=True)
        params.update(info)
    elif method == "subimage":   # far-field data: one tile is exact
        from .nufft import nufft_farfield

        kx, ky = acq.kspace()
        img = nufft_farfield(ph.data, kx, ky, grid, w, eps=eps, nthreads=nthreads)
        params.update({"tile": max(grid.nx, grid.ny), "eps": eps, "predicted_error": eps, "n_tiles": 1})
    elif method == "ffbp":
        from .ffbp import ffbp_image

        if all(v is None for v in (base, merge, os_range, os_angle, upsample, interp)):
            # no knobs: what auto would pick for ffbp at the tolerance (formers/planner.py)
            from .planner import ffbp_knobs

            tol = DEFAULT_TOLERANCE if tolerance is None else float(tolerance)
            picked = ffbp_knobs(ph, grid, tol, nthreads=nthreads)
            if picked is not None:
                base, merge, os_range, os_angle = (picked[k] for k in ("base", "merge", "os_range", "os_angle"))
                upsample, interp = picked["upsample"], picked["interp"]
                params["knobs_for_tolerance"] = tol
        pos, rcv, r0 = _positions(ph, grid)
        img, extra = ffbp_image(ph.data, acq.frequency_hz, pos, r0, grid, w, receive_position_m=rcv,
                                upsample=upsample, interp=interp, nthreads=nthreads, base=base, merge=merge,
                                os_range=os_range, os_angle=os_angle)
        params.update(extra)
        if ph.model != "spherical":
            params["virtual_range_m"] = float(r0[0])
    else:
        from . import backprojection as bp

        pos, rcv, r0 = _positions(ph, grid)
        up = bp.DEFAULT_UPSAMPLE if upsample is None else upsample
        it = bp.DEFAULT_INTERP if interp is None else interp
        img = bp.backproject(ph.data, acq.frequency_hz, pos, r0, grid, w, upsample=up, interp=it,
                             precision=precision, nthreads=nthreads, receive_position_m=rcv)
        params.update({"upsample": up, "interp": it, "precision": precision})
        if ph.model != "spherical":
            params["virtual_range_m"] = float(r0[0])
    runtime = time.perf_counter() - t0
    attrs = {k: v for k, v in ph.attrs.items() if str(k).startswith("scene_center")}
    attrs["source_name"] = acq.name
    return Image(image=np.asarray(img), x_m=grid.x, y_m=grid.y, method=method, parameters=params,
                 runtime_s=runtime, attrs=attrs)


def _form_map_image(ph, method, grid, dem, dem_datum, crs, window, nbar, sll_db, upsample, interp, precision,
                    nthreads) -> Image:
    """:func:`form_image` with a DEM: the map grid on terrain (:func:`sarcli.formers.points.form_map`)."""
    from ..io.dem import Dem, parse_crs, read_dem
    from .points import form_map

    dem = dem if isinstance(dem, Dem) else read_dem(dem, dem_datum)
    epsg = parse_crs(crs) if crs is not None else None
    params: dict = {"method": method, "window": window, "data_model": ph.model, "grid": grid.as_dict()}
    if method == "auto":   # the one fast former that forms at heights
        method = "backprojection"
        params["auto"] = {"choice": method, "reason": "the fast former that forms at per-pixel heights"}
    t0 = time.perf_counter()
    img, mg, info = form_map(ph, method, grid, dem, crs=epsg, weights=_weights(ph, window, nbar, sll_db),
                             upsample=upsample, interp=interp, precision=precision, nthreads=nthreads)
    params["map"] = info
    attrs = {k: v for k, v in ph.attrs.items() if str(k).startswith("scene_center")}
    attrs["source_name"] = ph.acquisition.name
    return Image(image=np.asarray(img), x_m=mg.easting, y_m=mg.northing, method=method, parameters=params,
                 runtime_s=time.perf_counter() - t0, attrs=attrs)


def _form_from_kgrid(kg, grid, center, extent, pixel_size) -> Image:
    from .pfa import pfa_image

    design = kg.parameters.get("design_grid")
    base = grid or (Grid(**design) if design else None)
    if base is None:
        raise SarcliInputError("this k-grid file does not record its design grid; give --extent and --pixel-size")
    grid = resolve_grid(base, center=center, extent=extent, pixel_size=pixel_size)
    t0 = time.perf_counter()
    img = pfa_image(kg, grid)
    runtime = time.perf_counter() - t0
    params = {"method": "pfa", "from_kgrid": True, "grid": grid.as_dict(),
              **{k: v for k, v in kg.parameters.items() if k != "design_grid"}}
    return Image(image=img, x_m=grid.x, y_m=grid.y, method="pfa", parameters=params, runtime_s=runtime)
