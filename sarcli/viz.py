"""Every matplotlib figure sarcli draws, in one module (``matplotlib.figure.Figure``, no pyplot
state and no ``matplotlib.use``: a figure saved to a file needs no backend).

Public API
----------
plot_psf_cuts(img, path=None, *, at=None, oversample=8, dynamic_range_db=60) -> dict
plot_kspace(acq, grid=None, path=None, *, max_points=20000, copies=1) -> dict
plot_image_fft(img, path=None, *, dynamic_range_db=60) -> dict
plot_psf(img, path, *, dynamic_range_db=60)
plot_history(history, path)
plot_benchmark(result, path, *, title='')
image_figure(img, path, *, kind="db", dynamic_range_db=50, cmap="gray")

The diagnostic plots return a dict with the matplotlib ``figure`` and the numbers it shows, and
write a PNG when ``path`` is given (atomically). Images are drawn north-up with axes in metres.
"""

from __future__ import annotations

import numpy as np

from .core import geometry
from ._util.atomic import atomic_path, open_held
from .errors import SarcliInputError
from .core.grid import Grid
from .core.types import Image

__all__ = ["plot_psf_cuts", "plot_kspace", "plot_image_fft", "plot_psf", "plot_history", "plot_benchmark",
           "image_figure"]

_HALF_POWER_DB = 20 * np.log10(1 / np.sqrt(2))  # -3.01 dB


def _figure(ncols=1, size=(6.4, 4.8), nrows=1, layout="constrained"):
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=100, layout=layout)
    axes = fig.subplots(nrows, ncols)
    return fig, np.atleast_1d(axes)


def _save(fig, path, *, metadata=None, **kwargs):
    if path is not None:
        with atomic_path(path) as tmp, open_held(tmp) as fh:
            fig.savefig(fh, format="png", metadata=metadata, **kwargs)


def _as_image(img_or_psf, grid=None) -> Image:
    if isinstance(img_or_psf, Image):
        return img_or_psf
    arr = np.asarray(img_or_psf)
    if arr.ndim != 2 or grid is None:
        raise SarcliInputError("plot needs a sarcli Image, or a 2-D array together with its grid")
    return Image(arr, grid.x, grid.y, method="array")


def _extent(x, y):
    dx = float(x[1] - x[0]) if x.size > 1 else 1.0
    dy = float(y[1] - y[0]) if y.size > 1 else 1.0
    return (x[0] - dx / 2, x[-1] + dx / 2, y[0] - dy / 2, y[-1] + dy / 2)


def _db(a, floor_db):
    mag = np.abs(np.asarray(a, dtype=np.complex128))
    peak = float(mag.max()) if mag.size else 0.0
    if peak <= 0:
        return np.full(mag.shape, floor_db)
    with np.errstate(divide="ignore"):
        return np.maximum(20 * np.log10(mag / peak), floor_db)


