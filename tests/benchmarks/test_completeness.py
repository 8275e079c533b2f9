"""benchmarks/completeness.py, the brute-force completeness check of a store: its own RK4
(paper Eq. 7, no code of kernels/) against the scipy oracle's period map, with and without
contact loss; the grouping of settled states into cycles and the matching of a cycle with a
store's slots (any phase, same period, stable, status 0); one small brute force at a
monostable point against the oracle's orbit there.

    .venv/bin/python -m pytest tests/benchmarks/test_completeness.py -q -n 0
"""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import completeness as C
from benchmarks import oracle


def _oracle_strobe(x0, omega, sigma, zeta, periods):
    """x(k T), k = 1..periods, by the oracle's one-period map, tight enough (rtol 1e-12) to be
    the reference of a 1e-7 check."""
    out, x = [], np.asarray(x0, float)
    for _ in range(periods):
        x = oracle.period_map(x, omega, sigma, zeta, 1, rtol=1e-12, atol=1e-12)
        out.append(x)
    return np.array(out)


def _switches(x0, omega, sigma, zeta, periods):
    """Contact switches (loss and recontact) of the oracle's trajectory over the periods."""
    P = periods * 2.0 * np.pi / omega
    return len(oracle.trajectory(x0, 0.0, P, [P], omega, sigma, zeta, rtol=1e-10,
                                 atol=1e-10)[2])


@pytest.mark.parametrize("omega, sigma, zeta, states, contact_loss", [
    # in contact all along: the force is smooth, RK4 at full order
    (1.5, 0.2, 0.01, [(-0.16, 0.006), (0.5, -0.3), (0.8, 0.4)], False),
    # contact loss and recontact every period: the steps near q = -n are sub-stepped
    (1.9, 0.5, 0.01, [(-0.09, 1.5), (-0.92, -1.31), (-3.0, 2.0)], True),
    (1.9, 2.0, 0.01, [(-0.09, 1.5), (0.86, 0.37), (3.0, -4.0)], True),
])
def test_rk4_period_map_agrees_with_the_oracle(omega, sigma, zeta, states, contact_loss):
    periods = 3
    got = C.strobe(np.array(states), omega, sigma, zeta, periods)
    assert got.shape == (len(states), periods + 1, 2)
    assert np.array_equal(got[:, 0], np.array(states))
    for s, x0 in enumerate(states):
        assert (_switches(x0, omega, sigma, zeta, periods) > 0) == contact_loss
        ref = _oracle_strobe(x0, omega, sigma, zeta, periods)
        err = np.abs(got[s, 1:] - ref).max(axis=1) / (1.0 + np.abs(ref).max(axis=1))
        assert err.max() < 1e-7, (x0, err)


def test_the_substeps_are_what_makes_contact_loss_accurate():
    """Without the substeps near q = -n the same steps are far less accurate on a hard
    impact: the check above is the substeps' doing, not a lenient tolerance."""
    x0, args = np.array([[3.0, -4.0]]), (1.9, 0.5, 0.01)
    ref = _oracle_strobe(x0[0], *args, 1)[0]
    plain = np.abs(C.strobe(x0, *args, 1, sub=1)[0, 1] - ref).max()
    sub = np.abs(C.strobe(x0, *args, 1)[0, 1] - ref).max()
    assert sub < 0.1 * plain


def test_transients_settle_on_the_repeat_test():
    """A state started on the oracle's 1T orbit settles at once with m = 1 after the
    RETURNS + 1 samples the test needs, its tail ends on the orbit."""
    omega, sigma, zeta = 1.5, 0.2, 0.01
    x, _, _ = oracle.shoot((0.0, 0.0), omega, sigma, zeta, 1, rtol=1e-12)
    period, ran, tail = C.transients(np.array([x]), omega, sigma, zeta, 1000, tol=1e-7)
    assert period[0] == 1 and ran[0] == C.RETURNS
    assert np.abs(tail[0, -1] - x).max() < 1e-7


def test_minimal_period_and_grouping_of_cycles():
    a, b, c = np.array([0.1, 1.0]), np.array([-0.9, -1.3]), np.array([-3.1, -2.7])
    L = (C.RETURNS + 1) * C.MAX_PERIOD
    tail = np.zeros((5, L, 2))
    tail[0, -2:] = [a, b]                  # the 2-cycle ending in one phase ...
    tail[1, -2:] = [b, a]                  # ... and in the other: the same orbit
    tail[2, -2:] = [a, c]                  # another 2-cycle through a: a different orbit
    tail[3, -2:] = [c, c + 1e-9]           # a 1T orbit the repeat test saw as 2-periodic
    period = np.array([2, 2, 2, 2, 0])     # the last state never repeated
    cycles, label = C.group_cycles(period, tail)
    assert label.tolist() == [0, 0, 1, 2, -1]
    assert [len(cy) for cy in cycles] == [2, 2, 1]
    assert C.minimal_period([a, b, a, b], 1e-9) == 2
    assert C.minimal_period([a, b, c], 1e-9) == 3


