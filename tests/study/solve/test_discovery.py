"""study.solve.discovery: transients and continuation along a line find the isola, the unstable
halves of branches and the bifurcation points; a grid block with discovery keeps the contract."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels import shoot
from hertzmap.kernels import status as st
from hertzmap.study.orbit_rules import same_orbit
from hertzmap.study.schema import ORBIT_VARIABLES, check_block
from hertzmap.study.solve import discovery
from hertzmap.study.solve.block import solve_block
from hertzmap.study.solve.point import merge_new_orbits, shoot_seeds_minimal


Z = 0.01


@pytest.fixture(scope="module")
def isola_line():
    omega = np.linspace(1.0, 2.0, 11)
    return discovery.discover_line(omega, 0.2, Z, sweep=False,
                                   initial=[[] for _ in omega], transients=16)


def test_isola_from_transients_alone(isola_line):
    """No sweep, no MMS seed, no hand-given guess: transients land on the isola's stable half,
    continuation finds its unstable half and both folds."""
    counts = isola_line.classes().sum(axis=0)
    assert counts[3 - 1] >= 5
    assert counts[5 - 1] >= 5
    folds = sorted((d for d in isola_line.special if d["kind"] == "fold" and d["period"] == 2),
                   key=lambda d: d["omega"])
    # the isola "delimited by a couple of saddle-node bifurcations ... in the interval
    # 1 < omega < 2" (paper section 3.2, Fig. 8, sigma 0.2, zeta 0.01)
    assert len(folds) == 2 and 1.0 < folds[0]["omega"] < folds[1]["omega"] < 2.0
    for d in folds:
        # the oracle's own fold (benchmarks.oracle.fold_point, rtol 1e-12), started 1e-2 in x
        # and 1e-3 in omega away from the located one; they agree to 7e-11 and 3e-10
        x0 = np.array([d["q0"], d["v0"]])
        x_oracle, w_oracle, (fixed_residual, fold_residual) = oracle.fold_point(
            x0 + 1e-2, d["omega"] + 1e-3, 0.2, Z, 2)
        # the oracle converged (its fold function at the root: <= 3e-12, the monodromy from
        # the variational equations)
        assert fixed_residual < 1e-8 * (1 + np.abs(x_oracle).max()) and fold_residual < 1e-9
        assert abs(d["omega"] - w_oracle) < 1e-7, (d["omega"], w_oracle)
    closed = [b for b in isola_line.branches if b.period == 2]
    assert closed and all(b.status == 0 or b.status == 1 for b in closed)   # boundary/closed


def test_solutions_distinct_and_genuine(isola_line):
    for i, sols in enumerate(isola_line.solutions):
        assert all(s["status"] == st.CONVERGED for s in sols)
        for a in range(len(sols)):
            for b in range(a + 1, len(sols)):
                assert not same_orbit(sols[a], sols[b])
        for s in sols:
            o = shoot(isola_line.omega[i], 0.2, Z, s["period"], s["x0"])
            assert o.converged and o.minimal_period == s["period"]
            assert abs(o.ptp - s["ptp"]) < 1e-7


def test_2t_shift_is_one_orbit():
    w, s = 1.5, 0.2
    o = shoot(w, s, Z, 2, (-3.06, -1.40))
    assert o.converged and o.minimal_period == 2
    from hertzmap.kernels import simulate
    x_shift = simulate(w, s, Z, o.x0, periods=1, samples_per_period=1)["final"]
    sols = shoot_seeds_minimal(w, s, Z, 2, [tuple(o.x0), tuple(x_shift)], dict(rtol=1e-10))
    assert np.hypot(*(sols[0]["x0"] - sols[1]["x0"])) > 0.1
    found = []
    merge_new_orbits(found, sols)
    assert len(found) == 1


def test_2t_solve_landing_on_1t_is_the_1t_orbit():
    w, s = 1.5, 0.2
    one = shoot(w, s, Z, 1, (0.0, 0.0))
    sols = shoot_seeds_minimal(w, s, Z, 2, [tuple(one.x0 + 1e-3)], dict(rtol=1e-10))
    assert sols[0]["period"] == 1
    assert np.allclose(np.sort_complex(sols[0]["multipliers"]),
                       np.sort_complex(one.multipliers), atol=1e-8)


def test_initial_states_deterministic():
    a = discovery.initial_states(16)
    assert a == discovery.initial_states(16) and len(a) == 16 and a[0] == (0.0, 0.0)
    assert discovery.transient_periods(1.5, 0.01) % 2 == 0


def test_block_discover_option_keeps_contract():
    omega = np.linspace(1.3, 1.7, 3)
    out = solve_block(omega, [0.2], [Z], discover=True, transients=8)
    ref = solve_block(omega, [0.2], [Z])
    check_block(out, ORBIT_VARIABLES, (3, 1, 1))
    # slot 0 is the 1T orbit; the isola's two 2T orbits are there at every point
    assert np.all(out["period"][:, 0, 0, 0] == 1)
    two = (out["period"] == 2) & (out["status"] == 0)
    assert np.all(two.sum(axis=-1)[:, 0, 0] == 2)
    assert np.all(out["loses_contact"][two])
    assert (ref["status"] == 0).sum() <= (out["status"] == 0).sum()


def test_default_sweep_path_finds_what_the_block_solver_finds():
    """discover_line's own sweep (no initial solutions given) runs the block solver's seeding:
    it must find at least every converged orbit solve_block finds on the same line."""
    omega = np.linspace(1.85, 2.1, 6)
    d = discovery.discover_line(omega, 0.5, 0.01, transients=0)
    b = solve_block(omega, np.array([0.5]), np.array([0.01]))
    for i in range(omega.size):
        got = d.solutions[i]
        for slot in range(b["period"].shape[-1]):
            if b["status"][i, 0, 0, slot] != 0:
                continue
            assert any(s["period"] == b["period"][i, 0, 0, slot]
                       and abs(s["min_q"] - b["min_q"][i, 0, 0, slot]) < 1e-6 for s in got), \
                (omega[i], slot)


def test_grid_block_with_discovery_finds_the_unstable_half_of_the_isola():
    """sigma = 0.2, zeta = 0.01: the isola's stable half is reached by the sweep seeds; its
    unstable half needs discovery (transients + continuation around the folds)."""
    omega = np.linspace(1.2, 1.7, 6)
    plain = solve_block(omega, np.array([0.2]), np.array([0.01]))
    disc = solve_block(omega, np.array([0.2]), np.array([0.01]), discover=True, transients=8)

    def unstable_2t(r):
        return int(((r["period"] == 2) & ~r["stable"] & (r["status"] == 0)).sum())
    assert unstable_2t(disc) >= omega.size          # one unstable 2T orbit at every point
    assert unstable_2t(disc) > unstable_2t(plain)
