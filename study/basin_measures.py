"""The measures of a basin boundary on a label map (pure numpy/scipy), each with its error:

* **the basin entropy** S_b and the **boundary basin entropy** S_bb (Daza, Wagemakers,
  Georgeot, Guery-Odelin and Sanjuan, Sci. Rep. 6, 31416, 2016; study.basin_entropy computes
  them), with their standard errors over the boxes (the spread of the boxes' entropies S_i
  over sqrt of their number; neighbouring boxes are not independent where the boundary is
  smooth, so this is a lower bound of the error there);
* **the uncertainty exponent** alpha (Grebogi, McDonald, Ott and Yorke, Phys. Lett. A 99, 415,
  1983; McDonald et al., Physica D 17, 125, 1985): the share f(eps) of the map's states whose
  attractor changes when the state moves by eps (here: any of the four states eps cells away
  along q or along q' has another label) scales as f ~ eps^alpha; alpha is the slope of
  log f against log eps (least squares over eps = 1, 2, 4, ... cells), its error the slope's
  standard error from the fit's residuals. The boundary's box-counting dimension is
  d = D - alpha with D = 2 (alpha = 1: a smooth boundary, d = 1; alpha < 1: fractal);
* **the Wada test by the merging method** (Daza, Wagemakers and Sanjuan, Sci. Rep. 8, 9954,
  2018): for each basin i, the map with all the other basins merged into one has a boundary
  B_i (the cells with a neighbour, of 8, in the other class). A boundary is Wada when it is the
  boundary of every basin: then merging does not move it, and all the B_i coincide. On a grid
  they coincide up to its resolution, so the test is the largest Hausdorff distance between two
  B_i, in cells, against a dilation of ``r`` cells: Wada when it is at most r (with three or more
  basins). Also given: the share of the full boundary's cells within r cells of every B_i (the
  Wada cells), with its binomial standard error.

Labels: integers >= 0, one per attractor; negative cells (not computed) are left out of
f(eps); basins smaller than MIN_BASIN_SHARE of the map are left out of the Wada test (a few
stray cells, such as integration failures, are not a basin).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from hertzmap.study.basin_entropy import BOX_SIDE, box_entropies

#: the dimension of the space of initial states (q, q')
STATE_DIMENSION = 2
#: the Wada test's dilation of the merged boundaries, in cells
WADA_DILATION = 5
#: basins below this share of the map are left out of the Wada test
MIN_BASIN_SHARE = 1e-3


@dataclass(frozen=True)
class EntropyErrors:
    """Standard errors (nats) of S_b and S_bb over the boxes."""
    basin_entropy_error: float
    boundary_basin_entropy_error: float


@dataclass(frozen=True)
class UncertaintyExponent:
    """f(eps) at eps (cells), the fitted exponent alpha and its standard error, the boundary's
    dimension d = 2 - alpha (same error)."""
    epsilon: np.ndarray
    fraction: np.ndarray
    states: np.ndarray
    alpha: float
    alpha_error: float

    @property
    def dimension(self) -> float:
        return STATE_DIMENSION - self.alpha


@dataclass(frozen=True)
class WadaTest:
    """The merging method's outcome: the basins compared, the largest and smallest Hausdorff
    distances (cells) between their merged boundaries, the dilation r, whether the map passes
    (three or more basins, largest distance <= r), and the share of the boundary's cells within
    r cells of every merged boundary, with its binomial standard error."""
    basins: int
    hausdorff_max: float
    hausdorff_min: float
    dilation: int
    wada: bool
    wada_share: float
    wada_share_error: float


def entropy_errors(labels: np.ndarray, box: int = BOX_SIDE) -> EntropyErrors:
    """The standard errors of S_b and S_bb of ``labels`` over boxes of ``box`` x ``box``
    cells: the standard deviation of the boxes' entropies over sqrt of their number."""
    s, kinds = box_entropies(labels, box)
    b = s[kinds > 1]

    def se(x):
        return float(np.std(x, ddof=1) / math.sqrt(x.size)) if x.size > 1 else 0.0
    return EntropyErrors(se(s), se(b))


