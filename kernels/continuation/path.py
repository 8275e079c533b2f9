"""A lean pseudo-arclength path in omega: the seed path of the line search's fold turning
(study.solve.line.LineSearch.trace), on the core's corrector (kernels.continuation.core).

The points only seed Newton at fixed omega: no records, no located points, a loose corrector
(|du| <= tol (1 + |u|), tol 1e-7, CORRECTOR_ITERATIONS iterations a step, no runaway check)
and dPhi/domega by a forward difference (core.PATH_DIFFERENCE) until the corrector stalls,
then by a central one (core.PATH_STALL_DIFFERENCE). Dimensionless (paper Eq. 7 / 11).
"""
from __future__ import annotations

import numpy as np

from hertzmap.kernels.continuation.core import (PATH_DIFFERENCE, PATH_STALL_DIFFERENCE,
                                                adapt_step, correct, fixed_point_residual,
                                                null_tangent, null_vector, predict_correct)

#: Newton iterations of arc_path's corrector per step
CORRECTOR_ITERATIONS = 5
#: arc_path halves a step while it is longer than this fraction of ds
SMALLEST_STEP = 1e-7


def arc_path(system, x0, omega, sigma, period, direction, w_lo, w_hi, *, ds, dp_max,
             max_points, on_step, tol=1e-7) -> int:
    """A lean pseudo-arclength continuation of the period-``period`` orbit through (x0, omega)
    in omega (``system``: a kernels.continuation.System), starting towards ``direction``, until
    omega leaves [w_lo, w_hi], ``max_points`` are taken, the corrector fails, or
    ``on_step(u_prev, u)`` returns False (u = (q, q', omega)). The points only seed Newton at
    fixed omega, so the corrector is loose (``tol``) and the derivative in omega is a forward
    difference (one map per corrector iteration more instead of two, and none of
    continue_orbit's records), until the corrector stalls (its steps shrink but do not reach
    ``tol`` in its iterations); from then on, a central difference. Returns the points taken.

    Why the switch: the forward difference's error grows with the map's curvature in omega,
    which grows with the period. On a stable 16T orbit met by the census (scenes/fine_map.toml,
    sigma 0.939, omega 1.167) the corrector converged only linearly, the steps shrank and the
    path spent its whole point budget (2,400 points each way; tests/kernels/continuation/
    test_path.py follows that path); with the switch the line's search takes a twelfth of the
    time (``benchmarks/search_ab.py --vs REV --study scenes/fine_map.toml --every 250 --offset
    233`` against a revision without it). Paths that never stall keep the forward difference.

    The steps grow (by 1.5 after a corrector of at most 2 iterations) to 4 ds times
    max(1, |x|): in arc length the state dominates, and the long-flight orbits the census
    meets (|x| ~ 10-40) took steps of 4 ds along branches 25 long in q."""
    forward = fixed_point_residual(system, period, "omega", omega, sigma, PATH_DIFFERENCE)
    central = fixed_point_residual(system, period, "omega", omega, sigma, PATH_STALL_DIFFERENCE)
    residual = [forward]            # the one in use: forward until the corrector stalls

    def to_central():
        if residual[0] is central:
            return None
        residual[0] = central
        return central

    def correct_at(u_pred, normal):
        return correct(residual[0], u_pred, normal, max_iter=CORRECTOR_ITERATIONS, xtol=tol,
                       runaway=False, on_stall=to_central)

    u = np.array([x0[0], x0[1], omega], float)
    r = forward(u)
    if r is None:
        return 0
    t = null_vector(r[1], unit=False)
    t *= np.sign(t[2] * direction) or 1.0
    h = ds
    # (the step is halved while h > SMALLEST_STEP ds: the smallest step tried is above it)
    h_min = np.nextafter(SMALLEST_STEP * ds, np.inf)
    taken = 1
    while taken < max_points and w_lo <= u[2] <= w_hi:
        if abs(t[2]) * h > dp_max:
            h = dp_max / abs(t[2])
        step, t_new, h = predict_correct(correct_at, u, t, h, h_min, tangent_at=null_tangent,
                                         slack=0.0)
        if step is None:
            break
        u_prev = u
        u, t = step.u, t_new
        taken += 1
        if not on_step(u_prev, u):
            break
        h = adapt_step(h, step.iterations, 4.0 * ds * max(1.0, float(np.hypot(u[0], u[1]))),
                       hard=None)
    return taken
