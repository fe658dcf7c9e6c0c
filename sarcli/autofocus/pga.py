"""Phase gradient autofocus (PGA) for any flight path.

The textbook algorithm (Wahl, Eichel, Ghiglia and Jakowatz 1994; Jakowatz et al., *Spotlight-Mode
Synthetic Aperture Radar*, ch. 4) works on range-compressed data, one range line per dominant
scatterer. Here each dominant scatterer's signal across pulses is taken directly from the data
compensated to that scatterer's own exact range history (:func:`pulse_signals`), so it is
``a_k exp(i ε_p)`` times the scatterer's residual linear phase, whatever the geometry, far or near
field, monostatic or bistatic. Then, per iteration:

1. *Selection*: the ``n_scatterers`` brightest pixels of the current image, each at least
   ``separation`` pixels from the others (one per neighbourhood, the analogue of one per range
   line), each placed at its peak to a fraction of a pixel (:func:`peak_positions`): a
   scatterer's signal compensated to a point ``δ`` away carries ``k δ·u_p``, the change of the look
   direction ``u_p`` along ``δ``, which is linear in the look angle (removed by the centre shift)
   only on a level path; where the elevation changes (a climbing path) an offset across range
   adds a smooth phase of its own (2° of climb at 30° elevation, Ku band: about 12 rad per metre,
   0.7 rad at the ends for half a pixel of 0.125 m).
2. *Centre shift*: the FFT across pulses of each scatterer's signal is its cross-range line
   (pulse angle and cross-range are a Fourier pair over a small aperture); its peak is shifted to
   zero frequency (removes the scatterer's linear phase).
3. *Weighting* (:func:`scatterer_weights`): a line whose peak stands no higher over its clutter
   (the median of its centred intensity) than speckle does is dropped, the others weigh
   ``1/clutter``.
   *Windowing*: a window about zero frequency whose width is where the scatterers' summed,
   centred intensity stays above ``window_db`` of its peak (it narrows as the image focuses),
   never narrower than ``min_window`` resolution cells; the first iteration uses the full width.
   The FFTs are zero-padded four times so the centre shift is good to a quarter cell.
4. *Phase-gradient estimate*: the inverse FFT gives each scatterer's windowed phase history
   ``g_k[p]``; by default the maximum-likelihood estimate (Jakowatz and Wahl 1993), the phase of
   the principal eigenvector of ``Σ_k g_k g_kᴴ``, whose successive differences are the phase
   gradient, recomputed :data:`REWEIGHT` times with each line weighted by ``1/σ_k²``, the power
   per pulse the model ``a_k v`` leaves of it; ``estimator='gradient'`` is the classic
   ``Δε_p = arg Σ_k g_k[p] conj(g_k[p-1])``.
5. *Integration*: ``ε_p = Σ_{q ≤ p} Δε_q`` (the eigenvector's phase is already integrated),
   constant and linear part removed (unobservable).
6. *Iteration*: apply, re-image, repeat until the rms increment is below ``tol`` rad; the
   iterate whose image has the lowest entropy is returned (a narrow window can drift once the
   image is focused).

The decision (``guard``, ``validate``). The estimate is applied only if it leaves the image no
less sharp (entropy not up, peak-to-mean not down, :func:`~sarcli.autofocus._common.keep_if_sharper`)
*and* passes a cross-validation like minimum entropy's (:mod:`sarcli.autofocus.entropy`): PGA is
run on each of two disjoint halves of the scene alone (across range, with a band between them);
the two estimates must agree modulo ``2π`` (:func:`halves_agreement`) with a correlation above
``max(1/3, chance)`` (:func:`~sarcli.autofocus._common.agreement_threshold`), differ by at most
:data:`MAX_PREDICTED_RESIDUAL_RAD` (the noise of their mean), predict for the whole scene's
estimate a residual below the error they are sure of
(:func:`~sarcli.autofocus._levels.predicted_residual`), and, each applied to the other half,
lower the entropy in sum. What was decided is ``result.code``
(:data:`~sarcli.autofocus._common.DECISION_CODES`). A phase error is common to the
scene; what PGA fits to one half's clutter is not, and on a focused scene it can still pass the
sharpness test alone. (Each half's own gain is not required: a half's PGA estimate, from half
the scatterers, carries noise of its own that can cost the other half more than the common error
it removes; on a 32 m window of GOTCHA with an injected 1 rad error one gain is slightly
negative.) On a grid too narrow across range for two halves nothing is applied, and
the decision says why: there the sharpness test is no evidence (what PGA fits sharpens a focused
scene as readily as the true error a blurred one).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..analysis.speckle import image_entropy
from .._util.options import with_options
from ..core.grid import Grid
from ..errors import SarcliInputError
from ._common import (AutofocusResult, AutofocusWarning, agreement_threshold, correlation, estimation_grid, form,
                      keep_if_sharper, pulse_signals, remove_linear_phase)

__all__ = ["pga", "PGAOptions", "select_scatterers", "phase_gradient_estimate", "scatterer_weights", "principal_vector",
           "ESTIMATORS"]

#: Phase estimators of one PGA step: maximum likelihood (principal eigenvector) or the classic
#: phase-difference estimate.
ESTIMATORS = ("eigen", "gradient")


def _check_estimator(estimator) -> None:
    if estimator not in ESTIMATORS:
        raise SarcliInputError(f"unknown PGA estimator {estimator!r}; choose one of {', '.join(ESTIMATORS)}")


def select_scatterers(image, n: int, separation: int):
    """Row, column of the ``n`` brightest pixels, pairwise at least ``separation`` pixels apart."""
    mag = np.abs(np.asarray(image)).astype(np.float64)
    order = np.argsort(mag, axis=None)[::-1]
    ny, nx = mag.shape
    taken = np.zeros_like(mag, dtype=bool)
    rows, cols = [], []
    for idx in order:
        r, c = divmod(int(idx), nx)
        if taken[r, c]:
            continue
        rows.append(r)
        cols.append(c)
        taken[max(r - separation, 0):r + separation + 1, max(c - separation, 0):c + separation + 1] = True
        if len(rows) == n:
            break
    return np.array(rows), np.array(cols)


def peak_positions(image, rows, cols, grid: Grid) -> np.ndarray:
    """x, y (m) of the selected pixels' peaks, each refined to a fraction of a pixel by a parabola
    through the log magnitude of the pixel and its two neighbours along each axis."""
    lm = np.log(np.abs(np.asarray(image)).astype(np.float64) + 1e-300)
    ny, nx = lm.shape
    out = np.column_stack([grid.x[cols], grid.y[rows]]).astype(np.float64)
    for k, (r, c) in enumerate(zip(rows, cols)):
        for axis, (i, n, d) in enumerate(((c, nx, grid.dx), (r, ny, grid.dy))):
            if 0 < i < n - 1:
                a, b, e = ((lm[r, i - 1], lm[r, i], lm[r, i + 1]) if axis == 0
                           else (lm[i - 1, c], lm[i, c], lm[i + 1, c]))
                den = a - 2.0 * b + e
                if den < 0:
                    out[k, axis] += d * float(np.clip(0.5 * (a - e) / den, -0.5, 0.5))
    return out


def phase_gradient_estimate(signals, window_db=-10.0, min_window=4, full=False, estimator="eigen",
                            oversample: int = 4):
    """One PGA step on scatterer signals ``z[p, k]``: centre shift, window, gradient, integration.

    The cross-range lines are FFTs zero-padded ``oversample`` times, so the centre shift is good
    to a fraction of a resolution cell (an integer-bin shift leaves each scatterer a residual
    linear phase, and a window cut across its main lobe biases the estimate).

    Returns
    -------
    phase : ndarray, shape (P,)
        The integrated estimate (constant part not removed).
    width : float
        The window width used, in resolution cells (bins of the unpadded FFT).
    """
    _check_estimator(estimator)
    z = np.asarray(signals, dtype=np.complex128)
    P, K = z.shape
    L = oversample * P
    Z = np.fft.fft(z, n=L, axis=0)
    peak = np.argmax(np.abs(Z), axis=0)  # centre shift: each scatterer's peak to bin 0
    idx = (np.arange(L)[:, None] + peak[None, :]) % L
    Z = np.take_along_axis(Z, idx, axis=0)
    offs = np.fft.fftfreq(L) * L  # signed fine-bin offsets from the centre
    Z = Z * np.sqrt(scatterer_weights(np.abs(Z) ** 2, P))[None, :]
    if full:
        half = L / 2
    else:
        power = np.sum(np.abs(Z) ** 2, axis=1)
        above = power >= power[0] * 10.0 ** (window_db / 10.0)
        # the contiguous run about bin 0 above the threshold
        right = np.argmin(above[1:L // 2]) if not np.all(above[1:L // 2]) else L // 2
        left = np.argmin(above[::-1][:L // 2 - 1]) if not np.all(above[::-1][:L // 2 - 1]) else L // 2
        half = max(2.0 * max(right, left) + oversample, min_window * oversample / 2.0)
    if half < L / 2:
        Z = Z * (np.abs(offs) <= half)[:, None]
    g = np.fft.ifft(Z, axis=0)[:P]
    width = float(min(2 * half, L) / oversample)
    if estimator == "eigen":
        # maximum likelihood (Jakowatz and Wahl 1993): the phase of the principal eigenvector of
        # Σ_k g_k g_kᴴ, i.e. the first left singular vector of [g_1 ... g_K]
        v = principal_vector(g)
        # then each line weighted by what the model a_k v leaves of it (a second scatterer on
        # the line, clutter in the window): maximum likelihood with unequal, estimated noise
        for _ in range(REWEIGHT):
            v = principal_vector(g * np.sqrt(_model_weights(g, v))[None, :], start=v)
        return np.unwrap(np.angle(v * np.conj(v[0]))), width
    grad = np.angle(np.sum(g[1:] * np.conj(g[:-1]), axis=1))
    return np.concatenate([[0.0], np.cumsum(grad)]), width


#: Eigenvectors recomputed with each line weighted by the power the model leaves of it.
REWEIGHT = 3


def _model_weights(g, v) -> np.ndarray:
    """``1 / σ_k²``: each line's power left outside the model ``a_k v`` (``a_k = vᴴ g_k``), per pulse."""
    a = np.einsum("p,pk->k", np.conj(v), g)   # numpy's loop, not BLAS (see principal_vector)
    resid = np.sum(np.abs(g - np.outer(v, a)) ** 2, axis=0) / g.shape[0]
    # a line the model fits exactly (one pulse, or noise-free data) is not infinitely sure
    floor = 1e-12 * np.sum(np.abs(g) ** 2, axis=0) / g.shape[0]
    live = floor > 0
    return np.where(live, 1.0 / np.maximum(resid, np.where(live, floor, 1.0)), 0.0)


