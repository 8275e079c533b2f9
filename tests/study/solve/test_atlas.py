"""study.solve.atlas: an orbit known at one grid point is continued into points that lack it,
each continued orbit checked by the oracle (scipy's period map, benchmarks/oracle.py); what the
continuity rule already pairs is not shot again; a point keeps every orbit it gains (its
slots grow); unstable orbits of periods the study does not search stay where they are (or are
continued too, by the study's choice); the result depends on the snapshot only."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels import shoot
from hertzmap.study.schema import ORBIT_VARIABLES, empty_arrays
from hertzmap.study.orbit_rules import fold_function
from hertzmap.study.solve.atlas import FAR_FROM_FOLD, MAX_ITER, neighbours, propagate_tile
from hertzmap.study.solve.point import shoot_seeds_minimal, shoot_targets
from hertzmap.study.solve.point_state import PointState, write_states

OPTIONS = {"exponent": 1.5, "model": "hertz", "rtol": 1e-10, "harmonics": False}
ZETA = 0.01


def _region(omega, sigma, orbits_at, names=ORBIT_VARIABLES + ("orbits_found",)):
    """Block arrays over (omega, sigma, one zeta) holding, at each (i, j), the orbits solved
    from orbits_at[(i, j)] = [(period, guess), ...] (grid orbits, atlas_round 0)."""
    states = {}
    for i in range(len(omega)):
        for j in range(len(sigma)):
            sols = []
            for period, guess in orbits_at.get((i, j), ()):
                s = shoot_seeds_minimal(omega[i], sigma[j], ZETA, period, [guess], OPTIONS)[0]
                assert s["status"] == 0
                sols.append(dict(s, atlas_round=0))
            states[i, j, 0] = PointState(sols, omega=float(omega[i]))
    return write_states(states, (len(omega), len(sigma), 1), names)


def _orbits(arrays, i, j):
    ok = arrays["status"][i, j, 0] == 0
    return [(int(arrays["period"][i, j, 0, s]), float(arrays["q0"][i, j, 0, s]),
             float(arrays["v0"][i, j, 0, s]), int(arrays["atlas_round"][i, j, 0, s]))
            for s in np.flatnonzero(ok)]


def test_neighbours_are_along_the_swept_axes_lower_first():
    assert list(neighbours((1, 0, 0), (3, 1, 1))) == [(0, 0, 0), (2, 0, 0)]
    assert list(neighbours((0, 1, 0), (2, 3, 1))) == [(1, 1, 0), (0, 0, 0), (0, 2, 0)]


def test_a_2t_orbit_known_at_one_sigma_is_continued_along_the_line_and_checked():
    """The stable 2T orbit at (2.0, 0.5) continued across sigma 0.46..0.58 (points that only
    hold their 1T orbit): every continued orbit is a fixed point of scipy's own period map,
    and its invariants change little from point to point."""
    omega = np.array([2.0])
    sigma = np.array([0.46, 0.5, 0.54, 0.58])
    o2 = shoot(2.0, 0.5, ZETA, 2, guess=(-0.6, 0.5))
    assert o2.converged and o2.period == 2 and o2.minimal_period == 2
    one_t = (1, (0.0, 0.0))
    region = _region(omega, sigma, {(0, 0): [one_t], (0, 1): [one_t, (2, tuple(o2.x0))],
                                    (0, 2): [one_t], (0, 3): [one_t]})
    own = (slice(0, 1), slice(0, 4), slice(0, 1))
    r = propagate_tile(region, {}, own, omega, sigma, np.array([ZETA]), 1, OPTIONS, -1.5,
                       (1, 2))
    assert r.changed[0, :, 0].tolist() == [True, False, True, True]
    for j in (0, 2, 3):
        found = [o for o in _orbits(r.arrays, 0, j) if o[0] == 2]
        assert len(found) == 1 and found[0][3] == 1          # added by round 1
        x = np.array(found[0][1:3])
        phi = oracle.period_map(x, 2.0, float(sigma[j]), ZETA, 2)
        assert np.max(np.abs(phi - x)) < 1e-7 * (1 + np.hypot(*x))
        assert r.arrays["orbits_found"][0, j, 0] == 2
    # the grid's orbits are kept as stored
    assert _orbits(r.arrays, 0, 1) == _orbits(region, 0, 1)
    # a second round has nothing to offer: the fixed point
    again = {n: region[n].copy() for n in region}
    for n, v in r.arrays.items():
        again[n][own] = v
    r2 = propagate_tile(again, {}, own, omega, sigma, np.array([ZETA]), 2, OPTIONS, -1.5,
                        (1, 2))
    assert not r2.changed.any() and r2.shots == 0


def test_orbits_the_continuity_rule_pairs_are_not_shot():
    """Two points holding the same branches: nothing to continue, no shot."""
    omega = np.array([2.0])
    sigma = np.array([0.5, 0.51])
    o2 = shoot(2.0, 0.5, ZETA, 2, guess=(-0.6, 0.5))
    o2b = shoot(2.0, 0.51, ZETA, 2, guess=tuple(o2.x0))
    region = _region(omega, sigma, {(0, 0): [(1, (0.0, 0.0)), (2, tuple(o2.x0))],
                                    (0, 1): [(1, (0.0, 0.0)), (2, tuple(o2b.x0))]})
    own = (slice(0, 1), slice(0, 2), slice(0, 1))
    r = propagate_tile(region, {}, own, omega, sigma, np.array([ZETA]), 1, OPTIONS, -1.5,
                       (1, 2))
    assert r.shots == 0 and not r.changed.any()


def _stand_in(period, q):
    """A converged, unstable orbit record of ``period`` far from the real ones (an orbit a
    point holds, not shot: it fills a slot)."""
    return {"period": period, "status": 0, "stable": False, "x0": (q, 0.0), "atlas_round": 0,
            "min_q": q - 1.0, "max_q": q + 1.0, "ptp": 2.0,
            "multipliers": np.array([3.0 + 0j, 0.1 + 0j])}


def test_a_point_keeps_every_orbit_it_gains_its_slots_growing():
    """The stable 2T orbit arriving at a point whose four slots are full (its 1T orbit,
    unstable there past its flip, and three orbits of other periods): the point keeps all
    five, the tile's arrays grow to two chunks of slots, nothing is dropped."""
    omega = np.array([2.0])
    sigma = np.array([0.5, 0.54])
    o2 = shoot(2.0, 0.5, ZETA, 2, guess=(-0.6, 0.5))
    one_t = shoot_seeds_minimal(2.0, 0.54, ZETA, 1, [(0.0, 0.0)], OPTIONS)[0]
    assert one_t["status"] == 0 and not one_t["stable"]
    full = [dict(one_t, atlas_round=0)] + [_stand_in(p, 50.0 + p) for p in (5, 7, 9)]
    a = _region(omega, sigma, {(0, 0): [(2, tuple(o2.x0))]})
    region = write_states({(0, 1, 0): PointState(full, omega=2.0)}, (1, 2, 1),
                          ORBIT_VARIABLES + ("orbits_found",), base=a)
    assert region["status"].shape[-1] == 4 and (region["status"][0, 1, 0] == 0).all()
    own = (slice(0, 1), slice(1, 2), slice(0, 1))
    r = propagate_tile(region, {}, own, omega, sigma, np.array([ZETA]), 1, OPTIONS, -1.5,
                       (1, 2))
    assert r.changed.all() and r.added == 1
    assert r.arrays["status"].shape[-1] == 8
    found = _orbits(r.arrays, 0, 0)
    assert sorted(o[0] for o in found) == [1, 2, 5, 7, 9]
    assert r.arrays["orbits_found"][0, 0, 0] == 5
    stable = r.arrays["stable"][0, 0, 0] & (r.arrays["status"][0, 0, 0] == 0)
    assert r.arrays["period"][0, 0, 0][stable].tolist() == [2]


