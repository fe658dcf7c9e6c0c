"""Formers at pixels anywhere in 3-D: a map grid whose pixels sit on terrain.

A map product's pixels are the centres of a grid in a map CRS, each at the height a DEM gives it
(:mod:`sarcli.io.dem`), so in the local frame they are points ``x_i = (x, y, z)`` that lie on no
plane. Two formers take them:

* :func:`backproject_points`: backprojection (the matched filter of docs/conventions.md, paper eq.
  ``mf`` with the spherical ``e_pj``) with each pixel's differential range exact in float64,
  ``Δr = (|x|² - 2 a·x) / (|a - x| + |a|) + |a| - r0`` (the bistatic mean of both ends when the
  receiver moves), then the range profiles, interpolation and carrier of
  :mod:`.backprojection` (``src/native/backprojection.cpp``, ``bp_points``). No tiles share a
  range model, so it costs a square root a pixel and pulse more than the tiled kernel
  (``bench/bench_points.py`` measures the ratio); its workers are compiled per instruction set
  as the tiled ones.
  :func:`reproject_points` is its exact adjoint.
* :func:`sarcli.formers.direct.direct_points`: the exact matched filter at the points (the
  reference).

The other formers (nufft, pfa, ffbp, subimage) form a plane z = 0 and refuse pixel heights.
"""

from __future__ import annotations

import numpy as np

from .._native import using_threads
from .._native.layout import BpGeo, BpPointGeo
from ..core.geometry import bistatic_differential_range
from ..core.grid import Grid
from ..errors import AliasingWarning, SarcliInputError
from .backprojection import kernels
from .backprojection import PAD, Setup, check_data, knobs_of, profiles
from .direct import direct_points
from .options import BackprojectionOptions

__all__ = ["backproject_points", "reproject_points", "form_map", "HEIGHT_METHODS"]

#: points whose ranges the window check takes at once (bounds its memory)
_CHECK_POINTS = 1 << 16
#: the formers that form at per-pixel heights (``form_image(..., heights)``)
HEIGHT_METHODS = ("backprojection", "direct")


def _checked_points(points_m):
    pts = np.asarray(points_m, dtype=np.float64)
    if pts.ndim < 2 or pts.shape[-1] != 3 or pts.size == 0 or not np.all(np.isfinite(pts)):
        raise SarcliInputError(f"pixel positions must be a finite (..., 3) array, got shape {pts.shape}")
    return pts