def scatterer_weights(intensity, n_pulses: int) -> np.ndarray:
    """Weights of the selected scatterers in one PGA step, from their centred cross-range lines
    ``intensity[bin, k]`` (peak at bin 0): ``1 / c_k`` for the scatterers whose peak stands at
    least :func:`dominance` above their line's clutter ``c_k`` (the median intensity of the
    line), 0 for the others.

    A selected pixel's signal is its whole range line: ``a_k e^{iε_p}`` plus the clutter of that
    line, of power ``c_k`` per cell. The maximum-likelihood estimate with clutter of unequal power
    weights each line by ``1/c_k`` (the principal eigenvector of ``Σ_k g_k g_kᴴ / c_k``; Jakowatz
    and Wahl 1993 assume equal powers). A pixel of speckle (an extended scene has no dominant
    scatterer) has a peak no higher over its line's median than the brightest of its ``P`` cells
    reaches by chance, about ``log2 P`` (exponential intensities; the median is ``ln 2`` of the
    mean); its phase history is not ``a_k e^{iε_p}`` and only adds noise. Where no line passes,
    those at least half as dominant as the most dominant one are kept (a strong error lowers every
    peak; the decision then judges the estimate).
    """
    inten = np.asarray(intensity, dtype=np.float64)
    # a line without clutter (noise-free points) is not infinitely sure either
    clutter = np.maximum(np.median(inten, axis=0), 1e-12 * inten[0])
    live = clutter > 0
    contrast = np.where(live, inten[0] / np.where(live, clutter, 1.0), 0.0)
    keep = live & (contrast >= min(dominance(n_pulses), 0.5 * float(np.max(contrast))))
    return np.where(keep, 1.0 / np.where(live, clutter, 1.0), 0.0)


