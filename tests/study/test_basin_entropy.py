"""study.basin_entropy against closed forms: the basin entropy S_b and the boundary basin entropy S_bb
(Daza et al. 2016) of label maps whose box entropies are known by hand, and the uncertainty
fraction of a straight boundary."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hertzmap.study.basin_entropy import basin_entropy, scattered_basin_entropy, uncertainty_fraction


def _binary_entropy(p):
    return -p * math.log(p) - (1 - p) * math.log(1 - p)


def test_one_attractor_has_no_entropy():
    e = basin_entropy(np.full((20, 20), 3), box=5)
    assert (e.basin_entropy, e.boundary_basin_entropy, e.boxes, e.boundary_boxes,
            e.attractors) == (0.0, 0.0, 16, 0, 1)


def test_half_planes_only_the_straddling_boxes_count():
    """20 x 20 cells split at column 12, boxes of 5: the 4 boxes of the third box column hold
    2 of 5 columns of the right attractor (p = 2/5); the other 12 boxes are pure."""
    labels = np.zeros((20, 20), int)
    labels[:, 12:] = 1
    e = basin_entropy(labels, box=5)
    h = _binary_entropy(2 / 5)
    assert e.boxes == 16 and e.boundary_boxes == 4 and e.attractors == 2
    assert e.basin_entropy == pytest.approx(4 * h / 16, rel=1e-12)
    assert e.boundary_basin_entropy == pytest.approx(h, rel=1e-12)


def test_a_boundary_along_the_box_edges_is_not_seen():
    labels = np.zeros((20, 20), int)
    labels[:, 10:] = 1
    e = basin_entropy(labels, box=5)
    assert (e.basin_entropy, e.boundary_basin_entropy, e.boundary_boxes) == (0.0, 0.0, 0)


def test_checkerboard_at_the_box_scale_has_log_2():
    """Cells alternating like a checkerboard, boxes of 4 x 4: every box is half and half."""
    i, j = np.indices((16, 16))
    e = basin_entropy((i + j) % 2, box=4)
    assert e.boundary_boxes == e.boxes == 16
    assert e.basin_entropy == pytest.approx(math.log(2), rel=1e-12)
    assert e.boundary_basin_entropy == pytest.approx(math.log(2), rel=1e-12)


def test_cells_beyond_the_last_whole_box_and_negative_labels_are_left_out():
    labels = np.zeros((12, 12), int)
    labels[10:, :] = 1              # rows 10, 11: beyond the two whole boxes of 5
    labels[0, 0] = -1               # not computed: its box lacks a state and is left out
    e = basin_entropy(labels, box=5)
    assert (e.boxes, e.basin_entropy) == (3, 0.0)


@pytest.mark.parametrize("k", [2, 3, 5])
def test_random_labels_tend_to_log_k(k):
    """k equally likely attractors, boxes of n = 400 states: S_b = log k less the plug-in
    estimator's bias (k - 1) / (2 n) (Miller 1955), to its spread ~ sqrt(k / n) / sqrt(boxes)."""
    rng = np.random.default_rng(7)
    labels = rng.integers(0, k, size=(200, 200))
    e = basin_entropy(labels, box=20)
    n = 400
    assert e.basin_entropy == pytest.approx(math.log(k) - (k - 1) / (2 * n), abs=3e-3)
    assert e.boundary_boxes == e.boxes == 100


def test_scattered_states_are_boxed_by_cells():
    """A 4 x 4 lattice of states at cell centres 0.125 + 0.25 i of the unit square, cut into
    2 x 2 cells of 4 states; attractor 1 where q > 0.3: the two left cells hold 2 states of
    each (log 2), the right ones one attractor."""
    c = 0.125 + 0.25 * np.arange(4)
    q, v = np.meshgrid(c, c)
    states = np.column_stack([q.ravel(), v.ravel()])
    labels = (states[:, 0] > 0.3).astype(int)
    e = scattered_basin_entropy(states, labels, ((0.0, 1.0), (0.0, 1.0)), cells=(2, 2))
    assert (e.boxes, e.boundary_boxes) == (4, 2)
    assert e.basin_entropy == pytest.approx(math.log(2) / 2, rel=1e-12)
    assert e.boundary_basin_entropy == pytest.approx(math.log(2), rel=1e-12)
    # default cells: 16 states / 4 per box = 2 x 2 cells, the same boxes
    assert scattered_basin_entropy(states, labels, ((0.0, 1.0), (0.0, 1.0))) == e


def test_scattered_cells_with_one_state_are_left_out():
    states = np.array([[0.1, 0.1], [0.2, 0.2], [0.9, 0.9]])
    e = scattered_basin_entropy(states, [0, 1, 0], ((0.0, 1.0), (0.0, 1.0)), cells=(2, 2))
    assert (e.boxes, e.boundary_boxes) == (1, 1)
    assert e.basin_entropy == pytest.approx(math.log(2), rel=1e-12)


def test_uncertainty_fraction_of_a_straight_boundary():
    """20 x 20 cells split at column 12: the cells of columns 11 and 12 change their outcome
    one cell away."""
    labels = np.zeros((20, 20), int)
    labels[:, 12:] = 1
    assert uncertainty_fraction(labels) == pytest.approx(2 / 20, rel=1e-12)
    assert uncertainty_fraction(np.zeros((5, 5), int)) == 0.0


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="2-D"):
        basin_entropy(np.zeros(10, int))
    with pytest.raises(ValueError, match="box"):
        basin_entropy(np.zeros((4, 4), int), box=5)
    with pytest.raises(ValueError, match="labels"):
        scattered_basin_entropy(np.zeros((3, 2)), [0, 1], ((0, 1), (0, 1)))
