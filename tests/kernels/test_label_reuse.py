"""kernels.label_reuse: the uniform block of evidence, the certified neighbourhoods, and the
transient that stops on them, against hand-made grids and the scipy oracle's period map."""
from __future__ import annotations

import numpy as np

from benchmarks import oracle
from hertzmap.kernels.label_reuse import CONFLICT, OPEN, UNSEEN, reuse_into, uniform_label

W, S, Z = 1.7, 1.0, 0.05
BOX = np.array([-6.0, -5.0, 1.0, 1.0])          # 10 x 10 cells of side 1 from (-6, -5)
NO_CERT = (np.empty((0, 8)), np.empty(0, np.int64))


def test_uniform_label_needs_the_whole_block():
    ev = np.full((10, 10), 2, np.int16)
    assert uniform_label(ev, -1.5, 0.5, BOX, 1) == 2
    ev[5, 5] = 3                                   # a neighbour of the cell of (-1.5, 0.5)
    assert uniform_label(ev, -1.5, 0.5, BOX, 1) == -1
    assert uniform_label(ev, -1.5, 0.5, BOX, 0) == 2              # the cell alone
    ev[5, 5] = CONFLICT
    assert uniform_label(ev, -1.5, 0.5, BOX, 1) == -1
    assert uniform_label(ev, -5.5, 0.5, BOX, 1) == -1     # the block leaves the grid
    assert uniform_label(ev, 40.0, 0.5, BOX, 0) == -1


def test_one_period_is_the_oracles_period_map():
    q0 = np.array([0.3, -2.0, 1.5])
    v0 = np.array([0.1, 1.0, -2.0])
    label = np.empty(3, np.int64)
    periods = np.empty(3, np.int64)
    end = np.empty((3, 2))
    ev = np.full((10, 10), UNSEEN, np.int16)
    reuse_into(W, S, Z, 1.5, 0, 1e-11, 200_000, q0, v0, 1, ev, BOX, 1, 1, *NO_CERT, label,
               periods, end)
    assert list(label) == [OPEN] * 3 and list(periods) == [1] * 3
    for i in range(3):
        x = oracle.period_map(np.array([q0[i], v0[i]]), W, S, Z, 1, rtol=1e-12, atol=1e-12)
        assert np.hypot(*(end[i] - x)) < 1e-8
    assert (ev == UNSEEN).all()                    # no label: no evidence


def test_a_transient_stops_in_uniform_evidence_and_leaves_its_own():
    """All evidence 4 (40 x 40 cells of side 1 around the origin) but the start's cell, far from the
    attractors: the
    first image lands in a uniform block (one period); the start cell gets the label."""
    box = np.array([-20.0, -20.0, 1.0, 1.0])
    ev = np.full((40, 40), 4, np.int16)
    ev[24, 23] = UNSEEN                              # the cell of (3.5, 4.0)
    label = np.empty(1, np.int64)
    periods = np.empty(1, np.int64)
    end = np.empty((1, 2))
    reuse_into(W, S, Z, 1.5, 0, 1e-10, 200_000, np.array([3.5]), np.array([4.0]), 50, ev, box,
               1, 1, *NO_CERT, label, periods, end)
    assert label[0] == 4 and periods[0] == 1
    assert ev[24, 23] == 4
    # with 2 visits asked it runs one more period
    ev[24, 23] = UNSEEN
    reuse_into(W, S, Z, 1.5, 0, 1e-10, 200_000, np.array([3.5]), np.array([4.0]), 50, ev, box,
               1, 2, *NO_CERT, label, periods, end)
    assert label[0] == 4 and periods[0] == 2


def test_a_cell_reached_by_two_attractors_is_a_conflict():
    ev = np.full((10, 10), 4, np.int16)
    ev[5, 6] = 3                                   # the start cell held another label
    label = np.empty(1, np.int64)
    reuse_into(W, S, Z, 1.5, 0, 1e-10, 200_000, np.array([0.3]), np.array([0.1]), 50, ev, BOX,
               0, 1, *NO_CERT, label, np.empty(1, np.int64), np.empty((1, 2)))
    assert label[0] == 4 and ev[5, 6] == CONFLICT


def test_the_budget_ends_open_without_evidence():
    ev = np.full((10, 10), UNSEEN, np.int16)
    label = np.empty(1, np.int64)
    periods = np.empty(1, np.int64)
    reuse_into(W, S, Z, 1.5, 0, 1e-10, 200_000, np.array([0.3]), np.array([0.1]), 7, ev, BOX,
               1, 1, *NO_CERT, label, periods, np.empty((1, 2)))
    assert label[0] == OPEN and periods[0] == 7 and (ev == UNSEEN).all()


def test_a_certified_neighbourhood_needs_its_contraction_seen():
    """A transient started 1e-3 off a stable orbit (period m), inside a neighbourhood V =
    |x - x*|^2 <= 1e-2 with kappa = 0.999: it enters after one period and stops once it is back
    m periods later with V decreased, after 1 + m periods; with kappa = 1e-9 (a contraction
    the orbit does not have) it never stops there."""
    from hertzmap.kernels import attractor

    a = attractor(W, S, Z, x0=(0.0, 0.0))
    assert a.status_name == "converged"
    m = int(a.period)
    q, v = a.orbit.x0
    ev = np.full((10, 10), UNSEEN, np.int16)
    label = np.empty(1, np.int64)
    periods = np.empty(1, np.int64)
    for kappa, want in ((0.999, (7, 1 + m)), (1e-9, (OPEN, 20))):
        cert = np.array([[q, v, 1.0, 0.0, 1.0, 1e-2, kappa, float(m)]])
        reuse_into(W, S, Z, 1.5, 0, 1e-10, 200_000, np.array([q + 1e-3]), np.array([v]), 20,
                   ev, BOX, 1, 1, cert, np.array([7]), label, periods, np.empty((1, 2)))
        assert (label[0], periods[0]) == want