def dominance(n_pulses: int) -> float:
    """Least peak-to-median intensity of a dominant scatterer's cross-range line: twice what the
    brightest of ``P`` speckle cells reaches (``2 log2 P``)."""
    return 2.0 * np.log2(max(n_pulses, 2))


def principal_vector(g, tol: float = 1e-12, max_iter: int = 1000, start=None) -> np.ndarray:
    """The first left singular vector of ``g`` (P × K) by power iteration on ``g gᴴ``.

    Two matrix-vector products per step instead of a full SVD (a LAPACK call whose threads
    contend on a loaded machine); stops when ``1 - |⟨u_k, u_{k+1}⟩|`` is below ``tol``. ``start``:
    the first vector (a previous estimate; default ``g gᴴ e_0``). The products run in numpy's own
    loops (``einsum``), not BLAS: OpenBLAS spreads each of these small products over every core
    and its threads spin between them, which cost 60 × the time (and twice the processor time of
    the whole of PGA) on a busy two-core machine.
    """
    gh = np.ascontiguousarray(np.conj(g).T)
    # g gᴴ e_0 (a start with a component along the principal vector), or the one given
    u = np.einsum("pk,k->p", g, gh[:, 0]) if start is None else np.asarray(start, dtype=g.dtype).copy()
    if not np.any(u):
        u = np.ones(g.shape[0], dtype=g.dtype)
    u = u / np.linalg.norm(u)
    for _ in range(max_iter):
        w = np.einsum("pk,k->p", g, np.einsum("kp,p->k", gh, u))
        n = np.linalg.norm(w)
        if n == 0:
            break
        w = w / n
        done = 1.0 - abs(np.vdot(u, w)) < tol
        u = w
        if done:
            break
    return u


