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

import math
import time
import warnings

import numpy as np

from .._util.resources import check_memory
from ..core.grid import Grid, resolve_grid
from ..core.types import Image, PhaseHistory
from ..errors import SarcliInputError, SarcliWarning
from .planning.cost import DIRECT_WARN_S, NUFFT_EPS
from .families import FORMERS, SPHERICAL_ADVICE, VIRTUAL_RANGE_PER_M, range_positions, warn_defocus
from .former import Plan, Settings
from .options import DEFAULT_TOLERANCE, OPTIONS

__all__ = ["form_image", "plan_image", "check_form_image", "plan_rows", "default_candidates", "PLANNED", "regrid", "METHODS", "image_error", "DEFAULT_TOLERANCE",
           "SPHERICAL_ADVICE", "VIRTUAL_RANGE_PER_M", "range_positions", "FARFIELD_METHODS"]

METHODS = tuple(OPTIONS)
FARFIELD_METHODS = ("nufft", "pfa")
#: Keywords of :func:`form_image` that are no method's knob: the window's Taylor parameters and a
#: map image's DEM.
WINDOW_KEYS = ("taylor_nbar", "taylor_sll_db")
MAP_KEYS = ("dem", "dem_datum", "crs")
#: Seconds of ``direct`` beyond which auto's fall-back to it warns.
AUTO_DIRECT_WARN_S = 60.0


def image_error(image, reference) -> float:
    """Relative error ``‖f − f_ref‖₂ / ‖f_ref‖₂`` (docs/conventions.md), the measure used everywhere."""
    ref = np.asarray(reference)
    return float(np.linalg.norm(np.asarray(image) - ref) / np.linalg.norm(ref))


def regrid(ph: PhaseHistory, *, grid: Grid | None = None, window="none", taylor_nbar=4, taylor_sll_db=-35.0,
           kernel="kaiser", oversample=2.0, width=6):
    """The polar format algorithm's first half: polar samples onto a Cartesian k-grid.

    Returns a :class:`sarcli.formers.pfa.KGrid` designed for ``grid`` (default: the
    acquisition's); :func:`form_image` with ``method='pfa'`` accepts it in place of the phase history.
    """
    from .options import PfaOptions
    from .pfa import regrid_polar

    grid = grid or ph.acquisition.grid
    warn_defocus(ph, grid, "pfa")
    w = Settings(window, taylor_nbar, taylor_sll_db).weights(ph.data.shape)
    kx, ky = ph.acquisition.kspace()
    kg = regrid_polar(ph.data, kx, ky, w, pixel_m=(grid.dx, grid.dy), shape=grid.shape, center_m=(grid.cx, grid.cy),
                      options=PfaOptions(kernel=kernel, oversample=oversample, width=width))
    kg.parameters.update({"window": window, "taylor_nbar": taylor_nbar, "taylor_sll_db": taylor_sll_db,
                          "design_grid": grid.as_dict()})
    return kg


def plan_image(ph: PhaseHistory, grid: Grid, options, settings: Settings | None = None, costs=None) -> Plan:
    """The :class:`~sarcli.formers.former.Plan` of ``options``' former (:mod:`sarcli.formers.options`)
    for these data on ``grid``; ``auto``: the plan of the cheapest former predicted to meet its
    tolerance (:func:`sarcli.formers.planning.planner.recommend`), its choice in ``plan.auto``."""
    settings = settings or Settings()
    if options.method != "auto":
        return FORMERS[options.method].plan(ph, grid, options, settings, costs)
    from .planning.planner import recommend

    tol = options.tolerance
    pick = recommend(ph, grid, tol, nthreads=settings.nthreads, costs=costs)
    if pick.method == "direct" and pick.seconds > AUTO_DIRECT_WARN_S:
        warnings.warn(f"no fast former is predicted to meet tolerance {tol:g} on these data; auto falls "
                      f"back to direct, estimated {pick.seconds:.3g} s (see `sar plan`)", SarcliWarning,
                      stacklevel=3)
    plan = FORMERS[pick.method].plan(ph, grid, pick.options, settings, costs)
    plan.auto = {"tolerance": tol, "choice": pick.method, "knobs": pick.knobs,
                 "predicted_error": pick.predicted_error, "predicted_s": pick.seconds}
    return plan


#: The formers ``sar plan`` lists for each data model, each first as ``--method X`` runs it with no
#: knob (:func:`default_candidates`).
PLANNED = {"spherical": ("direct", "backprojection", "ffbp", "subimage"), "farfield": ("direct", "nufft", "pfa")}