# --------------------------------------------------------------------------------------------
# PSF cuts
# --------------------------------------------------------------------------------------------
def plot_psf_cuts(img, path=None, *, at=None, oversample=8, dynamic_range_db=60.0, grid: Grid | None = None):
    """Cuts through a point response along x (east) and y (north), with the -3 dB width marked.

    The image is interpolated band-limitedly (the demodulated FFT zero-padding of
    :mod:`sarcli.analysis.quality`) ``oversample`` times before cutting through the brightest sample; the
    -3 dB width (IRW) of each cut comes from :func:`sarcli.analysis.ipr.profile_metrics`.

    Parameters
    ----------
    img : Image or ndarray
        An image holding a point response, or a PSF (e.g. :func:`sarcli.analysis.psf.psf_image`); a bare
        array needs ``grid``.
    path : str or Path, optional
        PNG to write.
    at : (float, float), optional
        Position (m) near which the peak is looked for (default: the brightest pixel).
    oversample : int
    dynamic_range_db : float
        Lower limit of the dB axis.

    Returns
    -------
    dict
        ``figure``, ``peak_xy_m``, and ``x`` / ``y`` cuts each with ``s_m``, ``db`` (arrays),
        ``irw_m``, ``peak_position_m``, ``half_power_m`` (the two -3 dB crossings marked).
    """
    from .analysis.ipr import level_crossing, upsample_patch, profile_metrics

    im = _as_image(img, grid)
    a = np.asarray(im.image, dtype=np.complex128)
    x, y = np.asarray(im.x_m, float), np.asarray(im.y_m, float)
    if a.shape[0] < 4 or a.shape[1] < 4:
        raise SarcliInputError(f"PSF cuts need at least 4 x 4 pixels, got {a.shape}")
    mag = np.abs(a)
    if at is not None:
        d2 = (x[None, :] - float(at[0])) ** 2 + (y[:, None] - float(at[1])) ** 2
        mag = np.where(d2 <= np.min(d2) + (4 * max(x[1] - x[0], y[1] - y[0])) ** 2, mag, -1.0)
    r0, c0 = np.unravel_index(int(np.argmax(mag)), mag.shape)
    ov = max(1, int(oversample))
    fine = upsample_patch(a, ov) if ov > 1 else a
    fx = x[0] + np.arange(fine.shape[1]) * (x[1] - x[0]) / ov
    fy = y[0] + np.arange(fine.shape[0]) * (y[1] - y[0]) / ov
    fmag = np.abs(fine)
    # brightest fine sample within one coarse pixel of the coarse peak
    rs = slice(max(0, r0 * ov - ov), r0 * ov + ov + 1)
    cs = slice(max(0, c0 * ov - ov), c0 * ov + ov + 1)
    pr, pc = np.unravel_index(int(np.argmax(fmag[rs, cs])), fmag[rs, cs].shape)
    pr += rs.start
    pc += cs.start
    fig, axes = _figure(2, size=(10, 4))
    out = {"figure": fig, "peak_xy_m": (float(fx[pc]), float(fy[pr]))}
    floor = -abs(float(dynamic_range_db))
    for ax, name, s, line in ((axes[0], "x", fx, fine[pr, :]), (axes[1], "y", fy, fine[:, pc])):
        amp = np.abs(line)
        m = profile_metrics(s, amp)
        db = _db(line, floor)
        ax.plot(s, db, lw=1.2)
        ax.axhline(_HALF_POWER_DB, color="0.5", ls="--", lw=0.8)
        i0 = int(np.argmax(amp))
        level = amp[i0] / np.sqrt(2.0)
        lo, hi = level_crossing(s, amp, i0, 0, level), level_crossing(s, amp, i0, amp.size - 1, level)
        irw = m["irw_m"]
        if irw is not None:
            ax.axvline(lo, color="C3", lw=0.8)
            ax.axvline(hi, color="C3", lw=0.8)
            ax.annotate("", xy=(lo, _HALF_POWER_DB), xytext=(hi, _HALF_POWER_DB),
                        arrowprops={"arrowstyle": "<->", "color": "C3"})
            ax.set_title(f"{'x (east)' if name == 'x' else 'y (north)'} cut: -3 dB width {irw:.3g} m")
        else:
            ax.set_title(f"{name} cut: -3 dB width not reached inside the image")
        ax.set_xlabel(f"{name} (m)")
        ax.set_ylabel("dB relative to peak")
        ax.set_ylim(floor, 3)
        ax.grid(alpha=0.3)
        out[name] = {"s_m": s, "db": db, "irw_m": irw, "peak_position_m": m["peak_position"],
                     "half_power_m": (lo, hi)}
    _save(fig, path)
    return out