def test_unstable_orbits_of_periods_not_searched_stay_where_found_unless_asked():
    """An unstable 5T stand-in at one point is not offered to its neighbour by default (the
    study searches 1T and 2T: it stays where the census met it), and is offered with
    unstable = "all" (its shot there fails: it is no orbit, but it was shot)."""
    omega = np.array([2.0])
    sigma = np.array([0.5, 0.54])
    a = _region(omega, sigma, {(0, 0): [(1, (0.0, 0.0))], (0, 1): [(1, (0.0, 0.0))]})
    one_t = shoot_seeds_minimal(2.0, 0.5, ZETA, 1, [(0.0, 0.0)], OPTIONS)[0]
    region = write_states({(0, 0, 0): PointState([dict(one_t, atlas_round=0),
                                                  _stand_in(5, 55.0)], omega=2.0)},
                          (1, 2, 1), ORBIT_VARIABLES + ("orbits_found",), base=a)
    own = (slice(0, 1), slice(1, 2), slice(0, 1))
    args = (region, {}, own, omega, sigma, np.array([ZETA]), 1, OPTIONS, -1.5, (1, 2))
    assert propagate_tile(*args).shots == 0
    assert propagate_tile(*args, unstable="all").shots >= 1


def test_a_shot_that_fails_far_from_a_fold_succeeds_in_two_half_steps():
    """The stable 2T orbit at (0.525, 0.7) of the default scene (complex multipliers: far from
    a fold) does not converge at (0.5125, 0.7) by one Newton shot from its start point (the
    orbit changes fast there); the atlas's half steps (via 0.51875) bring it, and the oracle
    confirms the orbit."""
    omega = np.array([0.5125, 0.525])
    sigma = np.array([0.7])
    guess = (1.605563501275337, -1.486627538966545)
    source = shoot_seeds_minimal(0.525, 0.7, ZETA, 2, [guess], OPTIONS)[0]
    assert source["status"] == 0 and source["stable"]
    assert abs(fold_function(source)) >= FAR_FROM_FOLD
    # one shot from the source's start point fails (the natural continuation alone)
    direct = shoot_targets([(0.5125, 0.7, ZETA, 2, tuple(source["x0"]))],
                           dict(OPTIONS, max_iter=MAX_ITER))[0]
    assert direct["status"] != 0
    region = _region(omega, sigma, {(1, 0): [(2, guess)]})
    own = (slice(0, 1), slice(0, 1), slice(0, 1))
    r = propagate_tile(region, {}, own, omega, sigma, np.array([ZETA]), 1, OPTIONS, -1.5,
                       (1, 2))
    found = _orbits(r.arrays, 0, 0)
    assert [o[0] for o in found] == [2] and found[0][3] == 1
    x = np.array(found[0][1:3])
    phi = oracle.period_map(x, 0.5125, 0.7, ZETA, 2)
    assert np.max(np.abs(phi - x)) < 1e-7 * (1 + np.hypot(*x))
    assert r.shots == 3                          # the shot, then the two half steps


