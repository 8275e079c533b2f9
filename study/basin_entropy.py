"""Measures of basin structure (pure numpy): the basin entropy and the boundary basin entropy
of Daza, Wagemakers, Georgeot, Guery-Odelin and Sanjuan (Sci. Rep. 6, 31416, 2016), and the
uncertainty fraction (Grebogi, McDonald, Ott and Yorke, Phys. Lett. A 99, 415, 1983).

Basin entropy: the region of initial states is covered by N boxes; in box i the share of its
states that end on attractor j is p_ij, and the box's Gibbs entropy is
S_i = -sum_j p_ij log p_ij. Then

* S_b = (1/N) sum_i S_i, the basin entropy (0: one attractor everywhere; log k at most, k the
  number of attractors);
* S_bb = (1/N_b) sum_{i boundary} S_i, the boundary basin entropy, over the N_b boxes that hold
  more than one attractor; S_bb > log 2 is a sufficient condition for a fractal boundary.

Natural logarithms: both are in nats. Labels are integers, one per attractor (any outcome the
caller tells apart, "unsettled" or "failed" included, is an attractor here); a negative label
is a state not computed, left out of the boxes.

Used by the census (per grid point, over its scattered initial states: study.solve.basin_grid) and
by the basin map of a grid of initial states (study.solve.basin_grid.basin_map).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Box side in cells of a basin map: Daza et al. take boxes of n = 5 x 5 states.
BOX_SIDE = 5
#: States per box the scattered states of a box of initial states are partitioned for (the
#: cells per side: sqrt(states / STATES_PER_BOX), at least 1).
STATES_PER_BOX = 4


@dataclass(frozen=True)
class BasinEntropy:
    """S_b and S_bb (nats), the boxes they are means over (``boxes``: N, ``boundary_boxes``:
    N_b) and the number of distinct labels seen. S_bb is 0 where no box is a boundary box."""
    basin_entropy: float
    boundary_basin_entropy: float
    boxes: int
    boundary_boxes: int
    attractors: int


def _box_entropies(box_of: np.ndarray, labels: np.ndarray, min_states: int
                   ) -> tuple[np.ndarray, np.ndarray, int]:
    """(S_i, number of labels in box i) of the boxes with at least ``min_states`` states, and
    the number of distinct labels."""
    keep = labels >= 0
    box_of, labels = box_of[keep], labels[keep]
    if labels.size == 0:
        return np.empty(0), np.empty(0, int), 0
    _, lab = np.unique(labels, return_inverse=True)
    _, box = np.unique(box_of, return_inverse=True)
    counts = np.zeros((box.max() + 1, lab.max() + 1))
    np.add.at(counts, (box, lab), 1.0)
    n = counts.sum(axis=1)
    counts, n = counts[n >= min_states], n[n >= min_states]
    p = counts / n[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = -np.where(p > 0, p * np.log(p), 0.0).sum(axis=1)
    return s, (counts > 0).sum(axis=1), int(lab.max() + 1)


def _summary(s: np.ndarray, kinds: np.ndarray, attractors: int) -> BasinEntropy:
    boundary = kinds > 1
    return BasinEntropy(
        basin_entropy=float(s.mean()) if s.size else float("nan"),
        boundary_basin_entropy=float(s[boundary].mean()) if boundary.any() else 0.0,
        boxes=int(s.size), boundary_boxes=int(boundary.sum()), attractors=attractors)


def basin_entropy(labels: np.ndarray, box: int = BOX_SIDE) -> BasinEntropy:
    """S_b and S_bb of a basin map: ``labels`` (2-D, one integer per cell of a regular grid of
    initial states, negative: not computed) covered by boxes of ``box`` x ``box`` cells. Cells
    beyond the last whole box along an axis are left out, and so are boxes with a cell not
    computed (every box holds n = box^2 states, as in Daza et al.)."""
    return _summary(*_map_boxes(labels, box))


def box_entropies(labels: np.ndarray, box: int = BOX_SIDE) -> tuple[np.ndarray, np.ndarray]:
    """Per box of ``box`` x ``box`` cells of a basin map (as basin_entropy takes them): its
    entropy S_i (nats) and the number of labels in it."""
    s, kinds, _ = _map_boxes(labels, box)
    return s, kinds


def _map_boxes(labels, box):
    labels = np.asarray(labels)
    if labels.ndim != 2:
        raise ValueError(f"labels must be 2-D, got shape {labels.shape}")
    if box < 1 or box > min(labels.shape):
        raise ValueError(f"box must be 1..{min(labels.shape)} cells, got {box}")
    a, b = labels.shape[0] // box, labels.shape[1] // box
    cut = labels[:a * box, :b * box]
    box_of = (np.arange(a)[:, None] * b + np.arange(b)[None, :]).repeat(box, 0).repeat(box, 1)
    return _box_entropies(box_of.ravel(), cut.ravel(), box * box)


def scattered_basin_entropy(states: np.ndarray, labels: np.ndarray,
                            region: tuple[tuple[float, float], tuple[float, float]],
                            cells: tuple[int, int] | None = None,
                            min_states: int = 2) -> BasinEntropy:
    """S_b and S_bb of labelled states scattered over ``region`` ((q_lo, q_hi), (v_lo, v_hi)):
    the region is cut into ``cells`` = (along q, along v) equal cells (default: square-ish
    cells of about STATES_PER_BOX states each), each cell's states are a box. Cells with fewer
    than ``min_states`` states (a single state shows no mix) are left out; states outside the
    region go to the nearest cell."""
    states = np.asarray(states, float).reshape(-1, 2)
    labels = np.asarray(labels).ravel()
    if states.shape[0] != labels.size:
        raise ValueError(f"{states.shape[0]} states but {labels.size} labels")
    if cells is None:
        side = max(1, int(round(np.sqrt(labels.size / STATES_PER_BOX))))
        cells = (side, side)
    (q0, q1), (v0, v1) = region
    iq = np.clip(((states[:, 0] - q0) / (q1 - q0) * cells[0]).astype(int), 0, cells[0] - 1)
    iv = np.clip(((states[:, 1] - v0) / (v1 - v0) * cells[1]).astype(int), 0, cells[1] - 1)
    return _summary(*_box_entropies(iq * cells[1] + iv, labels, min_states))


def uncertainty_fraction(labels: np.ndarray) -> float:
    """The share of a basin map's computed cells whose label differs from that of a computed
    neighbour one cell away (along either axis): the uncertain states at eps = one cell
    (Grebogi et al. 1983). Its decay with eps, f ~ eps^alpha, gives the boundary's uncertainty
    exponent alpha (alpha < 1: fractal); here eps is fixed by the grid."""
    labels = np.asarray(labels)
    ok = labels >= 0
    uncertain = np.zeros(labels.shape, bool)
    for axis in (0, 1):
        a = np.swapaxes(labels, 0, axis)
        k = np.swapaxes(ok, 0, axis)
        u = np.swapaxes(uncertain, 0, axis)
        differs = (a[1:] != a[:-1]) & k[1:] & k[:-1]
        u[1:] |= differs
        u[:-1] |= differs
    return float(uncertain[ok].mean()) if ok.any() else float("nan")
