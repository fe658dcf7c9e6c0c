"""Fast factorised backprojection against the exact matched filter (``direct``), and its error model.

Scenes: a circular path, a straight climbing path with a wiggle, far-field data (virtual antennas),
and separate transmit/receive positions. Each checks the measured relative error against
``direct`` and that the predicted error (:func:`sarcli.formers.ffbp.model.predict_error`) lies
within a factor 3 of it.
"""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from sarcli.core import geometry
from sarcli.core.acquisition import Acquisition
from sarcli.core.grid import Grid
from sarcli.core.types import PhaseHistory
from sarcli.errors import SarcliInputError
from sarcli.formers.direct import direct_spherical
from sarcli.formers.ffbp import ffbp, plan_stages
from sarcli.formers.ffbp.model import (_poly_weights, deapodized_error, deapodized_kernel, deapodized_response,
                                       interp_error, optimal_kernel, optimal_weights)
from sarcli.formers.formation import form_image, image_error
from sarcli.core.collection import Collection

GRID = Grid(48, 48, 0.3, 0.3)
FREQ = 9.7e9 + 4e6 * np.arange(96)
RNG = np.random.default_rng(3)
POINTS = np.column_stack([RNG.uniform(-6, 6, 8), RNG.uniform(-6, 6, 8), np.zeros(8)])
AMPS = RNG.normal(size=8) + 1j * RNG.normal(size=8)


def point_data(a, r0, freq=FREQ, rcv=None):
    """Closed-form spherical data of POINTS seen from positions ``a`` (and ``rcv``)."""
    dr = geometry.differential_range(a, r0, POINTS) if rcv is None else \
        geometry.bistatic_differential_range(a, rcv, r0, POINTS)
    psi = 4 * np.pi / geometry.C * freq[None, :, None] * dr[:, None, :]
    return (np.exp(-1j * psi) * AMPS).sum(-1)


def circle(P=96, r0=3e3, aperture_deg=6.0):
    az = np.radians(np.linspace(-aperture_deg / 2, aperture_deg / 2, P))
    a = geometry.antenna_positions_circle(az, np.radians(35), r0)
    return a, np.linalg.norm(a, axis=1)


def climbing_line(P=96):
    s = np.linspace(-1, 1, P)
    a = np.column_stack([-2500 + 15 * np.sin(3 * s), 300 * s, 1500 + 60 * s])   # climbs and weaves
    return a, np.linalg.norm(a, axis=1)


def check(data, a, r0, *, rcv=None, tol=1e-2, **knobs):
    ref = direct_spherical(data, FREQ, a, r0, GRID, receive_position_m=rcv)
    img, plan = ffbp(data, Collection(FREQ, a, r0, receive_position_m=rcv), GRID, return_plan=True, **knobs)
    err = image_error(img, ref)
    assert err <= tol, (err, plan.predicted_error)
    assert plan.predicted_error / 3 <= err <= 3 * plan.predicted_error, (err, plan.predicted_error)
    return err, plan


@pytest.mark.parametrize("geometry_fn", [circle, climbing_line])
def test_ffbp_matches_direct_default_knobs(geometry_fn):
    a, r0 = geometry_fn()
    # measured 1.3e-4 (circle), 4.3e-4 (climbing line)
    check(point_data(a, r0), a, r0, tol={circle: 1e-3, climbing_line: 2e-3}[geometry_fn])


@pytest.mark.parametrize("knobs", [dict(interp="cubic", os_range=3, os_angle=3, upsample=8, tol=5e-2),
                                   dict(interp="lagrange", os_range=3, os_angle=3, upsample=8, tol=5e-2),
                                   dict(interp="optimal", os_range=3, os_angle=3, base=4, tol=2e-5),
                                   dict(interp="linear", os_range=4, os_angle=4, upsample=8, tol=0.2),
                                   dict(interp="optimal", base=2, merge=3, tol=1e-3),
                                   dict(interp="optimal", os_range=1.5, upsample=3.0, tol=5e-4)])
# measured 1.6e-2, 1.3e-2, 3.6e-6, 5.3e-2, 1.5e-4, 8.4e-5
def test_ffbp_knobs_and_error_model(knobs):
    """Several stages and kernels: measured within tol, predicted within 3x of measured. Upsample
    3 over os_range 1.5 puts two profile bins between polar nodes, so stage 0 takes its gather
    path (the default's node spacing of one bin takes the contiguous runs)."""
    a, r0 = circle(P=192)
    tol = knobs.pop("tol")
    err, plan = check(point_data(a, r0), a, r0, tol=tol, **knobs)
    assert plan.n_stages >= 1


def test_ffbp_merges_in_stages():
    """A long aperture on a small grid is merged over several stages, still within the model."""
    a, r0 = circle(P=512, aperture_deg=8.0)
    err, plan = check(point_data(a, r0), a, r0, base=2, final=2, tol=5e-3)   # measured 9.2e-4
    assert plan.n_stages >= 3


