"""study.solve.line: the default search finds the branches beyond folds (the unstable middle 1T
branch of the primary resonance, the unstable half of an isola) that the seeded sweeps alone
miss, every orbit it finds is a genuine orbit of that period (checked against the independent
scipy oracle), and its census says what attracts at every point."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels import status as st
from hertzmap.kernels.attractors import A
from hertzmap.study.orbit_rules import class_code, same_orbit
from hertzmap.study.solve.line import LineSearch

OPTIONS = dict(exponent=1.5, model="hertz", rtol=1e-10, harmonics=False, seeds=())


def search(omega, sigma, zeta=0.01, periods=(1, 2), census=None):
    ls = LineSearch(np.asarray(omega, float), sigma, zeta, periods, OPTIONS)
    ls.sweep()
    ls.turn_folds()
    if census:
        ls.run_census(*census)
    return ls


@pytest.fixture(scope="module")
def primary_resonance():
    """sigma = 0.2, zeta = 0.01, the line of the issue: 161 points from omega 0.25 to 2.5."""
    return search(np.linspace(0.25, 2.5, 161), 0.2)


def test_three_coexisting_1t_orbits_of_the_primary_resonance(primary_resonance):
    ls = primary_resonance
    three = [i for i in range(ls.omega.size)
             if sum(s["period"] == 1 for s in ls.per_point[i]) == 3]
    # the hysteresis of the primary resonance with contact loss: upper and lower stable
    # branches and the unstable one between the folds, across omega ~0.29 .. 0.87
    assert len(three) >= 35
    lo, hi = ls.omega[three].min(), ls.omega[three].max()
    assert lo < 0.32 and hi > 0.85
    for i in three[::10]:
        one = sorted((s for s in ls.per_point[i] if s["period"] == 1), key=lambda s: s["ptp"])
        assert [s["stable"] for s in one] == [True, False, True]
        middle = one[1]
        # the unstable orbit is a fixed point of the oracle's period map (scipy, tight
        # tolerances: its residual is integration noise, ~1e-9 relative) with a real
        # multiplier above 1 (a saddle between the two nodes)
        x = np.asarray(middle["x0"])
        phi = oracle.period_map(x, ls.omega[i], 0.2, 0.01, 1, rtol=1e-11, atol=1e-11)
        assert np.hypot(*(phi - x)) < 1e-7 * (1 + np.hypot(*x))
        M = oracle.monodromy(x, ls.omega[i], 0.2, 0.01, 1, rtol=1e-11)
        assert np.max(np.abs(np.linalg.eigvals(M))) > 1.0
        assert oracle.fold_function(M) < 0.0          # a saddle: one multiplier beyond +1


def test_the_sweeps_alone_miss_the_middle_branch():
    """The fold turning is what finds it: the sweeps alone do not (the issue's observation)."""
    ls = LineSearch(np.linspace(0.25, 2.5, 161), 0.2, 0.01, (1, 2), OPTIONS)
    ls.sweep()
    assert max(sum(s["period"] == 1 for s in p) for p in ls.per_point) == 2


def test_the_isola_has_both_halves(primary_resonance):
    ls = primary_resonance
    both = [i for i in range(ls.omega.size)
            if {class_code(s) for s in ls.per_point[i]} >= {3, 5}]
    # paper Fig. 8: the isola of 2T orbits with contact loss between its two folds
    assert len(both) >= 40
    w = ls.omega[both]
    assert 1.10 < w.min() < 1.13 and 1.77 < w.max() < 1.79


def test_orbits_are_distinct_and_converged(primary_resonance):
    for sols in primary_resonance.per_point:
        assert all(s["status"] == st.CONVERGED for s in sols)
        for a in range(len(sols)):
            for b in range(a + 1, len(sols)):
                assert not same_orbit(sols[a], sols[b])


def test_census_where_none_stable_names_the_motion_on_the_vibro_impact_line():
    """sigma = 2, zeta = 0.01: where shooting finds no stable orbit the census says what
    attracts; basins sum to one; a point with a stable orbit is never called non-periodic."""
    omega = np.linspace(0.6, 1.6, 21)
    ls = search(omega, 2.0, census=("where-none-stable", 16, 500, 128))
    assert ls.attractors, "the census ran nowhere"
    kinds = set()
    for i, found in ls.attractors.items():
        assert sum(a.count for a in found) == 16
        has_stable = any(s["stable"] for s in ls.per_point[i])
        for a in found:
            kinds.add(a.kind)
            if a.kind == "non_periodic":
                assert not has_stable
                assert a.row[A["lyapunov"]] > 0
            if a.kind == "periodic":
                assert a.orbit["stable"] and a.orbit in ls.per_point[i]
    assert "non_periodic" in kinds
    # every point of the line has a stable orbit or a census result
    for i in range(omega.size):
        assert any(s["stable"] for s in ls.per_point[i]) or i in ls.attractors


def test_census_never_runs_nothing():
    ls = search(np.linspace(0.6, 1.0, 5), 2.0, census=("never", 16, 500, 128))
    assert not ls.attractors


# A stable 16T orbit the census meets on scenes/fine_map.toml's line sigma = 0.939 (grid point
# 233 of 250) at omega = 1.1667 (point 133 of 400): a bouncing motion with long flights, born
# from a flip of an unstable 8T orbit; its branch spans omega ~1.139 .. 1.247.
FINE_OMEGA = np.linspace(0.5, 2.5, 400)
FINE_SIGMA = 0.05 + 233 * 0.95 / 249
FINE_I = 133


@pytest.fixture(scope="module")
def orbit_16t():
    from hertzmap.study.solve.point import shoot_seeds_minimal
    got = shoot_seeds_minimal(FINE_OMEGA[FINE_I], FINE_SIGMA, 0.01, 16, [(-11.1085, -2.8141)],
                              OPTIONS)
    sol = got[0]
    assert sol["status"] == st.CONVERGED and sol["period"] == 16 and sol["stable"]
    return sol


def test_a_trace_stops_where_its_path_joins_the_lower_period_branch(orbit_16t, monkeypatch):
    """Beyond omega 1.247 the 16T branch ends on the 8T orbit it doubled from; a path that
    goes on follows the 8T branch (a closed loop, traced as a double cover: 2,400 points, the
    whole budget, before). The trace stops there, having kept the 16T orbits of the grid
    points the branch crosses."""
    from hertzmap.kernels import continuation as cont
    taken = []
    arc_path = cont.arc_path
    monkeypatch.setattr(cont, "arc_path", lambda *a, **k: taken.append(arc_path(*a, **k))
                        or taken[-1])
    ls = LineSearch(FINE_OMEGA, FINE_SIGMA, 0.01, (1, 2), OPTIONS)
    ls.per_point[FINE_I].append(dict(orbit_16t, omega=FINE_OMEGA[FINE_I]))
    ls.trace(FINE_I, ls.per_point[FINE_I][-1], +1, past_fold=True)
    found = [FINE_OMEGA[i] for i in range(FINE_OMEGA.size)
             if any(s["period"] == 16 for s in ls.per_point[i])]
    assert min(found) == FINE_OMEGA[FINE_I] and max(found) > 1.24
    assert len(found) >= 15
    assert sum(taken) < 400
