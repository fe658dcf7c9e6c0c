"""Interpolation kernels of fast factorised backprojection and its error model.

:func:`optimal_kernel` designs the minimax interpolator (``optimal``) for a given oversampling;
:func:`deapodized_kernel` the exponential-of-semicircle kernel whose mean response is divided out
of the data (deapodization, :mod:`sarcli.formers.ffbp._image`); :func:`interp_error` is the RMS error of
one interpolation of an oversampled signal; :func:`predict_error` adds them up over the stages of
:mod:`sarcli.formers.ffbp`.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from ...core import sampling

__all__ = ["INTERPOLATORS", "NTAPS", "optimal_kernel", "optimal_weights", "interp_error", "angle_interp_error",
           "predict_error", "deapodized_kernel", "deapodized_response", "deapodized_error", "deapodized_slope",
           "deapodized_inverse", "deapodized_edge_error", "profile_alias_error", "default_upsample"]

#: Interpolator codes and taps (:data:`sarcli.core.sampling.INTERPOLATORS`). ``optimal``: the
#: 6-tap minimax kernel for the band of a signal oversampled as much as the grid it reads
#: (:func:`optimal_weights`, designed per oversampling, its weights polynomials in the fraction).
INTERPOLATORS = {name: i.code for name, i in sampling.INTERPOLATORS.items()}
NTAPS = {i.code: i.taps for i in sampling.INTERPOLATORS.values()}
#: Degree of the polynomials that give the ``optimal`` kernel's weights as functions of the fraction.
#: Degree 7 matches the weights to 1e-6 at β = 1 and 4e-8 at β = 2, far below the kernel's own
#: error; eight fused multiply-adds per tap vectorise, where a table look-up would not.
DEGREE = 7


#: Iterations of Lawson's reweighting that turn the least-squares starting weights into (near)
#: minimax ones.
LAWSON_ITERATIONS = 40
#: A sub-aperture of fewer pulses than this is an angular spectrum of that many lines
#: (:func:`interp_error`'s ``tones``); of more, a flat band.
MAX_TONE_LINES = 64
#: Decimals an angular oversampling is rounded to before its error is looked up (the look-ups are
#: cached; nearby frames share them).
BETA_DECIMALS = 3
#: Frequencies across the band on which the minimax weights are designed and the alias errors taken
#: (the band's edges included).
BAND_POINTS = 129
#: Chebyshev points the weight polynomials are fitted at (:func:`_poly_fit`).
FIT_POINTS = 32
#: Fractions and frequencies :func:`interp_error` averages over (midpoints of equal cells).
ERROR_FRACTIONS = 64
ERROR_FREQUENCIES = 128


def optimal_weights(beta: float, t, taps: int = 6) -> np.ndarray:
    """Minimax interpolation weights ``[len(t), taps]`` at fractions ``t`` for oversampling ``beta``.

    For each fraction t the real weights minimise the largest error
    ``max |1 − Σ_n w_n e^{2πiν(n − t)}|`` over ``|ν| ≤ 1/(2β)`` (offsets ``n = −taps/2+1 .. taps/2``),
    by Lawson's iteratively reweighted least squares from the least-squares weights.

    Minimax, not least squares: a least-squares stencil errs ~3.5× its band average at the band's
    edges (6 taps, β = 2: 4.7e-3 there, 1.4e-3 on average), and the edges carry the far sidelobes
    of every unwindowed point response: an image sampled away from its targets (or a dark region
    beside a bright one) sees the edge error, not the average. Minimax halves the error there
    (2.3e-3 at β = 2, 1.7e-4 at β = 3) for 1.2× the band average.
    """
    offs = np.arange(-(taps // 2 - 1), taps // 2 + 1)
    nu = np.linspace(-0.5, 0.5, BAND_POINTS) / float(beta)
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    a = np.exp(2j * np.pi * nu[None, :, None] * (offs[None, None, :] - t[:, None, None]))   # [t, ν, tap]
    m = np.concatenate([a.real, a.imag], axis=1)                                        # [t, 2ν, tap]
    b = np.concatenate([np.ones(nu.size), np.zeros(nu.size)])
    lw = np.ones((t.size, nu.size))
    # every fraction at once: weighted least squares by a batched pseudo-inverse (the minimum-norm
    # solution, as LAPACK's gelsd, where a narrow band makes the columns nearly dependent)
    rcond = np.finfo(np.float64).eps * max(m.shape[1:])
    for _ in range(LAWSON_ITERATIONS + 1):
        sw = np.sqrt(np.concatenate([lw, lw], axis=1))[:, :, None]
        x = np.linalg.pinv(m * sw, rcond=rcond) @ (b[None, :, None] * sw)                 # [t, tap, 1]
        fit = (m @ x)[:, :, 0]                                                            # Re, Im of a x
        err = np.hypot(1.0 - fit[:, :nu.size], fit[:, nu.size:])
        lw = lw * (err + 1e-300)
        lw /= lw.sum(axis=1, keepdims=True)
    return x[:, :, 0]


@functools.lru_cache(maxsize=64)
def optimal_kernel(beta: float, taps: int = 6) -> np.ndarray:
    """The ``optimal`` kernel for oversampling ``beta``: coefficients ``[tap, power]`` of
    polynomials of degree :data:`DEGREE` in ``x = 2t − 1`` (lowest power first) whose values at a
    fraction ``t ∈ [0, 1]`` are the :func:`optimal_weights` (fitted at :data:`FIT_POINTS` Chebyshev points).
    Shipped precomputed for :data:`TABLE_BETAS` (6 taps)."""
    if taps == 6:
        return _tabled("optimal", beta, lambda: _poly_fit(lambda t: optimal_weights(beta, t, 6)))
    return _poly_fit(lambda t: optimal_weights(beta, t, taps))


#: Oversamplings whose kernels and error tables ship precomputed in ``kernel_tables.npy`` beside
#: this module (:func:`kernel_tables`, written by ``scripts/make_kernel_tables.py``): every
#: oversampling that the planner's sweep and the defaults use, so that planning designs no kernel.
#: Any other oversampling is designed when first asked for (about a tenth of a second each).
TABLE_BETAS = (1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 16.0, 20.0, 24.0, 32.0, 48.0, 64.0,
               96.0)
TABLE_PATH = Path(__file__).with_name("kernel_tables.npy")
#: The tables and their shapes, in the order of their columns in ``kernel_tables.npy`` (after a
#: first column of β): the ``optimal`` and deapodized kernels' coefficients, the deapodized
#: kernel's mean response on :func:`_table_nu` and its alias rms on the band (129 frequencies).
_TABLES = {"optimal": (6, DEGREE + 1), "deapodized": (6, DEGREE + 1), "deapodized_mean": (2049,),
           "deapodized_alias": (129,)}


@functools.lru_cache(maxsize=1)
def _shipped() -> dict:
    """``{(table, β): array}`` from ``kernel_tables.npy`` (one row per β: β, then every table
    flattened, in the order of :data:`_TABLES`); empty if the file is missing or malformed."""
    try:
        rows = np.load(TABLE_PATH)
    except (OSError, ValueError):
        return {}
    width = 1 + sum(int(np.prod(shape)) for shape in _TABLES.values())
    if rows.ndim != 2 or rows.shape[1] != width:
        return {}
    rows.setflags(write=False)
    out, col = {}, 1
    for name, shape in _TABLES.items():
        size = int(np.prod(shape))
        for b, row in zip(rows[:, 0], rows[:, col:col + size]):
            out[(name, float(b))] = row.reshape(shape)
        col += size
    return out


def _tabled(name: str, beta: float, compute):
    """The shipped table ``name`` at ``beta`` if there is one, else ``compute()``."""
    hit = _shipped().get((name, float(beta)))
    return compute() if hit is None else hit


def kernel_tables(betas=TABLE_BETAS) -> np.ndarray:
    """Every shipped table at ``betas``: what ``kernel_tables.npy`` holds, a row per β (β, then
    each table of :data:`_TABLES` flattened)."""
    rows = []
    for b in map(float, betas):
        coef = _design_deapodized(b)
        tabs = {"optimal": _poly_fit(lambda t, b=b: optimal_weights(b, t, 6)), "deapodized": coef,
                "deapodized_mean": _mean_response(coef, b), "deapodized_alias": _alias_rms(coef, b)[1]}
        rows.append(np.concatenate([[b]] + [np.ravel(tabs[name]) for name in _TABLES]))
    return np.stack(rows)


def _poly_weights(coef, t):
    x = 2.0 * np.asarray(t, dtype=np.float64) - 1.0
    w = np.broadcast_to(coef[:, -1], x.shape + coef.shape[:1]).copy()     # Horner, [t, tap]
    for k in range(coef.shape[1] - 2, -1, -1):
        w = w * x[..., None] + coef[:, k]
    return w


def _kernel_weights(kind: int, t: np.ndarray, design_beta: float = 2.0):
    """(offsets, weights[len(t), taps]) of an interpolator at fractions ``t`` (as the kernels)."""
    t = np.asarray(t, dtype=np.float64)
    if kind == 0:
        return np.array([0, 1]), np.stack([1 - t, t], axis=-1)
    if kind == 1:
        d0, d2, d3 = t + 1, 1 - t, 2 - t
        w0 = ((2.5 - 0.5 * d0) * d0 - 4) * d0 + 2
        w1 = (1.5 * t - 2.5) * t * t + 1
        w2 = (1.5 * d2 - 2.5) * d2 * d2 + 1
        w3 = ((2.5 - 0.5 * d3) * d3 - 4) * d3 + 2
        return np.arange(-1, 3), np.stack([w0, w1, w2, w3], axis=-1)
    if kind == 4:
        a, b, c = t + 1, t - 1, t - 2
        return np.arange(-1, 3), np.stack([-t * b * c / 6, a * b * c / 2, -a * t * c / 2, a * t * b / 6], axis=-1)
    offs = np.arange(-2, 4)
    if kind == 3:
        return offs, _poly_weights(optimal_kernel(float(design_beta)), t)
    d = t[:, None] - offs[None, :]
    w = np.sinc(d) * np.sinc(d / 3.0) * (np.abs(d) < 3)
    return offs, w / w.sum(axis=1, keepdims=True)


def _es_weights(t, beta_es, taps=6):
    """Weights ``ψ(n − t)`` of the exponential-of-semicircle kernel ``ψ(x) = exp(β(√(1 − (2x/w)²) − 1))``
    (``w = taps``; Barnett, Magland and af Klinteberg 2019, the kernel of FINUFFT)."""
    offs = np.arange(-(taps // 2 - 1), taps // 2 + 1)
    x = offs[None, :] - np.asarray(t, dtype=np.float64)[:, None]
    z = np.maximum(1.0 - (2.0 * x / taps) ** 2, 0.0)
    return np.where(z > 0, np.exp(beta_es * (np.sqrt(z) - 1.0)), 0.0)


def _poly_fit(w_of_t):
    """Coefficients ``[tap, power]`` of degree-:data:`DEGREE` polynomials in ``x = 2t − 1`` through
    the weights ``w_of_t(t) [len(t), taps]`` at :data:`FIT_POINTS` Chebyshev points."""
    x = np.cos(np.pi * (np.arange(FIT_POINTS) + 0.5) / FIT_POINTS)
    cheb = np.polynomial.chebyshev.chebfit(x, w_of_t(0.5 * (x + 1.0)), DEGREE)     # [DEGREE+1, taps]
    coef = np.ascontiguousarray(np.stack([np.polynomial.chebyshev.cheb2poly(cheb[:, j])
                                          for j in range(cheb.shape[1])]))
    coef.setflags(write=False)
    return coef


def _response(coef, nu, t):
    """``H(ν, t) = Σ_n w_n(t) e^{2πiν(n − t)}`` [ν, t] of the polynomial weights ``coef``."""
    offs = np.arange(-(coef.shape[0] // 2 - 1), coef.shape[0] // 2 + 1)
    return _stencil_response(offs, _poly_weights(coef, t), np.asarray(nu, dtype=np.float64), np.asarray(t))


def _stencil_response(offs, w, nu, t):
    """``Σ_n w[t, n] e^{2πiν(n − t)}`` [ν, t] as ``e^{−2πiνt} (E W^T)``, ``E = e^{2πiνn}``: two small
    tables of exponentials and one product instead of one exponential per (ν, t, tap)."""
    arg = 2 * np.pi * nu[:, None] * offs[None, :]                                      # [ν, tap]
    wt = np.ascontiguousarray(np.asarray(w, dtype=np.float64).T)     # real products stay in BLAS
    return np.exp(-2j * np.pi * nu[:, None] * t[None, :]) * ((np.cos(arg) @ wt) + 1j * (np.sin(arg) @ wt))


def _alias_rms(coef, beta, n_nu=BAND_POINTS, n_t=256):
    """``(ν, e(ν))`` over the band ``|ν| ≤ 1/(2β)``: the rms over fractions of ``H(ν, t) − H̄(ν)``,
    relative to ``H̄(ν)``: what is left of an interpolation once its mean response ``H̄`` is
    divided out."""
    nu = np.linspace(-0.5, 0.5, n_nu) / float(beta)
    h = _response(coef, nu, (np.arange(n_t) + 0.5) / n_t)
    hm = h.mean(axis=1)
    return nu, np.sqrt(np.mean(np.abs(h - hm[:, None]) ** 2, axis=1)) / np.abs(hm)


def _fluctuation(coef, beta, n_nu=BAND_POINTS, n_t=256, rms=False):
    """Largest (``rms``: the rms) over the band of :func:`_alias_rms`."""
    e = _alias_rms(coef, beta, n_nu, n_t)[1]
    return float(np.sqrt(np.mean(e * e)) if rms else np.max(e))


@functools.lru_cache(maxsize=64)
def deapodized_kernel(beta: float) -> np.ndarray:
    """The kernel of ffbp's range interpolations for oversampling ``beta``: weight polynomials
    (as :func:`optimal_kernel`) of a 6-tap exponential-of-semicircle kernel, to be used with its
    mean response divided out of the data (:func:`deapodized_response`).

    An interpolation with weights ``ψ(n − t)`` responds to the frequency ν with
    ``Ψ(ν) + Σ_{m≠0} Ψ(ν + m) e^{−2πimt}`` (Poisson): a mean ``Ψ(ν)`` that does not depend on where
    the point falls, and aliases that do. Where an interpolation reads a known frequency of each
    data sample, ``Ψ`` is divided out of the data beforehand, as a NUFFT divides out its kernel's
    transform, and only the aliases remain: 1.8e-5 at β = 2 and 1.5e-4 at β = 1.5
    (:func:`deapodized_error`), against 2.3e-3 and 1.7e-2 for the best stencil without the
    division (:func:`optimal_weights`). In ffbp that holds exactly for the range profiles (bin
    ``j − j_c`` of an FFT of length L is the frequency ``(j − j_c)/L``) and nearly for the polar
    grids' range q (frequency ``(k_j − k_ref) Δq / 2π`` where a pulse's range grows with q as the
    sub-aperture centre's: see :func:`sarcli.formers.ffbp.plan_stages` for when it does not). The shape parameter is
    ``γ π w (1 − 1/(2β))`` with γ picked from 0.95, 0.96, 0.97 (the best for β from 1.25 to 3) for
    the smallest alias error; the weights are scaled so that ``Ψ(0) = 1``.
    """
    return _tabled("deapodized", beta, lambda: _design_deapodized(float(beta)))


def _design_deapodized(beta: float) -> np.ndarray:
    best = None
    for gamma in (0.95, 0.96, 0.97):
        coef = _poly_fit(lambda t: _es_weights(t, gamma * np.pi * 6 * (1.0 - 0.5 / float(beta))))
        err = _fluctuation(coef, beta, n_nu=65, n_t=64)
        if best is None or err < best[0]:
            best = (err, coef)
    g, gw = np.polynomial.legendre.leggauss(16)
    dc = float(np.sum(_poly_weights(best[1], 0.5 * (g + 1.0)).sum(axis=1) * 0.5 * gw))   # Ψ(0)
    coef = np.ascontiguousarray(best[1] / dc)
    coef.setflags(write=False)
    return coef


def _table_nu(beta: float) -> np.ndarray:
    return np.linspace(-1.0, 1.0, 2049) * (0.6 / float(beta))


def _mean_response(coef, beta: float) -> np.ndarray:
    """``Ψ`` at :func:`_table_nu`: the exact mean over fractions (Gauss-Legendre, 48 points, of a
    polynomial times an exponential) of the response; real, the kernel being even."""
    g, gw = np.polynomial.legendre.leggauss(48)
    nu = _table_nu(beta)
    return np.concatenate([_response(coef, nu[a:a + 1024], 0.5 * (g + 1.0)).real @ (0.5 * gw)
                           for a in range(0, nu.size, 1024)])


@functools.lru_cache(maxsize=64)
def _deapodized_table(beta: float):
    beta = float(beta)
    return _table_nu(beta), _tabled("deapodized_mean", beta, lambda: _mean_response(deapodized_kernel(beta), beta))


@functools.lru_cache(maxsize=64)
def _deapodized_alias(beta: float) -> np.ndarray:
    """:func:`_alias_rms` of the deapodized kernel over its band (129 frequencies)."""
    beta = float(beta)
    return _tabled("deapodized_alias", beta, lambda: _alias_rms(deapodized_kernel(beta), beta)[1])


def deapodized_response(beta: float, nu) -> np.ndarray:
    """Mean response ``Ψ(ν)`` of :func:`deapodized_kernel` at frequencies ``nu`` (cycles per sample;
    within 1.2 times the band ``|ν| ≤ 1/(2β)``), from a table (linear interpolation, ~1e-7)."""
    tab_nu, tab_h = _deapodized_table(float(beta))
    return np.interp(nu, tab_nu, tab_h)


@functools.lru_cache(maxsize=64)
def deapodized_edge_error(beta: float) -> float:
    """:func:`deapodized_error` at its worst frequency (the band's edges, where Ψ is smallest):
    near β = 1 Ψ vanishes there and dividing it out is no longer worth it."""
    return float(np.max(_deapodized_alias(float(beta))))


@functools.lru_cache(maxsize=64)
def deapodized_error(beta: float) -> float:
    """Relative error of one interpolation by :func:`deapodized_kernel` with its mean response
    divided out: the aliases' rms over fractions and the band (7.0e-6 at β = 2, 5.1e-5 at 1.5;
    at the band's edge 2.5 to 3 times that). The rms, not the edge value as for the minimax
    stencils: with Ψ divided out the edges no longer carry the error coherently from stage to
    stage (measured on the 2048² circle, four levels at β = 1.5: 9.6e-4 against 1.0e-3 predicted
    this way and 2.5e-3 from the edge values)."""
    e = _deapodized_alias(float(beta))
    return float(np.sqrt(np.mean(e * e)))


def deapodized_inverse(beta: float):
    """``(h, 1/Ψ)``: the reciprocal of :func:`deapodized_response` at ``ν = 0, h, 2h, ...`` up to
    1.2 times the band (a table for compiled kernels; Ψ is even)."""
    nu, h = _deapodized_table(float(beta))
    half = nu.size // 2
    return float(nu[half + 1] - nu[half]), np.ascontiguousarray(1.0 / h[half:])


@functools.lru_cache(maxsize=64)
def deapodized_slope(beta: float) -> float:
    """The rms over the band ``|ν| ≤ 1/(2β)`` of ``d ln Ψ / dν``: the relative error per
    cycle-per-sample that dividing out ``Ψ`` at frequencies off by ``δν`` leaves over the band
    (``≈ slope · |δν|``; the largest, at the band's edge, is ~2.5 times this)."""
    nu, h = _deapodized_table(float(beta))
    inside = np.abs(nu) <= 0.5 / float(beta) + 1e-12
    return float(np.sqrt(np.mean(np.gradient(np.log(h), nu)[inside] ** 2)))


@functools.lru_cache(maxsize=256)
def profile_alias_error(upsample: float, os_range: float, n_levels: int) -> float:
    """Error of the deapodized range profiles where the polar grids' range kernel is deapodized
    too (``n_levels`` range interpolations, each divided out at the pulse's tone).

    The profiles' aliases are periodic in the profile bin, so on polar nodes ``Δq`` apart
    (``r = upsample/os_range`` bins) a tone at ``ν`` (cycles per polar sample) leaves aliases at
    ``ν ± m r`` folded into the band. The tone was amplified by ``Ψ(ν)^{−S}`` beforehand; an alias
    landing at ``ν'`` is attenuated by ``Ψ(ν')^S`` only, so it grows by ``(Ψ(ν')/Ψ(ν))^S``: up to
    ``0.2^{−S}`` at β = 1.5 where ``ν`` is at the band edge and ``ν'`` at its centre. Where ``r`` is
    an integer the aliases land on the tone itself and nothing grows, hence the default
    ``upsample`` = a multiple of ``os_range``. Returns the rms over the band of the amplified
    aliases for the worst fold ``m`` (measured on the 2048² circle, four levels at os_range 1.5:
    3.6e-3 at upsample 2 against 9.6e-4 at upsample 1.5)."""
    up, os_r = float(upsample), float(os_range)
    nu_p, fluct = np.linspace(-0.5, 0.5, BAND_POINTS) / up, _deapodized_alias(up)
    nu = nu_p * up / os_r
    worst = float(np.sqrt(np.mean(fluct * fluct)))
    for m in (1, -1, 2, -2):
        dest = (nu + m * up / os_r + 0.5) % 1.0 - 0.5
        inside = np.abs(dest) <= 0.6 / os_r
        gain = (deapodized_response(os_r, np.clip(dest, -0.6 / os_r, 0.6 / os_r))
                / deapodized_response(os_r, nu)) ** int(n_levels)
        worst = max(worst, float(np.sqrt(np.mean(np.where(inside, fluct * gain, 0.0) ** 2))))
    return worst


def default_upsample(os_range: float) -> float:
    """Profile upsampling of the ``optimal`` kernels: the smallest multiple of ``os_range`` of at
    least 1.5, so that the deapodized profiles' aliases land on their own tones on the polar grids
    (:func:`profile_alias_error`)."""
    return float(os_range) * float(np.ceil(1.5 / float(os_range) - 1e-9))


@functools.lru_cache(maxsize=1024)
def interp_error(interp: str, beta: float, tones: int = 0, design_beta: float | None = None) -> float:
    """RMS relative error of interpolating a signal oversampled ``beta`` times.

    ``sqrt(⟨|1 − Σ_n K(t − n) e^{−2πiν(n − t)}|²⟩)`` averaged over fractions ``t ∈ [0, 1)`` and
    frequencies ν (cycles per sample) spread over ``|ν| ≤ 1/(2β)``: uniformly (a flat spectrum,
    ``tones=0``), or as ``tones`` equally spaced lines from edge to edge, the angular spectrum of a
    sub-aperture of that many equally spaced pulses (two pulses put all their energy at the band
    edges, where interpolation errs most). ``design_beta``: the oversampling the ``optimal``
    kernel was designed for (default ``beta``).
    """
    kind = INTERPOLATORS[interp]
    t = (np.arange(ERROR_FRACTIONS) + 0.5) / ERROR_FRACTIONS
    if tones <= 0:
        nu = (np.arange(ERROR_FREQUENCIES) + 0.5) / ERROR_FREQUENCIES - 0.5
    elif tones == 1:
        nu = np.zeros(1)
    else:
        nu = np.linspace(-0.5, 0.5, int(tones))
    nu = nu / float(beta)
    offs, w = _kernel_weights(kind, t, beta if design_beta is None else design_beta)   # [T, taps]
    resp = _stencil_response(offs, w, nu, t)                  # [V, T]
    return float(np.sqrt(np.mean(np.abs(1.0 - resp) ** 2)))


def angle_interp_error(interp: str, beta: float, n_pulses: int, os_angle: float) -> float:
    """:func:`interp_error` of a level's angular interpolation: a sub-aperture of ``n_pulses``
    (its spectrum: that many lines, or a flat band from :data:`MAX_TONE_LINES` on) sampled at
    oversampling ``beta``, by the kernel designed for ``os_angle``."""
    n = int(n_pulses)
    return interp_error(interp, float(round(beta, BETA_DECIMALS)), n if n < MAX_TONE_LINES else 0, float(os_angle))


def predict_error(levels, *, interp="cubic", os_range=2.0, os_angle=2.0, upsample=4.0, profiles_deapodized=False,
                  range_deapodized=False, range_mismatch=0.0, angle_deapodized=False, angle_mismatch=0.0) -> float:
    """Predicted relative error of FFBP against the exact matched filter (module docstring).

    ``levels``: for every polar level that is interpolated (each merge reads its children's level,
    the final stage the last one), ``(pulses per sub-aperture, angular oversampling)``. Every
    interpolation mostly *attenuates* the upper part of the band, the same way at every stage, so
    the errors add coherently: ``ε ≈ ε_prof + Σ_levels (ε_range + ε_angle(pulses, β))`` (measured:
    adding them in quadrature under-predicts three-stage runs by 1.7×). Where the plan deapodizes
    the profiles' kernel (``profiles_deapodized``), the polar grids' range kernel
    (``range_deapodized``) or their angular kernel (``angle_deapodized``), their terms are
    :func:`deapodized_error` at the kernel's design oversampling (the profiles' with the growth of
    their aliases, :func:`profile_alias_error`), and the frequency mismatches
    ``range_mismatch`` and ``angle_mismatch`` are added once.
    """
    if profiles_deapodized:
        total = profile_alias_error(float(upsample), float(os_range), len(levels)) if range_deapodized else \
            deapodized_error(float(upsample))
    else:
        total = interp_error(interp, float(upsample))
    e_range = deapodized_error(float(os_range)) if range_deapodized else interp_error(interp, float(os_range))
    total += range_mismatch + angle_mismatch
    for n_pulses, beta in levels:
        total += e_range
        total += deapodized_error(float(os_angle)) if angle_deapodized else \
            angle_interp_error(interp, beta, n_pulses, os_angle)
    return float(total)


def frequency_error(freq_hz, antenna_position_m, grid) -> float:
    """Relative error from treating the frequencies as equally spaced (range profiles by FFT).

    Backprojection and ffbp place frequency ``j`` on the least-squares line
    (:func:`sarcli.core.sampling.frequency_line`); a deviation ``δ_pj`` from it (GOTCHA's float32
    frequencies are off by ~3e-4 Δα) turns into the phase ``4π δ Δr / c`` at differential range
    ``Δr``. RMS over samples and pixels: ``4π rms(δ) rms(Δr) / c`` with
    ``rms(Δr) = max(W, H) cos φ / √12`` for a W × H grid seen at elevation φ.
    """
    _, rms_hz = sampling.spacing_deviation(freq_hz)
    a = np.asarray(antenna_position_m, dtype=np.float64)
    cos_el = float(np.mean(np.hypot(a[:, 0], a[:, 1]) / np.linalg.norm(a, axis=1)))
    rms_dr = max(grid.nx * grid.dx, grid.ny * grid.dy) * cos_el / np.sqrt(12.0)
    return float(sampling.range_wavenumbers(rms_hz) * rms_dr)
