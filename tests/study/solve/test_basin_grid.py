"""study.solve.basin_grid: a basin map at a point where a stable 1T and a stable 2T orbit coexist
(omega 1.7, sigma 1.0, zeta 0.05, Hertz n = 1.5), checked cell by cell against the oracle
(scipy solve_ivp with contact-switch events, benchmarks/oracle.py: no code shared with the
kernels): each attractor is a fixed point of the oracle's own period map, and the oracle's
transient from a cell ends on the orbit the cell is labelled with. Then the census's per-point
basin entropy, stored by the block solver."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.study.solve.basin_grid import basin_map, grid_axes
from hertzmap.study.solve.block import solve_block
from hertzmap.study.solve.census import Attractor, census_basin_entropy
from hertzmap.study.solve.seeds import initial_states

W, S, Z = 1.7, 1.0, 0.05
OPTIONS = {"exponent": 1.5, "model": "hertz", "rtol": 1e-10}
#: periods the oracle's transient runs: exp(-zeta T)^200 ~ 1e-16, far below the distance
#: between the two orbits' stroboscopic points
ORACLE_PERIODS = 200


@pytest.fixture(scope="module")
def bistable():
    return basin_map(W, S, Z, grid=(12, 12), options=OPTIONS)


def test_two_coexisting_orbits_share_the_box(bistable):
    kinds = [(a["kind"], a["period"]) for a in bistable.attractors]
    assert sorted(kinds) == [("periodic", 1), ("periodic", 2)]
    assert sum(a["count"] for a in bistable.attractors) == 144
    assert set(np.unique(bistable.labels)) == {0, 1}
    # mixed basins: every 5 x 5 box of the 12 x 12 map holds both (S_bb = S_b > 0)
    e = bistable.entropy
    assert 0 < e.basin_entropy <= math.log(2) and e.boundary_basin_entropy >= e.basin_entropy
    assert 0 < bistable.uncertainty < 1


def test_the_attractors_are_the_oracles_orbits(bistable):
    for a in bistable.attractors:
        x, _, residual = oracle.shoot((a["q0"], a["v0"]), W, S, Z, a["period"], rtol=1e-11)
        assert np.hypot(*(x - (a["q0"], a["v0"]))) < 1e-7


def _inner_cells(labels, per_label):
    """``per_label`` cells of each label, those with the most neighbours (of 8) of their own
    label first (away from the basin boundary, where the outcome may hang on the integrators'
    last digits)."""
    out = []
    padded = np.pad(labels, 1, constant_values=-1)
    for lab in np.unique(labels):
        same = sum((padded[1 + di:padded.shape[0] - 1 + di, 1 + dj:padded.shape[1] - 1 + dj]
                    == lab).astype(int) for di in (-1, 0, 1) for dj in (-1, 0, 1))
        cells = sorted(zip(*np.nonzero(labels == lab)), key=lambda c: -same[c])
        out += cells[:per_label]
    return out


def test_cells_end_where_the_oracle_ends(bistable):
    """Two cells of each basin (of its most inner ones): the oracle's transient (rtol 1e-12) over ORACLE_PERIODS periods
    ends within 1e-6 of a stroboscopic point of the labelled orbit (the oracle's own orbit and
    its images under the oracle's period map), and farther from the other orbit's."""
    T = 2 * math.pi / W
    points = {}
    for index, a in enumerate(bistable.attractors):
        x, _, _ = oracle.shoot((a["q0"], a["v0"]), W, S, Z, a["period"], rtol=1e-11)
        pts = [x]
        for _ in range(a["period"] - 1):
            pts.append(oracle.period_map(pts[-1], W, S, Z, 1, rtol=1e-12, atol=1e-12))
        points[index] = np.array(pts)
    cells = _inner_cells(bistable.labels, 2)
    assert len(cells) == 4
    q, v = grid_axes(((-6.0, 4.0)), (-5.0, 5.0), (12, 12))
    assert np.allclose(q, bistable.q) and np.allclose(v, bistable.v)
    for i, j in cells:
        end = oracle.flow((bistable.q[j], bistable.v[i]), 0.0, ORACLE_PERIODS * T, W, S, Z,
                          rtol=1e-12, atol=1e-12)
        dist = {k: np.hypot(*(p - end).T).min() for k, p in points.items()}
        label = int(bistable.labels[i, j])
        assert dist[label] < 1e-6, (i, j, dist)
        assert all(d > 1e-2 for k, d in dist.items() if k != label)


def test_row_blocks_do_not_change_the_map(bistable):
    """The same map from blocks of 5 rows (orbits joined across blocks by the identity rule)."""
    again = basin_map(W, S, Z, grid=(12, 12), options=OPTIONS, rows_per_block=5)
    assert [(a["period"], a["count"]) for a in again.attractors] == \
        [(a["period"], a["count"]) for a in bistable.attractors]
    assert (again.labels == bistable.labels).all()


def test_census_basin_entropy_labels_the_states_by_attractor():
    """16 Halton states, all on one attractor: 0; split between two attractors state by state
    in turn (0, 1, 0, 1, ...): every cell of the 2 x 2 cut holds both; the states of a reach
    box (outside TRANSIENT_BOX) are left out."""
    states = initial_states(16)
    one = census_basin_entropy([Attractor("periodic", 16, states=states)])
    assert one.basin_entropy == 0 and one.boundary_basin_entropy == 0
    two = [Attractor("periodic", 8, states=states[0::2]),
           Attractor("unsettled", 8, states=states[1::2])]
    e = census_basin_entropy(two)
    assert 0 < e.basin_entropy <= math.log(2)
    assert e.boundary_basin_entropy >= e.basin_entropy
    far = [(-100.0 - i, 0.0) for i in range(8)]
    assert census_basin_entropy(two + [Attractor("periodic", 8, states=far)]) == e


def test_the_census_stores_the_basin_entropy_per_point():
    """Every point's census ("always"): 0 at omega 1.95 (one attractor: the 1T orbit of the
    map above's neighbourhood, sigma 0.4), positive at the bistable point, never above
    log(attractor_count)."""
    out = solve_block(np.array([W]), np.array([S, 0.4]), np.array([Z]), attractors="always",
                      initial_states=16, transient_periods=200, record_periods=32,
                      max_transient_periods=200)
    count = out["attractor_count"][0, :, 0]
    s_b = out["basin_entropy"][0, :, 0]
    s_bb = out["boundary_basin_entropy"][0, :, 0]
    assert count[0] == 2 and 0 < s_b[0] <= math.log(2) + 1e-12 and s_bb[0] >= s_b[0]
    assert count[1] == 1 and s_b[1] == 0 and s_bb[1] == 0