@pytest.mark.parametrize("order", [(0, 1, 2, 3), (3, 2, 1, 0)])
def test_the_result_depends_on_the_snapshot_only(order):
    """The same tile from the same snapshot, its arrays built in another order: the same
    bits."""
    omega = np.array([2.0])
    sigma = np.array([0.46, 0.5, 0.54, 0.58])
    o2 = shoot(2.0, 0.5, ZETA, 2, guess=(-0.6, 0.5))
    wanted = {(0, j): [(1, (0.0, 0.0))] for j in order}
    wanted[(0, 1)] = [(1, (0.0, 0.0)), (2, tuple(o2.x0))]
    own = (slice(0, 1), slice(0, 4), slice(0, 1))
    a = propagate_tile(_region(omega, sigma, wanted), {}, own, omega, sigma,
                       np.array([ZETA]), 1, OPTIONS, -1.5, (1, 2))
    b = propagate_tile(_region(omega, sigma, dict(sorted(wanted.items()))), {}, own, omega,
                       sigma, np.array([ZETA]), 1, OPTIONS, -1.5, (1, 2))
    for n in a.arrays:
        np.testing.assert_array_equal(a.arrays[n], b.arrays[n], err_msg=n)


def test_a_census_round_runs_the_census_again_where_a_stable_orbit_came():
    """(0.95, 1.8), zeta 0.01: the grid's census called the transients chaotic after their
    first pass (no stable orbit known); the atlas then brings the stable 5T orbit there
    (checked by the oracle's period map). census_points flags the point; census_tile runs the
    census again knowing the orbit (half of its states where the orbit's flight reaches: one
    settles on it; a longer pass of the others, none escaping: chaotic beside it), keeps the
    orbit in the slots, and leaves no point to run again."""
    from hertzmap.study.schema import ATTRACTOR_VARIABLES
    from hertzmap.study.solve.atlas import census_points, census_tile
    from hertzmap.study.solve.census import census

    w, s, guess = 0.95, 1.8, (-118.12574873, 2.24953184)
    search = dict(n_states=16, transient_periods=500, record_periods=128,
                  max_transient_periods=20_000, point_steps=2_000_000)
    orbit = shoot_seeds_minimal(w, s, ZETA, 5, [guess], OPTIONS)[0]
    assert orbit["status"] == 0
    x = np.array(orbit["x0"])
    assert np.max(np.abs(oracle.period_map(x, w, s, ZETA, 5) - x)) < 1e-7 * (1 + np.hypot(*x))
    first, _ = census(w, s, ZETA, [], OPTIONS, **search)
    # the orbit brought by the atlas (round 3) to the point whose census did not know it
    region = write_states({(0, 0, 0): PointState([dict(orbit, atlas_round=3)],
                                                 attractors=first, n_states=16, omega=w)},
                          (1, 1, 1), ORBIT_VARIABLES + ("orbits_found",) + ATTRACTOR_VARIABLES)
    assert census_points(region, 500, 128).tolist() == [[[True]]]
    own = (slice(0, 1),) * 3
    r = census_tile(region, {}, own, np.array([w]), np.array([s]), np.array([ZETA]), 4,
                    OPTIONS, -1.5, (1, 2), search)
    assert r.changed.tolist() == [[[True]]] and r.shots == 1 and r.added == 0
    out = r.arrays
    kinds = out["attractor_kind"][0, 0, 0]
    assert kinds.tolist() == [2, 1, 0, 0]                         # non_periodic, periodic
    assert out["attractor_periods_run"][0, 0, 0, 0] > 500 + 128
    assert out["basin_fraction"][0, 0, 0, :2].tolist() == [15 / 16, 1 / 16]
    assert out["attractor_solution"][0, 0, 0, 1] == 0 and out["period"][0, 0, 0, 0] == 5
    assert _orbits(out, 0, 0) == _orbits(region, 0, 0)
    assert not census_points(out, 500, 128).any()