def _setup(shape, collection, pts, options):
    """:class:`sarcli.formers.backprojection.Setup` (checks, profile layout, per-pulse constants) on the points'
    horizontal bounding box, and the kernel's geometry rows for 3-D points."""
    flat = pts.reshape(-1, 3)
    lo, hi = flat[:, :2].min(axis=0), flat[:, :2].max(axis=0)
    span = np.maximum(hi - lo, 1e-3)
    box = Grid(2, 2, float(span[0]), float(span[1]), float(lo[0] + span[0]), float(lo[1] + span[1]))
    import warnings

    with warnings.catch_warnings():   # the window is checked below on the 3-D points themselves
        warnings.simplefilter("ignore", AliasingWarning)
        st = Setup(shape, collection, box, *knobs_of(options))
    a = np.asarray(collection.antenna_position_m, dtype=np.float64)
    rcv = collection.receive_position_m
    b = a if rcv is None else np.asarray(rcv, dtype=np.float64)
    geo = np.empty((len(BpPointGeo), st.n_pulses))
    geo[BpPointGeo.AX:BpPointGeo.AZ + 1], geo[BpPointGeo.BX:BpPointGeo.BZ + 1] = a.T, b.T
    geo[BpPointGeo.NA], geo[BpPointGeo.NB] = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    geo[BpPointGeo.OFFSET], geo[BpPointGeo.INV_BIN], geo[BpPointGeo.KC] = (st.geo[BpGeo.OFFSET], st.geo[BpGeo.INV_BIN],
                                                                         st.geo[BpGeo.KC])
    # the window checked at every point for up to 17 pulses spread over the aperture (ends included)
    sel = np.unique(np.r_[np.arange(0, st.n_pulses, max(1, st.n_pulses // 16)), st.n_pulses - 1])
    r0 = np.asarray(collection.range_to_center_m, dtype=np.float64)
    half = np.abs(1.0 / st.geo[BpGeo.INV_BIN][sel]) * st.n_len / 2.0
    excess = max(float(np.max(np.abs(bistatic_differential_range(a[sel], b[sel], r0[sel], flat[k:k + _CHECK_POINTS]))
                                / half[:, None])) for k in range(0, flat.shape[0], _CHECK_POINTS))
    if excess >= 1.0:
        warnings.warn(f"the pixels reach {excess:.3g} times the unambiguous range window "
                      f"|Δr| < c/(4Δα) = {half.min():.4g} m; backprojection leaves pixels outside it out of "
                      "those pulses", AliasingWarning, stacklevel=3)
    return st, np.ascontiguousarray(geo)


def backproject_points(data, collection, points_m, options=None, *, nthreads=None) -> np.ndarray:
    """Spherical matched-filter image at 3-D pixel positions by backprojection (paper eq. ``mf``).

    Parameters
    ----------
    data, collection :
        As for :func:`sarcli.formers.backprojection.backproject`.
    points_m : array_like, shape (..., 3)
        Pixel positions in the local frame (m).
    options, nthreads :
        As for :func:`sarcli.formers.backprojection.backproject` (None: upsample 16, lagrange, float64).

    Returns
    -------
    ndarray, shape points_m.shape[:-1], complex128
        ``(1/W) Σ w d e_pj(x)``: a unit point scatterer at a pixel peaks at 1 there.
    """
    d = check_data(data)
    pts = _checked_points(points_m)
    st, geo = _setup(d.shape, collection, pts, options)
    flat = np.ascontiguousarray(pts.reshape(-1, 3))
    cdt = np.complex64 if st.dtype == np.float32 else np.complex128
    out_re = np.zeros(flat.shape[0])
    out_im = np.zeros(flat.shape[0])
    kern = kernels()
    with using_threads(nthreads):
        for sl in st.blocks():
            prof = profiles(d[sl], None if st.weights is None else st.weights[sl], st.total_weight, st.n_len, cdt)
            kern.bp_points(prof.view(st.dtype).reshape(prof.shape + (2,)), flat, np.ascontiguousarray(geo[:, sl]),
                           st.n_len, PAD, st.kind, st.bistatic, out_re, out_im)
    return (out_re + 1j * out_im).reshape(pts.shape[:-1])


def reproject_points(image, collection, points_m, options=None, *, nthreads=None) -> np.ndarray:
    """Exact adjoint of :func:`backproject_points`: an image at the points -> phase history (P, M).

    Arguments as for :func:`backproject_points`, with ``image`` of shape ``points_m.shape[:-1]``;
    the same steps as :func:`sarcli.formers.backprojection.reproject`.
    """
    pts = _checked_points(points_m)
    f = np.asarray(image)
    if f.shape != pts.shape[:-1]:
        raise SarcliInputError(f"image shape {f.shape} does not match the points {pts.shape[:-1]}")
    a = np.asarray(collection.antenna_position_m)
    fr = np.asarray(collection.frequency_hz)
    st, geo = _setup((a.shape[0], fr.shape[-1]), collection, pts, options)
    flat = np.ascontiguousarray(pts.reshape(-1, 3))
    fre = np.ascontiguousarray(f.real.ravel(), dtype=st.dtype)
    fim = np.ascontiguousarray(f.imag.ravel() if np.iscomplexobj(f) else np.zeros(f.size), dtype=st.dtype)
    out = np.empty((st.n_pulses, st.m), dtype=np.complex128)
    kern = kernels()
    with using_threads(nthreads):
        for sl in st.blocks():
            nb = sl.stop - sl.start
            hri = np.zeros((nb, st.n_len + 2 * PAD, 2), dtype=st.dtype)
            kern.rp_points(fre, fim, flat, np.ascontiguousarray(geo[:, sl]), st.n_len, PAD, st.kind, st.bistatic, hri)
            out[sl] = st.samples_from_profiles(hri)
    if st.weights is not None:
        out *= st.weights
    return out


def form_map(ph, method, grid: Grid, dem, *, crs=None, weights=None, options=None, nthreads=None):
    """A map image on terrain: the map grid covering ``grid`` (:func:`sarcli.io.dem.map_grid`, in
    EPSG ``crs``, default the scene centre's UTM zone), each pixel at its DEM height
    (:func:`sarcli.io.dem.map_points`), formed there by ``method`` ('backprojection' or 'direct';
    backprojection with ``options``, a :class:`~sarcli.formers.options.BackprojectionOptions`, default
    that of ``form_image``: 12, lagrange, float32) and window ``weights``.

    Returns
    -------
    image : ndarray (ny, nx) complex128
    map_grid : sarcli.io.dem.MapGrid
    info : dict
        What ``parameters['map']`` of the image records (CRS, DEM, datum, height range).
    """
    from ..io.dem import map_grid, map_points
    from ..io.georef import reference_point

    if method not in HEIGHT_METHODS:
        raise SarcliInputError(f"method {method!r} forms the plane z = 0 only and cannot form at DEM heights; "
                               f"use {', '.join(HEIGHT_METHODS)} or auto")
    acq = ph.acquisition
    if ph.model != "spherical" or not acq.has_positions:
        raise SarcliInputError("forming on a DEM needs spherical data with antenna positions "
                               "(far-field data have no range to a height)")
    ref = reference_point(ph.attrs)
    mg = map_grid(ref, grid.x, grid.y, min(grid.dx, grid.dy), crs)
    pts, hae = map_points(mg, dem, ref)
    col = acq.collection(weights)
    info = {"crs": f"EPSG:{mg.epsg}", "dem": str(dem.path), "dem_datum": dem.datum, "dem_geoid": dem.geoid,
            "dem_epsg": dem.epsg, "height_min_m": float(np.min(hae)), "height_max_m": float(np.max(hae)),
            "pixel_m": float(mg.easting[1] - mg.easting[0]) if mg.easting.size > 1 else float(grid.dx)}
    if method == "direct":
        img = direct_points(ph.data, col.frequency_hz, col.antenna_position_m, col.range_to_center_m, pts, weights,
                            receive_position_m=col.receive_position_m)
    else:
        opts = BackprojectionOptions() if options is None else options
        img = backproject_points(ph.data, col, pts, opts, nthreads=nthreads)
        info.update({"upsample": opts.upsample, "interp": opts.interp, "precision": opts.precision})
    return img, mg, info