def default_candidates(ph: PhaseHistory, grid: Grid, tolerance: float, *, nthreads=None, costs=None) -> list:
    """Each former of :data:`PLANNED` with its default options, what ``--method X`` runs with no
    knob: a :class:`~sarcli.formers.planning.planner.Candidate` marked ``default`` with the knobs, predicted
    error, seconds and bytes of its plan, ``meets`` at ``tolerance``. A former whose plan refuses
    these data (subimage where no tile meets its tolerance) is left out."""
    from .planning.planner import SAFETY, Candidate

    settings = Settings(nthreads=nthreads)
    out = []
    for method in PLANNED[ph.model]:
        options = OPTIONS[method]()
        try:
            plan = FORMERS[method].plan(ph, grid, options, settings, costs)
            cand = Candidate(method, dict(plan.knobs), plan.predicted_error, plan.seconds, plan.bytes, plan.notes,
                             options=options, default=True)
        except SarcliInputError:
            continue
        cand.meets = cand.predicted_error <= tolerance / SAFETY
        out.append(cand)
    return out


def plan_rows(ph: PhaseHistory, grid: Grid, tolerance: float, *, nthreads=None, costs=None) -> list:
    """``sar plan``'s rows: every former's default (:func:`default_candidates`), then the
    planner's candidates at ``tolerance`` (:func:`sarcli.formers.planning.planner.candidates`) that run
    something else; those that meet the tolerance first, each group by predicted time."""
    from .planning.planner import candidates, same_run

    rows = default_candidates(ph, grid, tolerance, nthreads=nthreads, costs=costs)
    defaults = list(rows)
    rows += [c for c in candidates(ph, grid, tolerance, nthreads=nthreads, costs=costs)
             if not any(same_run(d, c) for d in defaults)]
    return sorted(rows, key=lambda x: (not x.meets, x.seconds if x.seconds == x.seconds else math.inf))


def check_plan(plan: Plan) -> None:
    """Refuse a plan whose memory exceeds the limit (:func:`sarcli._util.resources.check_memory`);
    warn before a long ``direct`` with its predicted time and a faster method."""
    grid, (p, m) = plan.grid, plan.ph.data.shape
    check_memory(plan.bytes, f"{plan.method} on {grid.nx} x {grid.ny} pixels from {p} x {m} samples")
    if plan.method == "direct" and plan.seconds > DIRECT_WARN_S:
        model = plan.ph.model
        if model == "farfield":
            faster = f"method nufft (default eps {NUFFT_EPS:g}: relative error ~{NUFFT_EPS:g} against direct)"
        else:
            faster = "method backprojection (default knobs: relative error ~3e-4 against direct)"
        warnings.warn(f"direct on {grid.nx} x {grid.ny} pixels from {p} x {m} samples ({model}): "
                      f"estimated {plan.seconds:.3g} s; {faster} takes a small fraction of that", SarcliWarning,
                      stacklevel=3)


def check_form_image(src, method: str, grid: Grid, *, nthreads=None, **knobs) -> None:
    """Refuse (memory) or warn (``direct`` time) before anything is allocated, as
    :func:`form_image` does: ``src`` a :class:`PhaseHistory` (or a k-grid, checked by its size),
    ``knobs`` the method's (:mod:`sarcli.formers.options`)."""
    data = getattr(src, "data", None)
    if data is None:  # a k-grid: the image and the FFT of the grid
        shape = getattr(src, "samples", np.zeros((0, 0))).shape
        check_memory(3 * float(np.prod(shape)) * 16 + 2.0 * grid.nx * grid.ny * 16,
                     f"pfa of a {shape[1]} x {shape[0]} k-grid onto {grid.nx} x {grid.ny} pixels")
        return
    check_plan(plan_image(src, grid, OPTIONS[method].from_knobs(knobs), Settings(nthreads=nthreads)))


