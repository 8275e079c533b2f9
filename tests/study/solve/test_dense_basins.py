"""study.solve.dense_basins: the label-reuse basin map against the brute force (one whole
census transient per state, study.solve.basin_grid) on a 60 x 60 grid at a point where a stable
1T and a stable 2T orbit coexist (omega 1.7, sigma 1.0, zeta 0.05), and its attractors against
the scipy oracle (benchmarks/oracle.py, no code shared with the kernels). The 1000 x 1000 maps
of issue 52 and their 2,000-state agreement are benchmarks (benchmarks/basins_agreement.py)."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.study.solve import dense_basins as db
from hertzmap.study.solve.basin_grid import basin_map

W, S, Z = 1.7, 1.0, 0.05
OPTIONS = {"exponent": 1.5, "model": "hertz", "rtol": 1e-10}
GRID = (60, 60)
BUDGET = dict(transient_periods=200, record_periods=32)


@pytest.fixture(scope="module")
def maps():
    stats: dict = {}
    fast = db.cell_basin_map(W, S, Z, grid=GRID, options=OPTIONS, stats=stats, **BUDGET)
    brute = basin_map(W, S, Z, grid=GRID, options=OPTIONS, **BUDGET)
    return fast, brute, stats


def _boundary_distance(labels):
    from scipy import ndimage
    edge = np.zeros(labels.shape, bool)
    edge[1:] |= labels[1:] != labels[:-1]
    edge[:-1] |= labels[1:] != labels[:-1]
    edge[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    edge[:, :-1] |= labels[:, 1:] != labels[:, :-1]
    return ndimage.distance_transform_cdt(~edge, metric="chessboard") + 1


def test_the_same_attractors_as_the_brute_force(maps):
    fast, brute, stats = maps
    assert [(a["kind"], a["period"]) for a in fast.attractors] == \
        [(a["kind"], a["period"]) for a in brute.attractors] == [("periodic", 1), ("periodic", 2)]
    for a, b in zip(fast.attractors, brute.attractors):
        pts = db.orbit_points({"x0": (b["q0"], b["v0"]), "period": b["period"]}, W, S, Z,
                              OPTIONS)
        assert np.min(np.hypot(*(pts - (a["q0"], a["v0"])).T)) < 1e-7
    assert stats["orbits"] == 2 and stats["certified"] == 3     # one phase + two phases


def test_labels_agree_with_the_brute_force_away_from_the_boundary(maps):
    """Every state the two maps label differently lies next to the basin boundary (within
    two cells of a cell of the other label), and they are a small share."""
    fast, brute, stats = maps
    differ = fast.labels != brute.labels
    assert differ.mean() <= 0.01, differ.mean()
    assert (_boundary_distance(brute.labels)[differ] <= 2).all()
    # the reuse saved work: far fewer periods than the whole transients
    assert stats["mean_periods"] < 40
    assert set(np.unique(fast.method)) <= {db.SEED, db.REUSED, db.CENSUS}
    assert (fast.method == db.REUSED).mean() > 0.9


def test_inner_cells_end_where_the_oracle_ends(maps):
    """A cell of each basin, the one with the most cells of its own label around it: the
    scipy oracle's transient (200 periods: exp(-zeta T)^200 ~ 1e-16) ends on the labelled
    orbit (within 1e-6 of one of its stroboscopic points)."""
    fast, _, _ = maps
    T = 2 * np.pi / W
    dist = _boundary_distance(fast.labels)
    for label, a in enumerate(fast.attractors):
        i, j = np.unravel_index(np.argmax(np.where(fast.labels == label, dist, -1)), dist.shape)
        end = oracle.flow((fast.q[j], fast.v[i]), 0.0, 200 * T, W, S, Z, rtol=1e-12,
                          atol=1e-12)
        x, _, _ = oracle.shoot((a["q0"], a["v0"]), W, S, Z, a["period"], rtol=1e-11)
        pts = [x]
        for _ in range(a["period"] - 1):
            pts.append(oracle.period_map(pts[-1], W, S, Z, 1, rtol=1e-12, atol=1e-12))
        assert np.min(np.hypot(*(np.array(pts) - end).T)) < 1e-6


def test_the_map_does_not_depend_on_where_its_tasks_run(maps):
    """The tasks are pure functions of their specs: run in reverse order (as a cluster may
    finish them), the map is the same."""
    fast, _, _ = maps

    def reversed_run(name, function, specs):
        return [function(s) for s in specs[::-1]][::-1]
    again = db.cell_basin_map(W, S, Z, grid=GRID, options=OPTIONS, run=reversed_run, **BUDGET)
    assert (again.labels == fast.labels).all() and (again.method == fast.method).all()


def test_evidence_conflicts_are_never_reused():
    """Two tiles giving one cell two labels make it CONFLICT; a label given twice stays."""
    ev = np.full((2, 3), db.UNSEEN, np.int16)
    ev[0, 0] = 1
    tiles = [{"changed": np.array([1, 2]), "values": np.array([0, 0])},
             {"changed": np.array([1, 3]), "values": np.array([0, 1])},
             {"changed": np.array([2]), "values": np.array([1])}]
    out = db.merge_evidence(ev, tiles)
    assert list(out) == [1, 0, db.CONFLICT, 1, db.UNSEEN, db.UNSEEN]


def test_rounds_cover_every_cell_once():
    cells = np.concatenate([db.round_cells((13, 7), r, 4) for r in range(4)])
    assert sorted(cells) == list(range(13 * 7))


def test_a_stores_orbits_need_only_their_start_points(maps):
    """Stable orbits given as a store holds them (period, start point), no probe: the same
    attractors, the same map but near the boundary."""
    fast, _, _ = maps
    orbits = [{"period": a["period"], "x0": np.array([a["q0"], a["v0"]]), "stable": True,
               "status": 0} for a in fast.attractors]
    again = db.cell_basin_map(W, S, Z, grid=GRID, options=OPTIONS, orbits=orbits, probe=None,
                              **BUDGET)
    assert [(a["kind"], a["period"]) for a in again.attractors] == \
        [("periodic", 1), ("periodic", 2)]
    assert (again.labels != fast.labels).mean() < 0.02