# --------------------------------------------------------------------------------------------
# k-space in dimensionless frequencies (paper figure 1, right)
# --------------------------------------------------------------------------------------------
def plot_kspace(acq, grid: Grid | None = None, path=None, *, max_points=20000, copies=1):
    """The samples ``(k1, k2) = k h ξ_θ`` of the pixel model (eq. ``fund-freq``) and their aliases.

    The wrapped samples (section ``sec: alias``: the pixel grid sees frequencies modulo 2π) are
    drawn inside the fundamental square ``[-π, π)²`` together with their copies shifted by
    ``2π (m, n)``, ``|m|, |n| <= copies``, as in the paper's figure 1 (right).

    Parameters
    ----------
    acq : Acquisition
    grid : Grid, optional
        Pixel sizes ``(dx, dy)``; default the acquisition's grid.
    path : str or Path, optional
    max_points : int
        Samples drawn at most (evenly decimated over pulses and frequencies).
    copies : int
        Rings of aliased copies around the fundamental square.

    Returns
    -------
    dict
        ``figure``, ``k1``, ``k2`` (wrapped, drawn samples), ``unwrapped_radius`` (min, max of
        ``|k| h``), ``n_drawn``.
    """
    grid = acq.grid if grid is None else grid
    P, M = acq.n_pulses, acq.n_frequencies
    step = max(1, int(np.ceil(np.sqrt(P * M / max(1, max_points)))))
    sub = acq.subset(pulses=slice(None, None, step), frequencies=slice(None, None, step))
    k1u, k2u = geometry.dimensionless_frequencies(sub.frequency_hz, sub.azimuth_rad, sub.elevation_rad,
                                                  (grid.dx, grid.dy), wrap=False)
    k1, k2 = geometry.dimensionless_frequencies(sub.frequency_hz, sub.azimuth_rad, sub.elevation_rad,
                                                (grid.dx, grid.dy), wrap=True)
    fig, axes = _figure(1, size=(6, 6))
    ax = axes[0]
    two_pi = 2 * np.pi
    n = int(copies)
    for m in range(-n, n + 1):
        for q in range(-n, n + 1):
            home = m == 0 and q == 0
            ax.scatter((k1 + two_pi * m).ravel(), (k2 + two_pi * q).ravel(), s=1.5 if home else 0.8,
                       color="C0" if home else "0.6", alpha=1.0 if home else 0.6, linewidths=0,
                       label="samples (wrapped)" if home else ("aliased copies" if (m, q) == (-n, -n) else None))
            ax.add_patch(_square(ax, two_pi * m, two_pi * q, home))
    lim = (2 * n + 1) * np.pi
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    ticks = np.arange(-(2 * n + 1), 2 * n + 2, 2) * np.pi
    labels = [_pi_label(int(round(t / np.pi))) for t in ticks]
    ax.set_xticks(ticks, labels)
    ax.set_yticks(ticks, labels)
    ax.set_xlabel("k1 = k h cos θ (rad / pixel)")
    ax.set_ylabel("k2 = k h sin θ (rad / pixel)")
    radius = np.hypot(k1u, k2u)
    ax.set_title(f"k-space in dimensionless frequencies\n|k| h from {radius.min():.3g} to {radius.max():.3g} rad, "
                 f"h = {grid.dx:.3g} m")
    ax.legend(loc="upper right", markerscale=6, fontsize=8)
    _save(fig, path)
    return {"figure": fig, "k1": k1, "k2": k2, "unwrapped_radius": (float(radius.min()), float(radius.max())),
            "n_drawn": int(k1.size)}


def _pi_label(m: int) -> str:
    if m == 0:
        return "0"
    sign = "-" if m < 0 else ""
    return f"{sign}π" if abs(m) == 1 else f"{sign}{abs(m)}π"


def _square(ax, cx, cy, home):
    from matplotlib.patches import Rectangle

    return Rectangle((cx - np.pi, cy - np.pi), 2 * np.pi, 2 * np.pi, fill=False,
                     edgecolor="k" if home else "0.75", lw=1.2 if home else 0.6, ls="-" if home else ":")