def test_a_census_round_starts_from_the_neighbours_periodic_and_chaotic_attractors():
    """neighbour_starts: the last stroboscopic point of each non-periodic attractor and the
    last m (its phases) of each periodic one of period m stored at the point's grid neighbours
    along every axis (lower first, in axis order), none of an unsettled or failed group, an
    empty slot or a missing point."""
    from hertzmap.study.schema import ATTRACTOR_KINDS, ATTRACTOR_VARIABLES, STROBE_POINTS
    from hertzmap.study.solve.atlas import neighbour_starts

    region = empty_arrays((3, 3, 2), names=ATTRACTOR_VARIABLES)
    kinds, q, v = region["attractor_kind"], region["strobe_q"], region["strobe_v"]

    def put(at, slot, kind, x):
        kinds[at + (slot,)] = ATTRACTOR_KINDS[kind]
        q[at + (slot, slice(None))] = np.linspace(-1, x[0], STROBE_POINTS)
        v[at + (slot, slice(None))] = np.linspace(-1, x[1], STROBE_POINTS)

    put((0, 1, 0), 0, "non_periodic", (1.0, 2.0))
    put((2, 1, 0), 1, "periodic", (3.0, 4.0))
    put((2, 1, 0), 0, "unsettled", (9.0, 9.0))
    put((1, 0, 0), 0, "failed", (9.0, 9.0))
    put((1, 2, 0), 2, "periodic", (5.0, 6.0))
    region["attractor_period"][1, 2, 0, 2] = 2                   # a 2T orbit: two phases
    put((1, 1, 1), 0, "non_periodic", (7.0, 8.0))
    put((1, 1, 1), 1, "periodic", (np.nan, 8.0))
    put((0, 0, 0), 0, "periodic", (9.0, 9.0))                   # not a neighbour
    before_last = (-1 + (5.0 + 1) * (STROBE_POINTS - 2) / (STROBE_POINTS - 1),
                   -1 + (6.0 + 1) * (STROBE_POINTS - 2) / (STROBE_POINTS - 1))
    got = neighbour_starts(region, (1, 1, 0))
    assert got[:2] == [(1.0, 2.0), (3.0, 4.0)] and got[4:] == [(7.0, 8.0)]
    np.testing.assert_allclose(got[2:4], [before_last, (5.0, 6.0)], rtol=1e-14)
    assert neighbour_starts(region, (2, 2, 1)) == []