def _slot(slot, period, q0, v0, stable=True, status=0):
    return {"slot": slot, "period": period, "status": status, "stable": stable, "q0": q0,
            "v0": v0, "mu": 0.5}


def test_matching_a_cycle_with_the_store_slots():
    a, b = np.array([0.1, 1.0]), np.array([-0.9, -1.3])
    cycle = np.array([a, b])
    empty = _slot(0, 0, np.nan, np.nan, stable=False, status=-1)
    # the store's start point may be any phase of the cycle
    assert C.match_slot(cycle, [empty, _slot(1, 2, *b)]) == 1
    assert C.match_slot(cycle, [_slot(0, 2, *(a + 5e-7))]) == 0          # within 1e-6 (1 + |x|)
    # a different orbit, another period, an unstable or unconverged slot: not held
    assert C.match_slot(cycle, [_slot(0, 2, *(a + 1e-4))]) == -1
    assert C.match_slot(cycle, [_slot(0, 1, *a)]) == -1
    assert C.match_slot(cycle, [_slot(0, 2, *a, stable=False)]) == -1
    assert C.match_slot(cycle, [_slot(0, 2, *a, stable=False)], stable_only=False) == 0
    assert C.match_slot(cycle, [_slot(0, 2, *a, status=1)]) == -1
    # any number of slots (the solution dim's length is the store's)
    many = [empty] * 7 + [_slot(7, 2, *a)]
    assert C.match_slot(cycle, many) == 7


def test_done_points_from_task_done_and_from_status():
    xr = pytest.importorskip("xarray")
    status = np.full((4, 3, 1, 6), -1, np.int8)
    status[0, 0, 0, 0] = 0
    ds = xr.Dataset({"status": (("omega", "sigma", "zeta", "solution"), status),
                     "task_done": (("omega_chunk", "sigma_chunk", "zeta_chunk"),
                                   np.array([[[True], [False], [False]]]))},
                    attrs={"hertzmap_chunk_shape": [4, 1, 1]})
    # task_done: the whole block (all omega at sigma 0), a finished point without orbits too
    assert C.done_points(ds).tolist() == [[i, 0, 0] for i in range(4)]
    assert C.done_points(ds.drop_vars("task_done")).tolist() == [[0, 0, 0]]


def test_brute_force_at_a_monostable_point_finds_the_oracles_orbit():
    """omega 0.6, sigma 0.1, zeta 0.05: every state of both boxes ends on one stable 1T orbit,
    the oracle's own (shot here from the static equilibrium); a store holding it in any slot
    holds it, one holding it unstable or at a shifted start point does not."""
    omega, sigma, zeta = 0.6, 0.1, 0.05
    x, M, _ = oracle.shoot((0.0, 0.0), omega, sigma, zeta, 1, rtol=1e-12)
    assert np.abs(np.linalg.eigvals(M)).max() < 1.0
    empty = _slot(0, 0, np.nan, np.nan, stable=False, status=-1)
    store = {"index": [0, 0, 0], "dropped": 0,
             "slots": [empty, _slot(1, 1, *x), _slot(2, 2, x[0] + 0.5, x[1])]}
    r = C.check_point(omega, sigma, zeta, 1.5, 40, 2.0, 1, 1000, store=store)
    assert r["states_per_box"] == [20, 20]
    assert r["non_periodic_census"] == r["non_periodic_wide"] == 0.0
    [a] = r["attractors"]
    assert a["period"] == 1 and a["stable"] and a["refined"]
    assert a["basin_census"] == a["basin_wide"] == 1.0
    assert np.abs(np.array(a["q0"]) - x).max() < 1e-8
    assert a["held"] and a["slot"] == 1
    # the 2T slot is a stable orbit nobody reached
    assert [s["slot"] for s in r["store_stable_not_reached"]] == [2]
    h = C.headline([r])
    assert (h["census"]["held"], h["census"]["total"]) == (1, 1)

    store["slots"][1] = _slot(1, 1, *x, stable=False)
    r = C.check_point(omega, sigma, zeta, 1.5, 40, 2.0, 1, 1000, store=store)
    assert not r["attractors"][0]["held"]
    assert "stored unstable" in r["attractors"][0]["store"]
    h = C.headline([r])
    assert (h["either"]["held"], h["either"]["total"]) == (0, 1)
    assert h["either"]["missed"][0]["period"] == 1