@pytest.mark.parametrize("os_range, os_angle, tol", [(3.0, 1.5, 1e-3), (1.5, 2.5, 5e-4), (2.0, 2.5, 1e-4)])
# measured 5.5e-4, 2.5e-4, 4.2e-5 (4 stages)
def test_ffbp_unequal_oversampling_over_several_stages(os_range, os_angle, tol):
    """Unequal range and angle oversampling through several merges (the planner's sweep offers
    such pairs): each stage's range and angle kernels are their own, so a merge that interpolated
    in angle with the range kernel (or the reverse) leaves the exact matched filter."""
    a, r0 = circle(P=256, aperture_deg=8.0)
    err, plan = check(point_data(a, r0), a, r0, os_range=os_range, os_angle=os_angle, base=8, merge=2,
                      final=4, tol=tol)
    assert plan.n_stages >= 3
    assert (plan.knobs["os_range"], plan.knobs["os_angle"]) == (os_range, os_angle)


@pytest.mark.parametrize("knobs, tol", [(dict(interp="cubic", os_range=3, os_angle=3, upsample=8), 0.08),
                                        (dict(interp="linear", os_range=4, os_angle=4, upsample=8), 0.3),
                                        (dict(interp="lanczos", os_range=3, os_angle=2), 0.08)])
# measured 4.7e-2, 1.7e-1, 5.0e-2 (4 stages)
def test_ffbp_analytic_kernels_over_several_stages(knobs, tol):
    """The linear, Keys cubic and Lanczos kernels through several merges: the merges' separable
    path has a branch of its own for kernels of other than six taps."""
    a, r0 = circle(P=256, aperture_deg=8.0)
    err, plan = check(point_data(a, r0), a, r0, base=8, merge=2, final=4, tol=tol, **knobs)
    assert plan.n_stages >= 3


def test_ffbp_bistatic_positions():
    a, r0 = circle()
    rcv = a + np.array([0.0, 40.0, 5.0])
    r0b = 0.5 * (np.linalg.norm(a, axis=1) + np.linalg.norm(rcv, axis=1))
    err, plan = check(point_data(a, r0b, rcv=rcv), a, r0b, rcv=rcv, tol=1e-3)   # measured 1.4e-4
    assert plan.band_scale == (1.0, 1.0)   # a short baseline keeps the tones in the nominal bands


@pytest.mark.parametrize("offset", [(0.0, 600.0, 100.0), None])
def test_ffbp_wide_bistatic_geometry_samples_its_grids_finer(offset):
    """A 600 m baseline, and a fixed receiver 3 km from the transmitters' path: the polar grids
    are centred on the mean of transmit and receive positions, so the pulses' tones reach past
    the grids' nominal bands (range 14×, angle 4× for the fixed receiver). The plan samples the
    grids finer to hold them (at the nominal sampling they image at 1.7e-2 and 1.28 relative error)."""
    a, r0 = circle()
    rcv = a + np.array(offset) if offset is not None else np.broadcast_to([0.0, 3000.0, 800.0], a.shape).copy()
    r0b = 0.5 * (np.linalg.norm(a, axis=1) + np.linalg.norm(rcv, axis=1))
    err, plan = check(point_data(a, r0b, rcv=rcv), a, r0b, rcv=rcv, tol=5e-3)
    assert max(plan.band_scale) > 1.2


def test_ffbp_farfield_through_form_image():
    """Far-field data through virtual antennas, as backprojection images them."""
    P = 96
    az = np.radians(np.linspace(-3, 3, P))
    el = np.full(P, np.radians(30))
    psi = geometry.signal_phase(FREQ, az, el, POINTS, model="farfield")
    data = (np.exp(-1j * psi) * AMPS).sum(-1)
    ph = PhaseHistory(data, Acquisition(FREQ, az, el, GRID, model="farfield"))
    ref = form_image(ph, "direct").image
    img = form_image(ph, "ffbp")
    err = image_error(img.image, ref)
    assert err <= 1e-3   # measured 1.2e-4
    # virtual antennas ~1e9 m away: stage 0's range series would round too much, so it is not used
    import sarcli.formers.ffbp._stage0 as mod
    from sarcli.formers.families import range_positions
    pos, _, r0 = range_positions(ph, GRID)
    plan = plan_stages(pos, FREQ, GRID)
    assert not mod.series_inputs(pos, pos, r0, plan.levels[0], plan.dq, 4 * np.pi * FREQ.max() / geometry.C)[1].any()
    pred = img.parameters["predicted_error"]
    assert pred / 3 <= err <= 3 * pred
    assert img.parameters["virtual_range_m"] > 1e6 and img.method == "ffbp"


def test_interp_error_model_orders():
    """The kernels' modelled errors fall with oversampling, and the optimal kernel beats cubic."""
    assert interp_error("cubic", 4) < interp_error("cubic", 2) < interp_error("linear", 2)
    assert interp_error("optimal", 3) < 0.05 * interp_error("cubic", 3)
    t = np.linspace(0.0, 1.0, 101)
    w = _poly_weights(optimal_kernel(2.0), t)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-2)   # nearly a partition of unity


def _band_errors(w_of_t, offs, beta, divide=None):
    """Per frequency over the band, the rms over fractions of |tone − interpolated tone| (after
    dividing by ``divide(ν)``): interpolation of ``e^{2πiνn}`` at n = t from its samples."""
    t = (np.arange(97) + 0.5) / 97
    nu = np.linspace(-0.5, 0.5, 61) / beta
    w = w_of_t(t)                                                       # [t, taps]
    samples = np.exp(2j * np.pi * nu[:, None, None] * offs[None, None, :])   # tone at the stencil
    got = np.einsum("tn,vtn->vt", w, np.broadcast_to(samples, (nu.size, t.size, offs.size)))
    if divide is not None:
        got = got / divide(nu)[:, None]
    return np.sqrt(np.mean(np.abs(got - np.exp(2j * np.pi * nu[:, None] * t[None, :])) ** 2, axis=1))