def form_image(ph, method: str = "auto", *, grid: Grid | None = None, center=None, extent=None, pixel_size=None,
               window: str = "none", nthreads: int | None = None, **options) -> Image:
    """Form the matched-filter image of a phase history.

    Parameters
    ----------
    ph : PhaseHistory or KGrid
        The data (a :class:`~sarcli.formers.pfa.KGrid` from :func:`regrid` only with ``method='pfa'``).
    method : {'auto', 'direct', 'nufft', 'pfa', 'backprojection', 'ffbp', 'subimage'}
        ``auto`` (the default): the cheapest former predicted to meet ``tolerance`` (default
        :data:`DEFAULT_TOLERANCE`) for these data and this grid (:mod:`sarcli.formers.planning.planner`),
        with the knobs it picks; the choice, its predicted error and the tolerance are recorded in
        ``parameters['auto']``. A k-grid is imaged with ``pfa``.
    grid : Grid, optional
        Image grid; default the acquisition's, modified by ``center``/``extent``/``pixel_size``.
    center, extent, pixel_size : optional
        Grid overrides (m): centre ``(x, y)``, full side lengths ``W`` or ``(W, H)``, pixel size.
    window : {'none', 'hann', 'hamming', 'taylor'}
        Applied in range (over frequencies) and cross-range (over pulses); normalised by W = Σw.
    nthreads : int, optional
        Threads (default all cores).
    **options
        ``taylor_nbar``, ``taylor_sll_db``: Taylor window parameters (4, -35). The method's knobs,
        as named by its options dataclass (:mod:`sarcli.formers.options`: e.g. ``eps`` for
        ``nufft``; ``upsample``, ``interp``, ``precision`` for ``backprojection``; ``base``,
        ``merge``, ``os_range``, ``os_angle``, ``upsample``, ``interp``, ``tolerance`` for
        ``ffbp``; ``tile``, ``tolerance``, ``eps`` for ``subimage``; ``tolerance`` for ``auto``),
        each checked: a name that is no knob of the method is refused, naming it. ``dem``,
        ``dem_datum``, ``crs``: a map image on terrain (:func:`sarcli.formers.points.form_map`):
        ``dem`` a GeoTIFF of heights (path, or a :class:`sarcli.io.dem.Dem`), ``dem_datum``
        'ellipsoid' or 'geoid' (default: the file's own), ``crs`` the map CRS ('EPSG:NNNN';
        default the UTM zone of the scene centre). The grid then covers ``grid``'s rectangle; its
        pixels are the map CRS's, each formed at its DEM height. Only backprojection and direct
        form at heights (``auto`` takes backprojection); ``x_m``/``y_m`` are eastings/northings
        and ``parameters['map']`` records the CRS and the DEM.

    Returns
    -------
    Image
        With ``method``, every setting in ``parameters`` and ``runtime_s`` (the formation alone,
        one-time compilation included).
    """
    from ..core.types import KGrid

    if method not in METHODS:
        raise SarcliInputError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    taylor = {k: options.pop(k) for k in WINDOW_KEYS if k in options}
    dem_kw = {k: options.pop(k) for k in MAP_KEYS if k in options}
    if isinstance(ph, KGrid):
        if method == "auto":
            method = "pfa"
        if method != "pfa":
            raise SarcliInputError(f"a k-grid file can only be imaged with method 'pfa', not {method!r}")
        OPTIONS[method].from_knobs(options)
        return _form_from_kgrid(ph, grid, center, extent, pixel_size)
    if not isinstance(ph, PhaseHistory):
        raise TypeError(f"form_image expects a PhaseHistory or a KGrid, got {type(ph).__name__}")
    opts = OPTIONS[method].from_knobs(options)
    grid = resolve_grid(grid or ph.acquisition.grid, center=center, extent=extent, pixel_size=pixel_size)
    settings = Settings(window, nthreads=nthreads, **taylor)
    if dem_kw.get("dem") is not None:
        return _form_map_image(ph, opts, grid, settings, **dem_kw)
    if dem_kw.get("crs") is not None:
        raise SarcliInputError("--crs sets a map grid's CRS: give --dem too (a plane image stays in the scene's "
                               "tangent plane)")
    plan = plan_image(ph, grid, opts, settings)
    check_plan(plan)
    img = plan.form()
    auto = getattr(plan, "auto", None)
    if auto is not None:
        img.parameters["auto"] = auto
        img.parameters["predicted_error"] = auto["predicted_error"]
    return img


def _form_map_image(ph, options, grid, settings, dem, dem_datum=None, crs=None) -> Image:
    """:func:`form_image` with a DEM: the map grid on terrain (:func:`sarcli.formers.points.form_map`)."""
    from ..io.dem import Dem, parse_crs, read_dem
    from .options import BackprojectionOptions
    from .points import form_map

    dem = dem if isinstance(dem, Dem) else read_dem(dem, dem_datum)
    epsg = parse_crs(crs) if crs is not None else None
    method = options.method
    params: dict = {"method": method, "window": settings.window, "data_model": ph.model, "grid": grid.as_dict()}
    if method == "auto":   # the one fast former that forms at heights
        method, options = "backprojection", BackprojectionOptions()
        params["auto"] = {"choice": method, "reason": "the fast former that forms at per-pixel heights"}
    t0 = time.perf_counter()
    img, mg, info = form_map(ph, method, grid, dem, crs=epsg, weights=settings.weights(ph.data.shape),
                             options=options if method == "backprojection" else None, nthreads=settings.nthreads)
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
