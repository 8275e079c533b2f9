"""kernels.continuation.core: the corrector, tangent and predictor-corrector step on a problem
with a known answer (the unit circle), and the corrector's named options (a stall handed to a
better residual, the runaway check)."""
from __future__ import annotations

import numpy as np

from hertzmap.kernels.continuation import core


def circle(jacobian_scale=1.0):
    """F(u) = |u|^2 - 1 on R^2, its Jacobian scaled (a scale other than 1: a wrong Jacobian,
    with which Newton converges only linearly)."""
    def residual(u):
        return np.array([u @ u - 1.0]), jacobian_scale * 2.0 * u[None, :], None
    return residual


def test_a_step_lands_on_the_circle_on_the_hyperplane():
    u, t = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    r, tn, h = core.predict_correct(lambda up, n: core.correct(circle(), up, n), u, t, 0.1, 1e-6)
    assert h == 0.1
    # the hyperplane t . (u - u_pred) = 0 through u + 0.1 t is u1 = 0.1
    np.testing.assert_allclose(r.u, [np.sqrt(1.0 - 0.01), 0.1], rtol=0, atol=1e-14)
    np.testing.assert_allclose(tn, [-0.1, np.sqrt(0.99)], rtol=0, atol=1e-8)
    np.testing.assert_allclose(core.null_tangent(r.J, t), tn, atol=1e-8)


def test_a_step_too_long_for_the_curve_is_halved():
    # from (1, 0) along (0, 1): the hyperplane u1 = 1.5 misses the circle, at u1 = 0.75 the
    # tangent (-0.75, 0.66) turns by more than acos 0.9; at 0.375 (0.93) the step is taken
    u, t = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    r, tn, h = core.predict_correct(lambda up, n: core.correct(circle(), up, n), u, t, 1.5, 1e-6)
    assert h == 0.375 and abs(r.u @ r.u - 1.0) < 1e-12 and tn @ t > 0.9


def test_a_stalled_corrector_is_handed_the_better_residual_once():
    u_pred, normal = np.array([1.1, 0.3]), np.array([0.0, 1.0])
    calls = []

    def on_stall():
        calls.append(1)
        return circle()
    kw = dict(max_iter=5, xtol=1e-12, runaway=False)
    assert core.correct(circle(2.0), u_pred, normal, **kw) is None
    r = core.correct(circle(2.0), u_pred, normal, on_stall=on_stall, **kw)
    assert calls == [1] and abs(r.u @ r.u - 1.0) < 1e-12 and r.u[1] == 0.3


def test_the_runaway_check_refuses_a_step_longer_than_the_point():
    # Newton on atan(u0) = 0 from u0 = 2 overshoots to -3.5 (a step of 5.5 > 1 + 3.5): refused
    # at once with the check; without it the corrector goes on (diverging, here)
    def residual(u):
        calls.append(u.copy())
        return np.array([np.arctan(u[0])]), np.array([[1.0 / (1.0 + u[0] ** 2), 0.0]]), None
    u_pred, normal = np.array([2.0, 0.0]), np.array([0.0, 1.0])
    calls = []
    assert core.correct(residual, u_pred, normal) is None and len(calls) == 1
    calls = []
    assert core.correct(residual, u_pred, normal, runaway=False) is None and len(calls) > 1


def test_adapt_step():
    assert core.adapt_step(0.1, 2, 1.0) == 0.15000000000000002
    assert core.adapt_step(0.1, 5, 1.0, h_min=0.07) == 0.07
    assert core.adapt_step(0.1, 9, 1.0, hard=None) == 0.1
    assert core.adapt_step(0.1, 4, 0.12, easy=4) == 0.12
    # an effort other than iterations: a predictor's relative miss, a failure infinite
    assert core.adapt_step(0.1, 5e-5, 1.0, easy=1e-4, hard=1e-3) == 0.15000000000000002
    assert core.adapt_step(0.1, 5e-4, 1.0, easy=1e-4, hard=1e-3) == 0.1
    assert core.adapt_step(0.1, float("inf"), 1.0, h_min=0.01, easy=1e-4, hard=1e-3) == 0.06


def test_natural_prediction_is_exact_on_polynomials_of_its_degree():
    """The last vertex alone (a copy), the secant through two (exact on a line), the quadratic
    through the last three (exact on a parabola, whatever came before)."""
    def parabola(p):
        return np.array([1.0 - 2.0 * p + 3.0 * p**2, 0.5 * p**2])

    one = [np.array([1.0, 2.0])]
    u = core.natural_prediction([0.3], one, 0.7)
    assert np.array_equal(u, one[0]) and u is not one[0]
    np.testing.assert_allclose(core.natural_prediction([0.1, 0.3], [np.array([1.0, 5.0]),
                                                                   np.array([2.0, 4.0])], 0.6),
                               [3.5, 2.5], rtol=0, atol=1e-14)
    ps = [0.0, 0.1, 0.25, 0.3]
    points = [np.array([9.0, 9.0])] + [parabola(p) for p in ps[1:]]
    np.testing.assert_allclose(core.natural_prediction(ps, points, 0.42), parabola(0.42),
                               rtol=0, atol=1e-13)
    # order 1: the secant through the last two, even with more vertices at hand
    np.testing.assert_allclose(core.natural_prediction(ps, points, 0.35, order=1),
                               points[-1] + (points[-1] - points[-2]), rtol=0, atol=1e-13)