def test_minimax_kernel_halves_the_band_edge_error():
    """Minimax weights: at β = 2 the worst frequency errs 2.3e-3 (least squares: 4.7e-3 at the band
    edges), measured by interpolating tones from their samples."""
    offs = np.arange(-2, 4)
    e = _band_errors(lambda t: _poly_weights(optimal_kernel(2.0), t), offs, 2.0)
    assert e.max() < 2.6e-3
    assert e.max() < 1.6 * np.sqrt(np.mean(e ** 2))   # nearly level over the band


@pytest.mark.parametrize("beta", [1.5, 2.0, 4.0])
def test_deapodized_kernel_closed_form(beta):
    """Interpolating a tone with the deapodized kernel and dividing by its mean response Ψ(ν)
    returns the tone to the modelled alias error (rms over the band 5.1e-5 at β = 1.5, 7e-6 at
    β = 2; at most 3.5× that at the edges), 100× below the minimax stencil; Ψ(0) = 1 and Ψ is even."""
    offs = np.arange(-2, 4)
    coef = deapodized_kernel(beta)
    e = _band_errors(lambda t: _poly_weights(coef, t), offs, beta, lambda nu: deapodized_response(beta, nu))
    assert np.sqrt(np.mean(e ** 2)) <= 1.2 * deapodized_error(beta)
    assert e.max() <= 3.5 * deapodized_error(beta)
    if beta <= 2:
        assert deapodized_error(beta) < 0.02 * interp_error("optimal", beta)
    assert abs(deapodized_response(beta, 0.0) - 1) < 2e-15   # measured 3.3e-16 (β = 1.5), 0
    nu = np.linspace(0, 0.5 / beta, 7)
    np.testing.assert_allclose(deapodized_response(beta, nu), deapodized_response(beta, -nu), rtol=1e-9)


def test_polar_kernels_deapodized_only_where_the_mismatch_allows():
    """A level circle far away: both polar kernels are deapodized at the pulses' own tones, the
    default sampling drops to 1.5 in range and angle, and it measures within its prediction. The
    climbing, weaving path at 3 km changes the depression angle along the aperture (a pulse's range
    tone moves off ``k_j``): per-pulse tones keep it deapodized too, within 3× of its prediction
    (``check``). A near-field circle (60 m, 40°) spreads the range tones over its grid so much that
    the range kernel stays the minimax stencil, at the default 2."""
    a, r0 = circle(P=192, r0=1e4, aperture_deg=1.0)
    plan = plan_stages(a, FREQ, GRID)
    assert plan.range_deapodized and plan.knobs["os_range"] == 1.5
    assert plan.angle_deapodized and plan.knobs["os_angle"] == 1.5
    data = point_data(a, r0)
    img, plan = ffbp(data, Collection(FREQ, a, r0), GRID, return_plan=True)
    err = image_error(img, direct_spherical(data, FREQ, a, r0, GRID))
    assert err <= min(plan.predicted_error, 1e-3), (err, plan.predicted_error)
    a, r0 = climbing_line()
    err, plan = check(point_data(a, r0), a, r0, tol=2e-3)
    assert plan.range_deapodized and plan.angle_deapodized
    a, r0 = circle(P=192, r0=60.0, aperture_deg=40.0)
    plan = plan_stages(a, FREQ, GRID)
    assert not plan.range_deapodized and plan.knobs["os_range"] == 2.0


def test_tone_weights_match_the_mean_responses():
    """The compiled weights are ``Π_l 1/Ψ(k_j a[l, p] + b)`` (NumPy's table of Ψ), per pulse."""
    from sarcli.formers.ffbp._stage0 import tone_weights
    from sarcli.formers.ffbp.model import deapodized_inverse

    rng = np.random.default_rng(2)
    k = (4 * np.pi * FREQ / geometry.C)[None, :]
    a = rng.uniform(-1.6e-3, 1.6e-3, (3, 5)) / 1.5 / k.max()
    b = -0.1
    h, inv = deapodized_inverse(1.5)
    out = np.full((5, FREQ.size), 2.0)
    tone_weights(k, a, b, 1.0 / h, inv, out)
    ref = 2.0 / np.prod(deapodized_response(1.5, k[None, 0, :] * a[:, :, None] + b), axis=0)
    np.testing.assert_allclose(out, ref, rtol=1e-6)


def test_kernels_write_only_in_place():
    """A kernel's output that would need a converted copy (not C-contiguous, or another dtype) is
    refused rather than written to a copy and lost."""
    from sarcli.formers.ffbp._kernels import native

    k = np.ones((1, 4))
    a = np.zeros((1, 3))
    inv = np.ones(8)
    with pytest.raises(TypeError):
        native().tone_weights(k, a, 0.0, 1.0, inv, np.ones((4, 3)).T)
    with pytest.raises(TypeError):
        native().tone_weights(k, a, 0.0, 1.0, inv, np.ones((3, 4), np.float32))
    out = np.ones((3, 4))
    native().tone_weights(k, a, 0.0, 1.0, inv, out)
    np.testing.assert_array_equal(out, 1.0)