def uncertain_fraction(labels: np.ndarray, eps: int) -> tuple[float, int]:
    """(f, n): the share of the n cells that have all four cells ``eps`` away along either axis
    on the grid (and computed) whose label differs from at least one of those four."""
    lab = np.asarray(labels)
    e = int(eps)
    if e < 1 or 2 * e >= min(lab.shape):
        raise ValueError(f"eps must be 1..{(min(lab.shape) - 1) // 2} cells, got {eps}")
    c = lab[e:-e, e:-e]
    ok = c >= 0
    differs = np.zeros(c.shape, bool)
    for shifted in (lab[2 * e:, e:-e], lab[:-2 * e, e:-e], lab[e:-e, 2 * e:], lab[e:-e, :-2 * e]):
        ok &= shifted >= 0
        differs |= shifted != c
    n = int(ok.sum())
    return (float(differs[ok].mean()) if n else float("nan")), n


def default_epsilons(shape) -> np.ndarray:
    """eps = 1, 2, 4, ... cells up to a sixteenth of the map's smaller side (at least 4), and
    never past the largest eps the map has a cell for (``uncertain_fraction``): none on a map
    narrower than 3 cells."""
    top = min(max(4, min(shape) // 16), (min(shape) - 1) // 2)
    if top < 1:
        return np.zeros(0, int)
    return 2 ** np.arange(int(math.log2(top)) + 1)


def uncertainty_exponent(labels: np.ndarray, epsilons=None) -> UncertaintyExponent:
    """f(eps) over ``epsilons`` (cells; default_epsilons) and the slope alpha of log f against
    log eps (least squares) with its standard error (NaN with fewer than three usable eps:
    f > 0)."""
    eps = np.asarray(default_epsilons(np.shape(labels)) if epsilons is None else epsilons, int)
    pairs = [uncertain_fraction(labels, e) for e in eps]
    f = np.array([p[0] for p in pairs], float)
    n = np.array([p[1] for p in pairs], int)
    use = np.isfinite(f) & (f > 0)
    alpha = err = float("nan")
    if use.sum() >= 2:
        x, y = np.log(eps[use]), np.log(f[use])
        A = np.vstack([x, np.ones_like(x)]).T
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        alpha = float(coef[0])
        if use.sum() >= 3:
            resid = y - A @ coef
            s2 = float(resid @ resid) / (use.sum() - 2)
            err = float(math.sqrt(s2 / float(((x - x.mean()) ** 2).sum())))
    return UncertaintyExponent(eps.astype(float), f, n, alpha, err)


def _boundary(mask_or_labels: np.ndarray) -> np.ndarray:
    """The cells with a neighbour (of 8) of another value."""
    a = np.asarray(mask_or_labels)
    p = np.pad(a, 1, mode="edge")
    out = np.zeros(a.shape, bool)
    h, w = a.shape
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                out |= p[1 + di:1 + di + h, 1 + dj:1 + dj + w] != a
    return out


def _distance_to(mask: np.ndarray) -> np.ndarray:
    """Euclidean distance (cells) from every cell to the nearest cell of ``mask``."""
    return ndimage.distance_transform_edt(~mask)


def wada_merging(labels: np.ndarray, dilation: int = WADA_DILATION,
                 min_share: float = MIN_BASIN_SHARE) -> WadaTest:
    """The merging method's Wada test of a label map (module docstring)."""
    lab = np.asarray(labels)
    values, counts = np.unique(lab[lab >= 0], return_counts=True)
    keep = values[counts >= min_share * lab.size]
    merged = [_boundary(lab == v) for v in keep]
    merged = [b for b in merged if b.any()]
    if len(merged) < 2:
        return WadaTest(len(merged), float("nan"), float("nan"), int(dilation), False,
                        float("nan"), float("nan"))
    dist = [_distance_to(b) for b in merged]
    hd = []
    for i in range(len(merged)):
        for j in range(i + 1, len(merged)):
            hd.append(max(float(dist[j][merged[i]].max()), float(dist[i][merged[j]].max())))
    full = _boundary(np.where(lab >= 0, lab, -1))
    near_all = np.all([d[full] <= dilation for d in dist], axis=0)
    n = int(full.sum())
    share = float(near_all.mean()) if n else float("nan")
    return WadaTest(len(merged), max(hd), min(hd), int(dilation),
                    bool(len(merged) >= 3 and max(hd) <= dilation), share,
                    float(math.sqrt(share * (1 - share) / n)) if n else float("nan"))