@dataclass(frozen=True)
class PGAOptions:
    """The knobs of :func:`pga` (each also a keyword argument of it).

    Attributes
    ----------
    n_scatterers : int, optional
        Dominant scatterers per iteration (default: as many as grid rows, 32 to 256; the textbook
        one per range line).
    separation : int
        Least distance between selected scatterers, pixels.
    window_db, min_window : float, int
        Window threshold on the centred intensity (dB) and its least width (bins).
    max_iter, tol : int, float
        Iteration cap and the rms phase increment (rad) that counts as converged.
    guard : bool
        Keep the estimate only when it sharpens the image (:func:`keep_if_sharper`).
    start : array_like, optional
        Initial phase estimate (rad, per pulse).
    estimator : {'eigen', 'gradient'}
        Maximum likelihood (default) or the classic phase-difference estimate
        (:func:`phase_gradient_estimate`); anything else is a :class:`~sarcli.errors.SarcliInputError`.
    validate : bool
        With ``guard``: apply the estimate only when PGA's estimates from two halves of the scene
        agree beyond chance and, each applied to the other half, lower its entropy in sum (module
        docstring).
    """

    n_scatterers: int | None = None
    separation: int = 3
    window_db: float = -10.0
    min_window: int = 4
    max_iter: int = 10
    tol: float = 2e-3
    guard: bool = True
    start: object = None
    estimator: str = "eigen"
    validate: bool = True