def test_profile_upsample_is_a_multiple_of_the_range_sampling():
    """Deapodized profiles at upsample r·os_range alias onto their own tones (r an integer); at
    upsample 2 over os_range 1.5 the aliases land elsewhere in the band and grow by the polar
    deapodization (:func:`profile_alias_error`): the default is os_range itself."""
    from sarcli.formers.ffbp.model import profile_alias_error

    assert profile_alias_error(1.5, 1.5, 4) <= 1.01 * deapodized_error(1.5)
    assert profile_alias_error(2.0, 1.5, 4) > 10 * deapodized_error(2.0)
    a, r0 = circle(P=192, r0=1e4, aperture_deg=1.0)
    assert plan_stages(a, FREQ, GRID).knobs["upsample"] == 1.5
    assert plan_stages(a, FREQ, GRID, os_range=2.0).knobs["upsample"] == 2.0


def test_profiles_deapodized_only_where_it_pays():
    """At upsample 1.5 the profiles' kernel is deapodized (5e-5); at upsample 1 its mean response
    nearly vanishes at the band edge and the minimax stencil is kept (its error in the prediction)."""
    a, r0 = circle()
    fine = plan_stages(a, FREQ, GRID)
    assert fine.profiles_deapodized and fine.knobs["upsample"] == 1.5
    coarse = plan_stages(a, FREQ, GRID, upsample=1.0)
    assert not coarse.profiles_deapodized
    assert coarse.predicted_error > fine.predicted_error + 0.5 * interp_error("optimal", 1.0)


@pytest.mark.parametrize("beta", [1.0, 1.5, 2.0, 4.0])
def test_optimal_kernel_polynomials_match_minimax_weights(beta):
    """The degree-7 polynomials the kernels evaluate are the minimax weights to 5e-6 at any
    fraction (not only the fit points; 3e-6 at β = 1, whose kernel errs 1e-1), and the compiled
    evaluation equals NumPy's."""
    from sarcli.formers.ffbp._kernels import row_weights

    t = np.random.default_rng(5).random(40)
    coef = optimal_kernel(beta)
    w = _poly_weights(coef, t)
    # measured 2.8e-6, 7.2e-8, 1.9e-8, 9.4e-10 at β = 1, 1.5, 2, 4
    assert np.max(np.abs(w - optimal_weights(beta, t))) < {1.0: 5e-6, 1.5: 5e-7, 2.0: 1e-7, 4.0: 5e-9}[beta]
    np.testing.assert_allclose(row_weights(3, t, coef).T, w, rtol=0, atol=1e-13)
    # the kernels' float32 evaluation: float32 rounding of the same polynomials
    np.testing.assert_allclose(row_weights(3, t.astype(np.float32), coef).T, w, rtol=0, atol=1e-6)   # measured 1.1e-7


@pytest.mark.parametrize("kind", [0, 1, 2, 4])
def test_analytic_kernel_weights(kind):
    """The compiled linear, Keys cubic (a = -1/2), normalised Lanczos-3 and cubic Lagrange weights,
    against their formulas at each tap's distance from the point."""
    from sarcli.formers.ffbp._kernels import row_weights

    t = np.random.default_rng(6).random(30)
    offs = {0: np.arange(0, 2), 1: np.arange(-1, 3), 2: np.arange(-2, 4), 4: np.arange(-1, 3)}[kind]
    d = np.abs(t[None, :] - offs[:, None])
    if kind == 0:
        ref = 1.0 - d
    elif kind == 1:
        ref = np.where(d <= 1, (1.5 * d - 2.5) * d * d + 1, ((2.5 - 0.5 * d) * d - 4) * d + 2)
    elif kind == 4:   # Π_{m≠n} (t - m) / (n - m)
        ref = np.stack([np.prod([(t - m) / (n - m) for m in offs if m != n], axis=0) for n in offs])
    else:
        ref = np.sinc(d) * np.sinc(d / 3)
        ref /= ref.sum(axis=0)
    # Lanczos-3 is float32 in every family (numerics/lanczos.hpp), so its float64 weights are those
    # rounded: measured 0, 6.2e-16, 1.3e-7 (float64), 3.7e-8, 3.4e-7, 1.3e-7 (float32)
    np.testing.assert_allclose(row_weights(kind, t), ref, rtol=0, atol=5e-15 if kind != 2 else 1e-6)
    np.testing.assert_allclose(row_weights(kind, t.astype(np.float32)), ref, rtol=0, atol=1e-6)


def test_ffbp_refuses_nadir_inside_the_grid():
    a = np.column_stack([np.linspace(-5, 5, 16), np.zeros(16), np.full(16, 1000.0)])
    r0 = np.linalg.norm(a, axis=1)
    with pytest.raises(SarcliInputError, match="nadir"):
        ffbp(point_data(a, r0), Collection(FREQ, a, r0), GRID)


@pytest.mark.parametrize("n, size, merge", [(469, 8, 4), (2048, 8, 4), (800, 8, 4), (40, 8, 4), (1000, 8, 3),
                                            (17, 1, 4), (3, 8, 2)])
