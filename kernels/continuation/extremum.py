"""Extrema of a curve's parameter: located along a one-dimensional search, and continued in a
third parameter (the subharmonic thresholds sigma*(zeta) and sigma**(zeta), study.solve.
thresholds; the parameter extrema of a traced curve, kernels.continuation.codim2).

**Located** (:func:`bounded_extremum`). Along a one-dimensional search t (omega at fixed zeta;
the position on a chord between two vertices of a traced curve), each trial t is a point of
the curve corrected with t held (the caller's ``value_at``) and f(t) the parameter there (the
curve's sigma). The extremum is where df/dt = 0, found as the minimum of f (of -f for a
maximum) by Brent's bounded search over [c - w, c + w] to ``xtol`` in t: f is flat there, so
its value is exact to the corrector's tolerance plus f'' xtol^2 / 2. A trial whose corrector
fails is f = +inf for the search (no arithmetic warning), and a search that ends on one is
no extremum. When the window is not known to bracket the extremum (``recentre`` given), one
found within ``edge_share`` w of an end lies on its edge: the window is centred there and
searched again, at most ``recentre`` times.

**Continued** (:func:`continue_extremum`). An extremum is a point of codimension 2 in (t, f,
p): a curve point with df/dt = 0, followed in a third parameter p (zeta) by natural-parameter
continuation both ways from its start across a range. Each step predicts the extremum's point
u (its orbit's start point, t and f) at p + h by the natural-parameter predictor
(core.natural_prediction: secant, then quadratic, through the last vertices), locates it
again there from the prediction (the caller's ``find_at``) and adapts h by the core's rule
(core.adapt_step) with the predictor's relative miss in f, |f - f_pred| / |f|, as the effort:
grown below PREDICTOR_TOL / 10, shrunk at PREDICTOR_TOL or more or when the extremum was not
found, between the range's share MIN_STEP_SHARE and 1 / min_vertices of it; the continuation
lands on every p asked for in the way (a study's grid values: the step shortened to reach it,
which says nothing against the step length). Units those of the caller (dimensionless in this
package: paper Eq. 7 / 11).

Pure: numpy and scipy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, NamedTuple

import numpy as np

from hertzmap.kernels.continuation.core import adapt_step, natural_prediction

#: An extremum within this share of the half-width from an end of its window is on its edge.
EDGE_SHARE = 0.02
#: The predictor's relative miss in the extremal value f above which the step shrinks (and a
#: tenth of which below which it grows): adapt_step's hard and easy efforts.
PREDICTOR_TOL = 1e-3
#: The shortest step, as a share of the range: a step this short that fails loses the extremum.
MIN_STEP_SHARE = 1e-4


class Extremum(NamedTuple):
    """An extremum located by :func:`bounded_extremum`: where (``at``, in t), its value f and
    the point ``value_at`` returned with it."""

    at: float
    value: float
    point: Any


def bounded_extremum(value_at: Callable[[float], tuple[float, Any] | None], centre: float,
                     half_width: float, *, xtol: float, max_iter: int, maximum: bool = False,
                     recentre: int | None = None,
                     edge_share: float = EDGE_SHARE) -> Extremum | None:
    """The minimum (``maximum``: the maximum) of f over t in [centre - half_width, centre +
    half_width] by Brent's bounded search to ``xtol`` in t, in at most ``max_iter`` trials a
    window. ``value_at(t)``: (f(t), the point found there) or None where it was not (f = +inf
    for the search). ``recentre``: None when the window brackets the extremum (it is then
    taken wherever it lies); else an extremum on the window's edge (within ``edge_share``
    half_width of an end) is searched again in the window centred on it, at most ``recentre``
    times. Returns the :class:`Extremum`, or None (the search ended on a failed trial, or the
    extremum stayed on the edge)."""
    from scipy.optimize import minimize_scalar

    sign = -1.0 if maximum else 1.0
    found: dict[float, tuple[float, Any]] = {}

    def objective(t):
        r = value_at(t)
        if r is None:
            return math.inf
        found[t] = r
        return sign * r[0]

    for _ in range(1 if recentre is None else recentre + 1):
        lo, hi = centre - half_width, centre + half_width
        # a trial that does not converge is +inf: no arithmetic warning from the search
        with np.errstate(invalid="ignore", over="ignore"):
            res = minimize_scalar(objective, bounds=(lo, hi), method="bounded",
                                  options={"xatol": xtol, "maxiter": max_iter})
        t = float(res.x)
        if t not in found or not math.isfinite(res.fun):
            return None
        if recentre is None or min(t - lo, hi - t) > edge_share * half_width:
            value, point = found[t]
            return Extremum(t, value, point)
        centre = t
    return None


@dataclass
class ExtremumPath:
    """An extremum continued in p (:func:`continue_extremum`): its vertices in increasing p,
    each with its point u (``points``) and what ``find_at`` returned with it (``found``; the
    start's as given), and how each end stopped ("range": the end of the range; "lost": not
    found again with the shortest step; "max_vertices": max_vertices on that side)."""

    params: list = field(default_factory=list)
    points: list = field(default_factory=list)
    found: list = field(default_factory=list)
    status: tuple = ("range", "range")


def continue_extremum(find_at: Callable[[float, np.ndarray, np.ndarray],
                                        tuple[np.ndarray, Any] | None],
                      start: tuple[float, Any, Any], p_range, *, min_vertices: int,
                      max_vertices: int, land_on=(), value_index: int = -1,
                      predictor_tol: float = PREDICTOR_TOL,
                      min_step_share: float = MIN_STEP_SHARE) -> ExtremumPath:
    """Continue an extremum in p both ways across ``p_range`` = (lo, hi) from ``start`` = (p0,
    u0, found0), landing on every p of ``land_on`` in the range (module docstring).

    ``find_at(p, u_pred, u_last)``: the extremum at p located from the predicted point u_pred
    (u_last: the last vertex's point, for the search's reach), as (u, what to keep with it), or
    None. u: a vector whose ``value_index`` component is the extremal value f (the predictor's
    miss is measured in it). The step is at most the range / ``min_vertices``; at most
    ``max_vertices`` vertices a side. Returns the :class:`ExtremumPath` (the start among its
    vertices)."""
    lo, hi = (float(p) for p in p_range)
    p0, u0, found0 = start
    if not lo <= p0 <= hi:
        raise ValueError(f"the start's parameter {p0} is outside the range ({lo}, {hi})")
    span = max(hi - lo, 1e-12)
    h_max, h_min = span / min_vertices, min_step_share * span
    targets = sorted(float(p) for p in land_on if lo <= p <= hi)
    sides, status = [], []
    for end in (lo, hi):
        ps, us, fs = [p0], [np.asarray(u0, float)], [found0]
        h = h_max
        how = "range"
        while ps[-1] != end:
            if len(ps) >= max_vertices:
                how = "max_vertices"
                break
            p_last = ps[-1]
            p_next = p_last + math.copysign(min(h, abs(end - p_last)), end - p_last)
            # land on the asked values in the way
            between = [p for p in targets if min(p_last, p_next) < p < max(p_last, p_next)]
            if between:
                p_next = min(between, key=lambda p: abs(p - p_last))
            if abs(end - p_next) < 1e-12 * span:
                p_next = end
            step = abs(p_next - p_last)
            u_pred = natural_prediction(ps, us, p_next)
            got = find_at(p_next, u_pred, us[-1])
            if got is None:
                if step <= h_min:
                    how = "lost"
                    break
                h = adapt_step(step, math.inf, h_max, h_min=h_min)
                continue
            u, kept = got
            ps.append(p_next)
            us.append(np.asarray(u, float))
            fs.append(kept)
            f = us[-1][value_index]
            miss = abs(f - u_pred[value_index]) / max(abs(f), 1e-12)
            # h adapted, not the step taken: a step shortened to land on an asked value says
            # nothing against the step length
            h = adapt_step(h, miss, h_max, h_min=h_min, easy=0.1 * predictor_tol,
                           hard=predictor_tol)
        sides.append((ps, us, fs))
        status.append(how)
    (p_lo, u_lo, f_lo), (p_hi, u_hi, f_hi) = sides
    return ExtremumPath(p_lo[::-1] + p_hi[1:], u_lo[::-1] + u_hi[1:], f_lo[::-1] + f_hi[1:],
                        (status[0], status[1]))