# --------------------------------------------------------------------------------------------
# image and its spectrum
# --------------------------------------------------------------------------------------------
def plot_image_fft(img, path=None, *, dynamic_range_db=60.0, grid: Grid | None = None):
    """The image (dB, north-up, metres) beside ``log |2-D FFT|`` (dB, axes in cycles/m).

    The spectrum shows the k-space support the image holds (wrapped into the pixel grid's
    band ``±1/(2h)``, section ``sec: alias``): a polar annulus sector for a spotlight image.

    Returns
    -------
    dict
        ``figure``, ``spectrum_db`` (fftshifted, [ky, kx]), ``fx``, ``fy`` (cycles/m, increasing),
        ``spectral_peak_cycles_per_m`` (fx, fy of the strongest spectral bin).
    """
    im = _as_image(img, grid)
    a = np.asarray(im.image, dtype=np.complex128)
    x, y = np.asarray(im.x_m, float), np.asarray(im.y_m, float)
    dx = float(x[1] - x[0]) if x.size > 1 else 1.0
    dy = float(y[1] - y[0]) if y.size > 1 else 1.0
    floor = -abs(float(dynamic_range_db))
    spec = np.fft.fftshift(np.fft.fft2(a))
    fx = np.fft.fftshift(np.fft.fftfreq(a.shape[1], dx))
    fy = np.fft.fftshift(np.fft.fftfreq(a.shape[0], dy))
    sdb = _db(spec, floor)
    r, c = np.unravel_index(int(np.argmax(np.abs(spec))), spec.shape)
    fig, axes = _figure(2, size=(11, 4.6))
    h0 = axes[0].imshow(_db(a, floor), origin="lower", extent=_extent(x, y), cmap="gray",
                        vmin=floor, vmax=0, interpolation="nearest")
    axes[0].set_xlabel("x (east) [m]")
    axes[0].set_ylabel("y (north) [m]")
    axes[0].set_title(f"|f| (dB), {im.method or 'image'}")
    fig.colorbar(h0, ax=axes[0], label="dB")
    h1 = axes[1].imshow(sdb, origin="lower", extent=_extent(fx, fy), cmap="viridis",
                        vmin=floor, vmax=0, interpolation="nearest")
    axes[1].set_xlabel("spatial frequency x [cycles/m]")
    axes[1].set_ylabel("spatial frequency y [cycles/m]")
    axes[1].set_title("20 log10 |FFT2(f)| (dB)")
    fig.colorbar(h1, ax=axes[1], label="dB")
    _save(fig, path)
    return {"figure": fig, "spectrum_db": sdb, "fx": fx, "fy": fy,
            "spectral_peak_cycles_per_m": (float(fx[c]), float(fy[r]))}


# --------------------------------------------------------------------------------------------
# the PSF as a picture, iteration histories, error against time, annotated images
# --------------------------------------------------------------------------------------------
def plot_psf(img, path, *, dynamic_range_db=60.0):
    """Write a PNG of ``20 log10 |K|`` (north up, axes in metres).

    Parameters
    ----------
    img : sarcli.core.types.Image
    path : str or Path
    dynamic_range_db : float
        Colour scale from ``-dynamic_range_db`` to 0 dB (relative to the peak).
    """
    mag = np.abs(np.asarray(img.image))
    db = 20 * np.log10(np.maximum(mag / max(float(mag.max()), 1e-300), 1e-300))
    x, y = np.asarray(img.x_m), np.asarray(img.y_m)
    fig, (ax,) = _figure(size=(6, 5), layout=None)
    im = ax.imshow(db, origin="lower", cmap="gray", vmin=-abs(dynamic_range_db), vmax=0, extent=_extent(x, y))
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_title("PSF 20 log10|K| (dB)")
    fig.colorbar(im, ax=ax, label="dB")
    _save(fig, path)
    return path


def plot_history(history: dict, path) -> None:
    """Plot objective and relative change against iteration and elapsed time (PNG, atomic).

    Parameters
    ----------
    history : dict of str -> ndarray
        An :class:`~sarcli.core.types.Image`'s ``history`` (needs ``objective``, ``relative_change``,
        ``elapsed_s``).
    path : str or Path
    """
    if not history or "objective" not in history:
        raise SarcliInputError("the image has no iteration history to plot")
    obj = np.asarray(history["objective"])
    rel = np.asarray(history.get("relative_change", np.full(obj.size, np.nan)))
    t = np.asarray(history.get("elapsed_s", np.arange(obj.size)))
    it = np.arange(1, obj.size + 1)
    fig, axes = _figure(ncols=2, nrows=2, size=(9, 6))
    for col, (xv, xlabel) in enumerate([(it, "iteration"), (t, "elapsed (s)")]):
        axes[0, col].semilogy(xv, np.maximum(obj, np.finfo(float).tiny))
        axes[0, col].set_ylabel("objective")
        axes[1, col].semilogy(xv, np.maximum(rel, np.finfo(float).tiny))
        axes[1, col].set_ylabel("relative change")
        axes[1, col].set_xlabel(xlabel)
    _save(fig, path)