def test_split_gives_equal_groups_and_an_even_tree(n, size, merge):
    """Sub-apertures differ by at most one pulse, there are at least ceil(n/size) and at most a
    quarter more, and when rounded up the count is r·merge^a so the merges group them evenly."""
    from sarcli.formers.ffbp._grids import _split

    first, count = _split(n, size, merge)
    k = -(-n // size)
    assert count.sum() == n and np.all(first == np.concatenate([[0], np.cumsum(count)[:-1]]))
    assert count.max() - count.min() <= 1
    assert k <= first.size <= max(k, 1.25 * k)
    if first.size > k:
        a = 1
        while first.size % merge ** (a + 1) == 0:
            a += 1
        assert first.size // merge ** a < 2 * merge
    f2, c2 = _split(first.size, merge)   # the parents of one merge stage: children differ by <= 1
    assert c2.max() - c2.min() <= 1 and c2.sum() == first.size


def test_plan_stages_counts_operations():
    a, _ = circle(P=256)
    plan = plan_stages(a, FREQ, GRID, base=4)
    assert plan.ops["stage0"] > 0 and plan.ops["final"] > 0
    assert plan.levels[0].n == 64


def test_cli_form_image_ffbp(tmp_path):
    """`sar form-image --method ffbp` records its knobs and predicted error."""
    from sarcli.cli.main import cli
    from sarcli.io.hdf5 import read_image, write_phase_history

    a, r0 = circle()
    az, el, _ = geometry.angles_from_positions(a)
    ph = PhaseHistory(point_data(a, r0), Acquisition(FREQ, az, el, GRID, antenna_position_m=a,
                                                     range_to_center_m=r0, model="spherical"))
    src = tmp_path / "ph.h5"
    write_phase_history(src, ph)
    out = tmp_path / "img.h5"
    res = CliRunner().invoke(cli, ["-q", "form-image", str(src), "-o", str(out), "--method", "ffbp",
                                   "--os-angle", "3", "--base", "4"])
    assert res.exit_code == 0, res.output
    img = read_image(out)
    assert img.method == "ffbp" and img.parameters["os_angle"] == 3 and img.parameters["base"] == 4
    assert 0 < img.parameters["predicted_error"] < 1e-3   # measured 1.0e-4


@pytest.mark.parametrize("bistatic", [False, True])
def test_stage0_range_series_matches_exact_ranges(monkeypatch, bistatic):
    """Stage 0's range series (``series_inputs``) gives the image of the exact square roots."""
    import sarcli.formers.ffbp._stage0 as mod

    a, r0 = circle(P=128)
    rcv = a + np.array([0.0, 40.0, 5.0]) if bistatic else None
    if bistatic:
        r0 = 0.5 * (np.linalg.norm(a, axis=1) + np.linalg.norm(rcv, axis=1))
    data = point_data(a, r0, rcv=rcv)
    fast = ffbp(data, Collection(FREQ, a, r0, receive_position_m=rcv), GRID)
    plan = plan_stages(a if rcv is None else 0.5 * (a + rcv), FREQ, GRID)
    _, series = mod.series_inputs(a, a if rcv is None else rcv, r0, plan.levels[0], plan.dq,
                                   4 * np.pi * FREQ.max() / geometry.C)
    assert series.all()            # 3 km range, short sub-apertures: the series holds everywhere
    monkeypatch.setattr(mod, "SERIES_PHASE", -1.0)   # no tail is small enough: exact everywhere
    exact = ffbp(data, Collection(FREQ, a, r0, receive_position_m=rcv), GRID)
    assert image_error(fast, exact) < 1e-7   # measured 1.4e-8 (monostatic), 2.7e-8 (bistatic)


def test_stage0_range_series_falls_back_in_the_near_field():
    """A long sub-aperture seen from close by keeps the exact square root (the tail bound fails)."""
    import sarcli.formers.ffbp._stage0 as mod

    a, r0 = circle(P=1024, r0=100.0, aperture_deg=40.0)
    kmax = 4 * np.pi * FREQ.max() / geometry.C
    plan = plan_stages(a, FREQ, GRID, base=256)
    _, series = mod.series_inputs(a, a, r0, plan.levels[0], plan.dq, kmax)
    assert not series.any()
    _, series = mod.series_inputs(a, a, r0, plan_stages(a, FREQ, GRID, base=16).levels[0], plan.dq, kmax)
    assert series.all()
    check(point_data(a, r0), a, r0, base=256, tol=2e-2)


def test_ffbp_keeps_targets_at_the_image_edge():
    """Points on the outermost pixels, several merge stages: the polar grids' extensions hold
    every stencil there (the border pixels are as accurate as the rest)."""
    h = GRID.nx * GRID.dx / 2 - GRID.dx / 2
    pts = np.array([[-h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0], [h, -h, 0.0], [0.0, h, 0.0], [h, 0.0, 0.0]])
    a, r0 = circle(P=384, aperture_deg=8.0)
    dr = geometry.differential_range(a, r0, pts)
    data = np.exp(-1j * 4 * np.pi / geometry.C * FREQ[None, :, None] * dr[:, None, :]).sum(-1)
    ref = direct_spherical(data, FREQ, a, r0, GRID)
    img, plan = ffbp(data, Collection(FREQ, a, r0), GRID, base=4, merge=2, final=2, return_plan=True)
    assert plan.n_stages >= 4
    border = np.zeros(GRID.shape, bool)
    border[:3] = border[-3:] = True
    border[:, :3] = border[:, -3:] = True
    err_border = np.linalg.norm((img - ref)[border]) / np.linalg.norm(ref[border])
    assert err_border <= 2 * max(image_error(img, ref), plan.predicted_error), (err_border, image_error(img, ref))


def test_rows_form_every_node_later_stencils_read():
    """Seen from close by the scene's near edge spans a wider u than its far edge, so each polar
    row forms only the nodes later stencils can read (``_Level.rows``): over several merges, with
    points on the image's edges, the image equals the one formed from whole rows to float32
    rounding, and rows cut shorter by a few nodes more than their slack are seen to miss."""
    import dataclasses

    h = GRID.nx * GRID.dx / 2 - GRID.dx / 2
    pts = np.array([[-h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0], [h, -h, 0.0], [0.0, h, 0.0], [h, 0.0, 0.0],
                    [-h, 0.0, 0.0], [0.0, -h, 0.0], [1.0, 2.0, 0.0]])
    a, r0 = circle(P=384, r0=40.0, aperture_deg=8.0)
    dr = geometry.differential_range(a, r0, pts)
    data = np.exp(-1j * 4 * np.pi / geometry.C * FREQ[None, :, None] * dr[:, None, :]).sum(-1)
    col = Collection(FREQ, a, r0)
    plan = plan_stages(a, FREQ, GRID, base=8, merge=2, final=2)
    assert plan.n_stages >= 4
    last = plan.levels[-1]
    assert last.nodes < 0.75 * last.n * last.n_u * last.n_q   # rows are cut (0.66 of the nodes formed)
    img = ffbp(data, col, GRID, plan=plan)
    full = ffbp(data, col, GRID, plan=dataclasses.replace(
        plan, levels=[dataclasses.replace(lv, rows=None) for lv in plan.levels]))
    assert np.abs(img - full).max() < 1e-5 * np.abs(full).max()   # measured 2e-7

    def cut(lv, k):   # k nodes fewer at each end a row that is cut there
        rows = lv.rows.copy()
        rows[..., 0] += k * (rows[..., 0] > 0)
        rows[..., 1] -= k * (rows[..., 1] < lv.n_q)
        rows[..., 1] = np.maximum(rows[..., 1], rows[..., 0])
        return dataclasses.replace(lv, rows=rows)

    short = ffbp(data, col, GRID, plan=dataclasses.replace(plan, levels=[cut(lv, 10) for lv in plan.levels]))
    assert np.abs(short - full).max() > 1e-3 * np.abs(full).max()
    # 3 km away the grids' far and near ranges differ by under RANGE_RATIO: whole rows
    far, _ = circle(P=384, aperture_deg=8.0)
    assert all(lv.rows is None for lv in plan_stages(far, FREQ, GRID, base=8, merge=2, final=2).levels)


def test_polar_nodes_that_are_no_ground_point_stay_out():
    """25 m from a 14 m scene, 4-pulse sub-apertures: stage 0's grids, extended by their coarse
    angular spacing, reach past |u| = 1, where a node is no ground point (NaN coordinates). Those
    nodes contribute nothing, so the image is finite and near the exact one (their NaN stencil
    starts once indexed outside the grids). The error model does not cover such grids (measured
    4.2e-2 where it gives 1.2e-3): the plan promises no accuracy (UNCOVERED_ERROR, so auto passes
    it by) and ffbp warns with the reach. 200 m away the same pulses' grids stay on the ground."""
    import warnings
    from sarcli.errors import SarcliWarning
    from sarcli.formers.ffbp._grids import ground_reach
    from sarcli.formers.ffbp._plan import UNCOVERED_ERROR

    a, r0 = circle(P=384, r0=25.0, aperture_deg=8.0)
    plan = plan_stages(a, FREQ, GRID, base=4)
    lv = plan.levels[0]
    assert np.max(np.abs(lv.u0)) > 1   # the grids reach past the ground
    assert ground_reach(plan.levels) > 1 and plan.predicted_error >= UNCOVERED_ERROR
    data = point_data(a, r0)
    with pytest.warns(SarcliWarning, match=r"\|u\| = [0-9.]+ > 1, past the ground"):
        img = ffbp(data, Collection(FREQ, a, r0), GRID, plan=plan)
    assert np.isfinite(img).all()
    assert image_error(img, direct_spherical(data, FREQ, a, r0, GRID)) < 0.1
    far, rf = circle(P=384, r0=200.0, aperture_deg=8.0)
    plan = plan_stages(far, FREQ, GRID, base=4)
    assert ground_reach(plan.levels) < 1 and plan.predicted_error < 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("error", SarcliWarning)
        ffbp(point_data(far, rf), Collection(FREQ, far, rf), GRID, plan=plan)


def test_ffbp_depth_first_groups_give_the_same_image(monkeypatch):
    """Sub-images formed and imaged a subtree at a time (bounded memory) = all at once."""
    import sarcli.formers.ffbp._image as mod

    a, r0 = circle(P=384, aperture_deg=8.0)
    data = point_data(a, r0)
    whole, plan = ffbp(data, Collection(FREQ, a, r0), GRID, base=4, final=8, return_plan=True)
    assert mod._subtree_groups(plan) == [(0, plan.levels[-1].n)]
    monkeypatch.setattr(mod, "SUBTREE_BYTES", 1)   # one last-level sub-image (and its subtree) at a time
    assert len(mod._subtree_groups(plan)) == plan.levels[-1].n >= 3
    parts = ffbp(data, Collection(FREQ, a, r0), GRID, base=4, final=8)
    assert image_error(parts, whole) < 1e-12


def test_each_level_is_freed_once_its_parents_are_formed(monkeypatch):
    """Memory: when a merge runs, the grids two levels below (the previous merge's children, stage
    0's at the second merge) are no longer held by anyone, in every depth-first group."""
    import gc
    import weakref

    import sarcli.formers.ffbp._image as fb
    import sarcli.formers.ffbp._kernels as kernels

    a, r0 = circle(P=512, aperture_deg=8.0)
    d = point_data(a, r0)
    plan = plan_stages(a, FREQ, GRID, base=2, final=8)
    assert len(plan.levels) >= 4
    per = sum(lv.nbytes for lv in plan.levels) / plan.levels[-1].n
    monkeypatch.setattr(fb, "SUBTREE_BYTES", per)   # one last-level sub-image a group
    assert len(fb.subtree_groups(plan, fb.SUBTREE_BYTES)) >= 2
    merge, calls = kernels.merge, []

    def watched(children, *args):
        gc.collect()
        calls.append(([weakref.ref(x) for x in children], len(calls) and [r() is not None for r in calls[-1][0]]))
        return merge(children, *args)

    monkeypatch.setattr(kernels, "merge", watched)
    img = ffbp(d, Collection(FREQ, a, r0), GRID, base=2, final=8)
    per_group = len(plan.levels) - 1
    assert len(calls) == per_group * len(fb.subtree_groups(plan, fb.SUBTREE_BYTES))
    for i, (_, before_alive) in enumerate(calls):
        if i % per_group:   # not a group's first merge: the level below its children is gone
            assert before_alive == [False, False], i
    assert image_error(img, direct_spherical(d, FREQ, a, r0, GRID)) <= 5e-3


def _merge_reference(cre, cim, cf, pf, first, count, tab_q, tab_t, dq, kref, n_u, n_q):
    """NumPy twin of the compiled merge's separable path (``separable_row`` in src/native/ffbp.cpp)
    for the optimal 6-tap kernels: each parent row's nodes in every child's (q, u); the child's
    columns the row's q-stencils touch interpolated in u at the row's u, linear in q between nodes
    (pass 1); that signal interpolated in q at each node and re-referenced (pass 2)."""
    from sarcli.formers.ffbp._grids import polar_coords
    from sarcli.formers.ffbp._kernels import row_weights

    out = np.zeros((len(first), n_u, n_q), complex)
    for s in range(len(first)):
        cx, cy, cn, rho0, e0x, e0y, cz, q0, u0, du = pf[:, s]
        qp = q0 + dq * np.arange(n_q)
        for it in range(n_u):
            g = qp * (2 * cn + qp)                   # the parent's nodes on the ground (``node``)
            across = (u0 + it * du) * (cn + qp)
            along = (g - across ** 2) / (np.sqrt(rho0 ** 2 + g - across ** 2) + rho0)
            x, y = along * e0x - across * e0y, along * e0y + across * e0x
            for c in range(first[s], first[s] + count[s]):
                f = cf[:, c]
                qs, ts, _ = polar_coords(f[:, None], x[None], y[None])
                qs, ts = qs[0], ts[0]
                assert np.all(np.diff(qs) > 0)      # the separable path
                fq = (qs - f[7]) / dq
                sq = np.floor(fq).astype(int) - 2
                okq = (sq >= 0) & (sq + 6 <= cre.shape[2])
                i0, i1 = np.flatnonzero(okq)[[0, -1]]
                cols = np.arange(sq[i0], sq[i1] + 6)
                qj = f[7] + cols * dq
                k = np.clip(np.searchsorted(qs, qj, side="right") - 1, 0, n_q - 2)
                tj = ts[k] + (qj - qs[k]) * (ts[k + 1] - ts[k]) / (qs[k + 1] - qs[k])
                fu = (tj - f[8]) / f[9]
                su = np.floor(fu).astype(int) - 2
                oku = (su >= 0) & (su + 6 <= cre.shape[1])
                su = np.clip(su, 0, cre.shape[1] - 6)
                wt = row_weights(3, (fu - np.floor(fu)).astype(np.float32), tab_t).astype(float)
                sub = (cre[c] + 1j * cim[c]).astype(complex)
                gj = oku * sum(wt[a] * sub[su + a, cols] for a in range(6))
                wq = row_weights(3, (fq - np.floor(fq)).astype(np.float32), tab_q).astype(float)
                at = np.clip(sq - sq[i0], 0, len(cols) - 6)
                v = sum(wq[b] * gj[at + b] for b in range(6))
                out[s, it] += okq * v * np.exp(1j * kref * (qs - qp))
    return out


@pytest.mark.parametrize("name, beta_q, beta_t", [("optimal", 2.0, 2.0), ("optimal", 3.0, 1.5),
                                                  ("deapodized", 1.5, 3.0)])
def test_merge_matches_its_numpy_reference(name, beta_q, beta_t):
    """The compiled merge (each column's segment found by walking the row, run boundaries listed
    by blocks) equals its NumPy twin to float32 rounding, on random sub-images of two levels of the
    tests' circle; with equal range and angle tables and with unequal ones (each pass its own)."""
    import sarcli.formers.ffbp._kernels as kern
    from sarcli.formers.ffbp.model import deapodized_kernel

    a, r0 = circle(P=192)
    plan = plan_stages(a, FREQ, GRID, base=4)
    child, parent = plan.levels[0], plan.levels[1]
    rng = np.random.default_rng(7)
    cre, cim = (rng.standard_normal((child.n, child.n_u, child.n_q)).astype(np.float32) for _ in range(2))
    first, count = parent.children
    cf, pf = kern.frame(child), kern.frame(parent)
    make = optimal_kernel if name == "optimal" else deapodized_kernel
    tab_q, tab_t = make(beta_q), make(beta_t)
    out_re, out_im = (np.zeros((parent.n, parent.n_u, parent.n_q), np.float32) for _ in range(2))
    kern.merge((cre, cim), cf, pf, (first, count), kern.Interp(3, tab_q, tab_t, plan.dq, plan.kref), (out_re, out_im))
    ref = _merge_reference(cre, cim, cf, pf, first, count, tab_q, tab_t, plan.dq, plan.kref, parent.n_u,
                           parent.n_q)
    got = out_re + 1j * out_im
    assert np.abs(got).max() > 1
    assert np.linalg.norm(got - ref) / np.linalg.norm(ref) < 1e-6   # measured 1.5e-7


def test_stage0_weights_in_a_pass_or_in_the_blocks_give_the_same_image(monkeypatch):
    """Stage 0's two ways of forming the 6-tap weights (``WEIGHTS_FIRST``: a pass before the sums,
    or inside each block; each CPU takes one) sum the same products: the same image bit for bit,
    with the deapodized (symmetric) kernels and the analytic (read) ones."""
    import sarcli.formers.ffbp._stage0 as s0

    a, r0 = circle(P=128)
    data = point_data(a, r0)
    for knobs in ({}, {"interp": "lanczos", "os_range": 3, "os_angle": 3}):
        imgs = []
        for first in (True, False):
            monkeypatch.setattr(s0, "WEIGHTS_FIRST", first)
            imgs.append(ffbp(data, Collection(FREQ, a, r0), GRID, **knobs))
        assert np.abs(imgs[0]).max() > 0.5
        assert np.array_equal(imgs[0], imgs[1])


@pytest.mark.parametrize("first", [True, False])
def test_weight_polynomials_of_an_asymmetric_kernel_give_the_same_image(monkeypatch, first):
    """A 6-tap table that is not symmetric (one coefficient moved by 1e-5 of the largest) takes the
    kernels' general polynomial path (stage 0's, in a weight pass or in its blocks, the merges' and
    the final stage's stencils) instead of the even/odd one: the image moves by about that much,
    no more."""
    import sarcli.formers.ffbp._stage0 as s0
    import sarcli.formers.ffbp._image as mod

    monkeypatch.setattr(s0, "WEIGHTS_FIRST", first)
    a, r0 = circle(P=128)
    data = point_data(a, r0)
    sym = ffbp(data, Collection(FREQ, a, r0), GRID)

    def skewed(make):
        def table(beta):
            tab = np.array(make(beta), dtype=np.float64)
            tab[0, 0] += 1e-5 * np.abs(tab).max()
            return tab
        return table

    monkeypatch.setattr(mod, "deapodized_kernel", skewed(mod.deapodized_kernel))
    monkeypatch.setattr(mod, "optimal_kernel", skewed(mod.optimal_kernel))
    asym = ffbp(data, Collection(FREQ, a, r0), GRID)
    assert 0 < image_error(asym, sym) < 1e-4   # measured 2.3e-5


def test_final_stage_by_bands_of_columns_gives_the_same_image(monkeypatch):
    """The final stage forms the image by bands of FINAL_COLUMNS columns (ragged last band), in
    every depth-first group: the same image, bit for bit, as in one call per group."""
    import sarcli.formers.ffbp._image as fb

    a, r0 = circle(P=512, aperture_deg=8.0)
    d = point_data(a, r0)
    plan = plan_stages(a, FREQ, GRID, base=2, final=8)
    per = sum(lv.nbytes for lv in plan.levels) / plan.levels[-1].n
    monkeypatch.setattr(fb, "SUBTREE_BYTES", per)   # one last-level sub-image a group
    assert len(fb.subtree_groups(plan, fb.SUBTREE_BYTES)) >= 2
    monkeypatch.setattr(fb, "FINAL_COLUMNS", 10 ** 6)
    whole = ffbp(d, Collection(FREQ, a, r0), GRID, base=2, final=8)
    monkeypatch.setattr(fb, "FINAL_COLUMNS", 7)
    banded = ffbp(d, Collection(FREQ, a, r0), GRID, base=2, final=8)
    assert np.array_equal(banded, whole)
    assert image_error(banded, direct_spherical(d, FREQ, a, r0, GRID)) <= 5e-3


def test_timings_give_each_part_its_processor_seconds():
    """``timings`` (what the planner's calibration fits) gets every part, and together they are
    the call's processor seconds, less its planning."""
    import time

    a, r0 = circle(P=512, aperture_deg=8.0)
    d = point_data(a, r0)
    parts = {}
    t = time.process_time()
    _, plan = ffbp(d, Collection(FREQ, a, r0), GRID, base=2, final=8, timings=parts, return_plan=True)
    total = time.process_time() - t
    assert plan.n_stages >= 2 and plan.range_deapodized   # merges and tone weights both run
    assert set(parts) == {"profiles", "tones", "stage0", "merge", "final"}
    assert all(v >= 0 for v in parts.values()) and sum(parts.values()) <= total + 1e-9
    assert ffbp(d, Collection(FREQ, a, r0), GRID, base=2, final=8) is not None   # no timings: nothing kept


def test_an_unknown_stage_knob_is_one_line_naming_it():
    from sarcli.errors import SarcliInputError

    a, _ = circle(P=64)
    with pytest.raises(SarcliInputError, match="'bse'"):
        plan_stages(a, FREQ, GRID, bse=4)
