"""kernels.continuation.extremum: the bounded extremum search on an analytic curve (an ellipse,
each trial point corrected onto it by the core's Newton corrector with the search coordinate
held) and the continuation of an extremum in a parameter, against closed forms: where the
minimum lies, its value, the landing on asked values, the step rule (core.adapt_step's
factors on the predictor's miss) and how an end stops."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hertzmap.kernels.continuation import core
from hertzmap.kernels.continuation.extremum import (MIN_STEP_SHARE, bounded_extremum,
                                                    continue_extremum)

#: an ellipse ((x - X0) / A)^2 + ((y - Y0) / B)^2 = 1: lowest point (X0, Y0 - B), highest
#: (X0, Y0 + B)
X0, Y0, A, B = 0.3, 2.0, 0.5, 0.2


def ellipse(u):
    """F(u) and its Jacobian for u = (x, y) on the ellipse (core.correct's residual)."""
    dx, dy = u[0] - X0, u[1] - Y0
    return (np.array([(dx / A) ** 2 + (dy / B) ** 2 - 1.0]),
            np.array([[2.0 * dx / A**2, 2.0 * dy / B**2]]), None)


def ellipse_y(branch):
    """value_at(x) for the search: y on the lower (branch -1) or upper (+1) arc at x, Newton
    from the arc's extreme y with x held; None where x is off the ellipse (no convergence)."""
    def value_at(x):
        r = core.correct(ellipse, np.array([x, Y0 + branch * B]), np.array([1.0, 0.0]),
                         max_iter=30, xtol=1e-14)
        return None if r is None else (float(r.u[1]), r.u)
    return value_at


def test_the_lowest_and_highest_points_of_an_ellipse():
    """The window [-0.3, 0.5] starts off the ellipse (x < -0.2: the corrector fails there, a
    trial of +inf for the search), the extremum inside it."""
    low = bounded_extremum(ellipse_y(-1), 0.1, 0.4, xtol=1e-9, max_iter=200)
    assert abs(low.at - X0) < 1e-7 and abs(low.value - (Y0 - B)) < 1e-12
    assert low.point[0] == low.at and low.point[1] == low.value
    high = bounded_extremum(ellipse_y(+1), 0.1, 0.4, xtol=1e-9, max_iter=200, maximum=True)
    assert abs(high.at - X0) < 1e-7 and abs(high.value - (Y0 + B)) < 1e-12


def test_an_extremum_outside_the_window_is_followed_by_recentring():
    """f(t) = (t - 3)^2 + 1 searched from [-1, 1]: the minimum found on the edge is searched
    again in windows recentred there (t = 1, 2, then 3 inside); with too few recentrings or
    on a window that fails everywhere there is none; a window said to bracket it (recentre
    None) gives its edge."""
    def value_at(t):
        return (t - 3.0) ** 2 + 1.0, t

    found = bounded_extremum(value_at, 0.0, 1.0, xtol=1e-10, max_iter=200, recentre=4)
    assert abs(found.at - 3.0) < 1e-8 and abs(found.value - 1.0) < 1e-15
    assert bounded_extremum(value_at, 0.0, 1.0, xtol=1e-10, max_iter=200, recentre=1) is None
    edge = bounded_extremum(value_at, 0.0, 1.0, xtol=1e-10, max_iter=200)
    assert 1.0 - 1e-7 < edge.at <= 1.0          # Brent stops sqrt(eps) |t| from a bound
    assert bounded_extremum(lambda t: None, 0.0, 1.0, xtol=1e-10, max_iter=200) is None


# -- continued in a parameter: f(t; p) = f*(p) + 2 (t - t*(p))^2, extremum (t*(p), f*(p)) ----

def t_star(p):
    return 0.3 * math.sin(3.0 * p)


def f_star(p):
    return math.exp(p)


def minimum_at(t_of=t_star, f_of=f_star, calls=None, fails=lambda p, u_pred: False):
    """find_at for continue_extremum: the minimum over t of f(t; p), searched within 0.1 (or
    three times the predicted move of t) of the predicted t; ``fails`` makes it not found."""
    def find_at(p, u_pred, u_last):
        if calls is not None:
            calls.append((p, u_pred.copy()))
        if fails(p, u_pred):
            return None
        ts, fs = t_of(p), f_of(p)
        found = bounded_extremum(lambda t: (fs + 2.0 * (t - ts) ** 2, None), u_pred[0],
                                 max(0.1, 3.0 * abs(u_pred[0] - u_last[0])), xtol=1e-10,
                                 max_iter=200, recentre=4)
        return None if found is None else (np.array([found.at, found.value]), p)
    return find_at


def start_at(p, t_of=t_star, f_of=f_star):
    return p, np.array([t_of(p), f_of(p)]), p


def test_an_extremum_continued_lands_on_the_asked_values_and_matches_the_closed_form():
    land = [0.0, 0.137, 0.25, 0.6, 0.61, 1.0, 1.7]          # 1.7: outside, not landed on
    path = continue_extremum(minimum_at(), start_at(0.4), (0.0, 1.0), land_on=land,
                             min_vertices=20, max_vertices=400)
    p = np.array(path.params)
    assert path.status == ("range", "range")
    assert p[0] == 0.0 and p[-1] == 1.0 and np.all(np.diff(p) > 0.0)
    assert np.diff(p).max() <= 1.0 / 20 * (1 + 1e-12) and len(p) >= 20
    for q in land[:-1]:
        assert q in path.params, q
    assert 0.4 in path.params and path.found == path.params
    for q, u in zip(path.params, path.points, strict=True):
        assert abs(u[0] - t_star(q)) < 1e-8 and abs(u[1] - f_star(q)) < 1e-14 * f_star(q)


def test_the_step_follows_the_cores_rule_on_the_predictors_miss():
    """t* = p, f* = 1 + p: the first step (h_max = 0.05) is predicted by the start itself and
    misses f by 0.05 / 1.55 > PREDICTOR_TOL: shrunk by adapt_step's 0.6; the next steps are
    predicted exactly (secant, quadratic through a line): grown by 1.5, to h_max. A step
    shortened to land on an asked value (0.401: missed by 7e-4, between PREDICTOR_TOL / 10
    and PREDICTOR_TOL) leaves the step length as it was."""
    line = (lambda p: p, lambda p: 1.0 + p)
    path = continue_extremum(minimum_at(*line), start_at(0.5, *line), (0.0, 1.0),
                             min_vertices=20, max_vertices=400)
    p = np.array(path.params)
    up = np.diff(p[p >= 0.5])
    np.testing.assert_allclose(up[:4], [0.05, 0.03, 0.045, 0.05], rtol=0, atol=1e-12)
    down = -np.diff(p[p <= 0.5][::-1])
    np.testing.assert_allclose(down[:4], [0.05, 0.03, 0.045, 0.05], rtol=0, atol=1e-12)
    path = continue_extremum(minimum_at(*line), start_at(0.4, *line), (0.0, 1.0),
                             land_on=[0.401], min_vertices=20, max_vertices=400)
    p = np.array(path.params)
    np.testing.assert_allclose(np.diff(p[p >= 0.4])[:3], [0.001, 0.05, 0.05], rtol=0,
                               atol=1e-12)


def test_the_predictor_is_the_quadratic_through_the_last_vertices():
    """After two vertices the point at p is predicted by the quadratic through the last three
    (p_i): its error is at most max|u'''| / 6 |(p - p_1)(p - p_2)(p - p_3)| (Lagrange's
    remainder; |t*'''| <= 8.1, |f*'''| <= e^0.9); the first prediction is the start itself."""
    calls = []
    continue_extremum(minimum_at(calls=calls), start_at(0.4), (0.4, 0.9), min_vertices=50,
                      max_vertices=400)
    assert np.array_equal(calls[0][1], start_at(0.4)[1])
    vertices = [0.4] + [p for p, _ in calls]              # none failed: each call a vertex
    for k in range(2, len(calls)):
        p, u_pred = calls[k]
        spread = abs(np.prod([p - q for q in vertices[k - 2:k + 1]]))
        assert 0.0 < abs(u_pred[0] - t_star(p)) <= 8.1 / 6 * spread * (1 + 1e-6) + 1e-12
        assert abs(u_pred[1] - f_star(p)) <= math.exp(0.9) / 6 * spread * (1 + 1e-6) + 1e-12


def test_an_end_is_lost_where_the_extremum_stops_being_found():
    """Beyond p = 0.55 the extremum is not found: each failed step is retried from the same
    vertex 0.6 times as long (adapt_step, to the range's MIN_STEP_SHARE) until the shortest
    fails; the last vertex lies within that of 0.55. The other way the range's end is
    reached."""
    calls = []
    path = continue_extremum(minimum_at(calls=calls, fails=lambda p, u_pred: p > 0.55),
                             start_at(0.4), (0.0, 1.0), min_vertices=20, max_vertices=400)
    assert path.status == ("range", "lost")
    h_min = MIN_STEP_SHARE * 1.0
    assert 0.0 < 0.55 - path.params[-1] < h_min
    upward = [p for p, _ in calls if p > 0.4]
    base, failed = 0.4, None
    for p in upward:
        if failed is not None:
            assert abs((p - base) - max(h_min, 0.6 * failed)) < 1e-12
        if p > 0.55:
            failed = p - base
        else:
            base, failed = p, None
    assert failed is not None and failed <= h_min * (1 + 1e-9)


def test_the_vertex_budget_and_a_start_outside_the_range():
    path = continue_extremum(minimum_at(), start_at(0.4), (0.0, 1.0), min_vertices=20,
                             max_vertices=5)
    assert path.status == ("max_vertices", "max_vertices") and len(path.params) == 9
    with pytest.raises(ValueError, match="outside the range"):
        continue_extremum(minimum_at(), start_at(0.4), (0.5, 1.0), min_vertices=20,
                          max_vertices=5)
