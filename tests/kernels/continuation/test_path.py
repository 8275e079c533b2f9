"""kernels.continuation.path: the line search's seed path follows a long-period branch (the
central difference it switches to where the forward one stalls its corrector), each point a
fixed point of the period map."""
from __future__ import annotations

import numpy as np

from hertzmap.kernels import continuation as cont
from hertzmap.kernels import shoot
from hertzmap.kernels import status as st

# A stable 16T orbit the census meets on scenes/fine_map.toml's line sigma = 0.939 (grid point
# 233 of 250) at omega = 1.1667 (point 133 of 400): a bouncing motion with long flights, born
# from a flip of an unstable 8T orbit; its branch spans omega ~1.139 .. 1.247.
FINE_OMEGA = np.linspace(0.5, 2.5, 400)
FINE_SIGMA = 0.05 + 233 * 0.95 / 249
FINE_I = 133


def test_arc_path_follows_a_long_period_branch_with_full_steps():
    """On this 16T map the forward difference in omega leaves the corrector converging only
    linearly: with it alone, 150 points reached omega 1.173 (this test fails there). With the
    central difference arc_path switches to, they go beyond the branch's end (omega 1.247),
    each a fixed point of the 16T map (checked by the period map itself, not the path's
    corrector)."""
    orbit = shoot(FINE_OMEGA[FINE_I], FINE_SIGMA, 0.01, 16, guess=(-11.1085, -2.8141))
    assert orbit.converged and orbit.minimal_period == 16 and orbit.stable
    system = cont.System(0.01, 1.5, "hertz", 1e-10)
    h = FINE_OMEGA[1] - FINE_OMEGA[0]
    points = []
    taken = cont.arc_path(system, orbit.x0, FINE_OMEGA[FINE_I], FINE_SIGMA, 16, 1.0, 0.5 - h,
                          2.5 + h, ds=2 * h, dp_max=h, max_points=150,
                          on_step=lambda a, b: points.append(b.copy()) or True)
    U = np.array(points)
    assert taken == len(U) + 1
    assert U[:, 2].max() > 1.25
    for u in U[::15]:
        # the corrector's tolerance is loose (1e-7 relative, the points only seed Newton)
        phi, _, code = system.map(u[:2], u[2], FINE_SIGMA, 16)
        assert code == st.CONVERGED
        assert np.hypot(*(phi - u[:2])) < 1e-5 * (1 + np.hypot(*u[:2]))


def test_arc_path_stops_when_told_and_outside_its_window():
    system = cont.System(0.01)
    x = shoot(2.2, 0.3, 0.01, 1, guess=(0.0, 0.0)).x0
    seen = []
    taken = cont.arc_path(system, x, 2.2, 0.3, 1, -1.0, 2.0, 2.4, ds=0.01, dp_max=0.005,
                          max_points=100, on_step=lambda a, b: seen.append(b[2]) or len(seen) < 3)
    assert taken == 4 and len(seen) == 3 and all(np.diff([2.2] + seen) < 0)
    seen.clear()
    taken = cont.arc_path(system, x, 2.2, 0.3, 1, -1.0, 2.1, 2.4, ds=0.01, dp_max=0.005,
                          max_points=100, on_step=lambda a, b: seen.append(b[2]) or True)
    assert seen[-1] < 2.1 <= seen[-2] and taken == len(seen) + 1