def pga(ph, *, grid: Grid | None = None, options: PGAOptions | None = None, **knobs) -> AutofocusResult:
    """Phase gradient autofocus (see the module docstring for the steps).

    Parameters
    ----------
    ph : PhaseHistory
    grid : Grid, optional
        Image grid the scatterers are selected on (default the acquisition's, cut to
        :func:`estimation_grid`).
    options : PGAOptions, optional
        The knobs (default ``PGAOptions()``).
    **knobs
        Fields of :class:`PGAOptions` given as keyword arguments (``pga(ph, max_iter=4)``); they
        replace those of ``options``.

    Returns
    -------
    AutofocusResult
    """
    o = with_options(PGAOptions, options, knobs)
    n_scatterers, separation, window_db, min_window = o.n_scatterers, o.separation, o.window_db, o.min_window
    max_iter, tol, start, estimator = o.max_iter, o.tol, o.start, o.estimator
    _check_estimator(estimator)
    acq = ph.acquisition
    grid = estimation_grid(grid or acq.grid, acq=acq)
    P = ph.data.shape[0]
    n = n_scatterers or int(np.clip(grid.ny, 32, 256))
    phi = np.zeros(P) if start is None else np.asarray(start, np.float64).copy()
    hist = {"rms_increment_rad": [], "window_bins": [], "entropy": []}
    best_h, best_phi = np.inf, phi
    it = 0
    for it in range(1, max_iter + 1):
        img = form(ph, grid, phi)
        h = image_entropy(img)
        hist["entropy"].append(h)
        if h < best_h:
            best_h, best_phi = h, phi
        rows, cols = select_scatterers(img, n, separation)
        pts = peak_positions(img, rows, cols, grid)
        z = pulse_signals(ph, pts) * np.exp(-1j * phi)[:, None]
        inc, width = phase_gradient_estimate(z, window_db, min_window, full=(it == 1 and start is None),
                                             estimator=estimator)
        inc = remove_linear_phase(inc, acq.azimuth_rad)
        phi = remove_linear_phase(phi + inc, acq.azimuth_rad)
        rms = float(np.sqrt(np.mean(inc ** 2)))
        hist["rms_increment_rad"].append(rms)
        hist["window_bins"].append(width)
        if rms < tol:
            break
    h = image_entropy(form(ph, grid, phi))
    hist["entropy"].append(h)
    if h < best_h:
        best_h, best_phi = h, phi
    # the iterate of lowest entropy (a narrowing window can drift once the image is focused)
    res = AutofocusResult(best_phi, "pga", iterations=it, history=hist)
    if o.guard:
        from ._sharpness import sharpness_imager

        res = keep_if_sharper(ph, grid, res, [best_phi, phi], sharpness_imager(ph, grid))
        if o.validate and np.any(res.phase_rad):
            _crossvalidate(ph, grid, res, o)
    return res


#: Largest rms noise (rad) the halves of the scene may predict for PGA's estimate for it to be
#: applied (:func:`_crossvalidate`, half the rms of the halves' difference): below it the residual
#: costs a point at most 4 % of its peak energy (``1 - exp(-σ²)``); above it the halves' own
#: spread says the estimate is mostly noise.
MAX_PREDICTED_RESIDUAL_RAD = 0.2


def halves_agreement(a, b, gauge) -> tuple[float, float]:
    """Agreement of two halves' estimates modulo ``2π``: their correlation once ``b`` is moved by
    whole turns (and an unobservable constant and linear phase) to lie nearest ``a``, and half the
    rms of what still separates them.

    With ``a = ε + n_a`` and ``b = ε + n_b`` (independent noise of power ``N`` each), the whole
    scene's estimate carries noise of about ``N/2``, whose rms is half that of ``a - b``: the second
    number predicts the residual of the estimate that is applied.
    """
    from ._levels import predicted_residual, wrapped, without_gauge

    a = np.asarray(a, np.float64)
    d = wrapped(without_gauge(wrapped(a - np.asarray(b, np.float64)), gauge))
    return correlation(a, a - d), predicted_residual(a, a, b, gauge)["spread_rad"]