def plot_benchmark(result, path, *, title: str = ""):
    """``error_vs_time.png``: error vs time (log-log), one marker per method, each method's own
    frontier drawn thin in its colour and the overall Pareto front in black; a second panel with
    the error to the truth when one is known.

    Parameters
    ----------
    result : sarcli.batch.benchmark.BenchResult
    path : str or Path
    title : str
    """
    from pathlib import Path

    from .analysis.accuracy import pareto_front

    rows = result.rows
    has_truth = any(np.isfinite(r.error_truth) for r in rows)
    fig, axes = _figure(ncols=2 if has_truth else 1, size=(12 if has_truth else 7, 5), layout="tight")
    markers = {"direct": "*", "nufft": "o", "pfa": "s", "backprojection": "^"}
    floor = 1e-16  # error 0 (the reference itself) drawn at the float64 floor
    panels = [("error", "relative error vs exact matched filter")]
    if has_truth:
        panels.append(("error_truth", "relative error of |f| vs |truth|"))
    for ax, (attr, label) in zip(axes, panels):
        methods = list(dict.fromkeys(r.method for r in rows))
        for i, m in enumerate(methods):
            pts = [(r.seconds, getattr(r, attr)) for r in rows if r.method == m and np.isfinite(getattr(r, attr))]
            if not pts:
                continue
            t, e = np.array(pts).T
            e = np.maximum(e, floor)
            (line,) = ax.loglog(t, e, markers.get(m, "DvPX"[i % 4]), ls="none", alpha=0.75, label=m)
            own = pareto_front(e, t)
            if own.size > 1:  # the method's own frontier, in its colour
                ax.step(t[own], e[own], where="post", color=line.get_color(), lw=0.8, alpha=0.6)
        err = np.array([max(getattr(r, attr), floor) if np.isfinite(getattr(r, attr)) else np.nan for r in rows])
        sec = np.array([r.seconds for r in rows])
        front = pareto_front(err, sec)
        if front.size:
            ax.step(sec[front], err[front], where="post", color="k", lw=1.5, label="Pareto front (all)")
        ax.set_xlabel("run time (s, median)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(title or "error against run time")
    path = Path(path)
    with atomic_path(path) as tmp, open_held(tmp) as fh:
        fig.savefig(fh, dpi=110, format="png")
    return path


def image_figure(img, path, *, kind="db", dynamic_range_db=50.0, cmap="gray"):
    """An image as a figure: metre axes (east, north), title, colour bar (PNG, atomic).

    The pixels are the display values of :func:`sarcli.io.png.display_values` (``kind`` 'db' or
    'magnitude', ``dynamic_range_db``) in the matplotlib colormap ``cmap``.
    """
    from .io.png import colormap, display_values, png_text

    values = display_values(img, kind=kind, dynamic_range_db=dynamic_range_db)
    dr = float(dynamic_range_db)
    grid = img.grid
    extent = (img.x_m[0] - grid.dx / 2, img.x_m[-1] + grid.dx / 2,
              img.y_m[0] - grid.dy / 2, img.y_m[-1] + grid.dy / 2)
    width, height = extent[1] - extent[0], extent[3] - extent[2]
    aspect = height / width if width > 0 else 1.0
    fig, (ax,) = _figure(size=(6.4, float(np.clip(5.2 * aspect, 2.5, 9.0))), layout=None)
    if kind == "db":
        shown = values.astype(np.float64) * (dr / 255.0) - dr
        label, vmin, vmax = f"dB relative to peak ({dr:g} dB shown)", -dr, 0.0
    else:
        shown = values.astype(np.float64) / 255.0
        label, vmin, vmax = "|f| / max|f|", 0.0, 1.0
    # origin='lower' puts our row 0 (south) at the bottom: the figure is north-up
    im = ax.imshow(shown, origin="lower", extent=extent, cmap=colormap(cmap), vmin=vmin, vmax=vmax,
                   interpolation="nearest")
    ax.set_xlabel("x (east) [m]")
    ax.set_ylabel("y (north) [m]")
    ax.set_title(f"{img.method or 'image'}: {grid.nx} x {grid.ny} pixels of {grid.dx:.3g} m "
                 f"({width:.4g} m x {height:.4g} m)", fontsize=10)
    fig.colorbar(im, ax=ax, label=label)
    _save(fig, path, bbox_inches="tight",
          metadata=png_text(kind=kind, dynamic_range_db=dr, cmap=cmap, figure=True))