def _crossvalidate(ph, grid: Grid, res: AutofocusResult, options: PGAOptions) -> None:
    """Keep ``res``'s estimate only if PGA's estimates from the two halves of ``grid`` agree (modulo
    ``2π``) beyond chance and beyond ``1/3``, lower each other's entropy in sum, differ by at most
    :data:`MAX_PREDICTED_RESIDUAL_RAD` (half the rms of their difference, the noise of their
    mean), and predict for it a residual below the least error they are sure of
    (:func:`~sarcli.autofocus._levels.predicted_residual`: the spread plus the whole scene's
    departure from their mean, against ``√⟨a, b⟩`` less two standard errors); else reject it (in
    place), the reason in ``res.code`` and the decision.

    The correlation ``ρ = s/(s + n)`` of two halves (``s`` the common error's power, ``n`` one
    half's noise) says the whole scene's estimate (noise about ``n/2``) is nearer the error than
    no correction only when ``ρ > 1/3``; chance alone (``2/√dof``) lets through estimates that are
    mostly noise (on a scene of five points in extended clutter the halves correlated 0.27,
    chance 0.13, and the estimate left more error than it removed). The departure counts what the
    whole scene's iterations reach that neither half does (a drift of the window, a scatterer
    one half lacks).
    """
    from ._imager import SPLIT_GAP, range_axis, split_grid
    from ._levels import gauge_basis, predicted_residual

    acq = ph.acquisition
    try:
        halves = split_grid(grid, range_axis(acq), SPLIT_GAP)[:2]
    except SarcliInputError:
        # no two halves: the sharpness of so narrow a window is no evidence (what PGA fits there
        # sharpens a focused scene as readily as the true error a blurred one)
        why = (f"the grid of {grid.nx} x {grid.ny} pixels is too narrow across range to compare two halves of "
               f"the scene")
        res.history["decision"] = f"not cross-validated, so not applied: {why}"
        res.reject(code="not_cross_validated")
        warnings.warn(f"autofocus (pga) applied no correction: {why}", AutofocusWarning, stacklevel=4)
        return
    ests = [pga(ph, grid=g, options=options, guard=False, validate=False).phase_rad for g in halves]
    h0 = [image_entropy(form(ph, g)) for g in halves]
    gains = (h0[0] - image_entropy(form(ph, halves[0], ests[1])), h0[1] - image_entropy(form(ph, halves[1], ests[0])))
    gauge = gauge_basis(acq)
    corr, _ = halves_agreement(ests[0], ests[1], gauge)
    trust = predicted_residual(res.phase_rad, ests[0], ests[1], gauge)
    chance = agreement_threshold(max(1, ph.data.shape[0] - 2))
    need = max(1.0 / 3.0, chance)
    res.history.update(heldout_gain=gains, halves_correlation=corr, predicted_residual_rad=trust["predicted_rad"],
                       trust=trust)
    facts = (f"correlation {corr:.2f}, needed {need:.2f}; halves' spread {trust['spread_rad']:.3f} rad rms, needed at "
             f"most {MAX_PREDICTED_RESIDUAL_RAD:g}; predicted residual {trust['predicted_rad']:.3f} (spread + departure "
             f"{trust['departure_rad']:.3f}), needed below {trust['signal_low_rad']:.3f}, the error the halves are sure "
             f"of; held-out gains {gains[0]:.4f}, {gains[1]:.4f} nats, needed positive in sum")
    if (sum(gains) > 0 and corr > need and trust["spread_rad"] <= MAX_PREDICTED_RESIDUAL_RAD
            and trust["trusted"]):
        res.history["decision"] = (f"it lowers the entropy and does not lower the peak-to-mean ratio, and PGA's "
                                   f"estimates from the two halves of the scene agree and lower each other's "
                                   f"entropy in sum ({facts})")
        return
    if corr <= chance or sum(gains) <= 0:
        why, code = "no error common to the scene", "no_common_error"
    else:
        why, code = "an error common to the scene, but PGA's estimate of it is too uncertain to apply", "untrusted"
    res.history["decision"] = (f"{why}: PGA's estimates from the two halves of the scene fail a test ({facts}), "
                               f"so nothing is applied")
    res.reject(code=code)
