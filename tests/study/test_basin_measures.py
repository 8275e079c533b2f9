"""study.basin_measures against independent oracles: the boxes' entropies and their standard
error on maps whose boxes are known by hand, the uncertainty exponent of smooth boundaries
(alpha = 1: d = 1) and of the graph of a Weierstrass function, whose box-counting dimension is
2 - H (Kaplan, Mallet-Paret and Yorke, Ergod. Th. Dyn. Sys. 4, 261, 1984), and the merging
method's Wada test on the basins of Newton's method for z^3 = 1 (Wada: every boundary point of
one basin is a boundary point of all three) and on three sectors (not Wada)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hertzmap.study.basin_entropy import basin_entropy, box_entropies
from hertzmap.study.basin_measures import (entropy_errors, uncertain_fraction,
                                           uncertainty_exponent, wada_merging)

N = 600


def _grid(n=N, half=1.0):
    x = np.linspace(-half, half, n)
    return np.meshgrid(x, x)


def test_box_entropies_of_a_checkerboard_and_their_error():
    """A checkerboard of single cells in boxes of 5 x 5: every box holds 13 of one label and
    12 of the other, S_i = -(13/25 log 13/25 + 12/25 log 12/25) in every box: S_b = S_bb =
    that, with no spread (error 0)."""
    labels = np.indices((20, 20)).sum(axis=0) % 2
    s, kinds = box_entropies(labels, 5)
    h = -(13 / 25 * math.log(13 / 25) + 12 / 25 * math.log(12 / 25))
    assert np.allclose(s, h, rtol=1e-12) and (kinds == 2).all()
    assert basin_entropy(labels, 5).basin_entropy == pytest.approx(h, rel=1e-12)
    err = entropy_errors(labels, 5)
    assert err.basin_entropy_error == pytest.approx(0, abs=1e-12)
    assert err.boundary_basin_entropy_error == pytest.approx(0, abs=1e-12)


def test_entropy_error_of_half_planes():
    """20 x 20 split at column 12 (boxes of 5): 4 boxes of entropy h(2/5), 12 of 0: the
    standard error of S_b is the sample deviation of those 16 values over 4."""
    labels = np.zeros((20, 20), int)
    labels[:, 12:] = 1
    p = 0.4
    h = -p * math.log(p) - (1 - p) * math.log(1 - p)
    values = np.array([h] * 4 + [0.0] * 12)
    err = entropy_errors(labels, 5)
    assert err.basin_entropy_error == pytest.approx(np.std(values, ddof=1) / 4, rel=1e-12)
    assert err.boundary_basin_entropy_error == 0.0


def test_uncertain_fraction_of_a_straight_boundary_is_exact():
    """A vertical boundary between columns 299 and 300 of 600: the cells eps or fewer columns
    from it change label when moved eps along q: 2 eps columns of the N - 2 eps counted."""
    labels = np.zeros((N, N), int)
    labels[:, N // 2:] = 1
    for eps in (1, 3, 8):
        f, n = uncertain_fraction(labels, eps)
        assert n == (N - 2 * eps) ** 2
        assert f == pytest.approx(2 * eps / (N - 2 * eps), rel=1e-12)


@pytest.mark.parametrize("shape, eps", [((4, 3), [1]), ((5, 9), [1, 2]), ((2, 40), [])])
def test_a_small_map_uses_only_the_eps_it_has_cells_for(shape, eps):
    """A map of 4 x 3 cells (hertzmap basins --grid 4 3) has cells 1 away on both sides along
    each axis and none 2 away: f(1) only, and no exponent (one eps does not give a slope; two
    give a slope without an error)."""
    labels = np.zeros(shape, int)
    labels[:, shape[1] // 2:] = 1
    u = uncertainty_exponent(labels)
    np.testing.assert_array_equal(u.epsilon, eps)
    assert np.isnan(u.alpha) == (len(eps) < 2) and np.isnan(u.alpha_error)


@pytest.mark.parametrize("shape", ["line", "circle"])
def test_a_smooth_boundary_has_exponent_one(shape):
    x, y = _grid()
    labels = (x + 0.3 * y > 0.1) if shape == "line" else (x ** 2 + y ** 2 < 0.5)
    u = uncertainty_exponent(labels.astype(int))
    # the circle's curvature over the largest eps (37 cells of a 212-cell radius) adds 0.06
    assert u.alpha == pytest.approx(1.0, abs=0.08)
    assert u.dimension == pytest.approx(1.0, abs=0.08)
    assert 0 <= u.alpha_error < 0.03


@pytest.mark.parametrize("hurst", [0.3, 0.5, 0.7])
def test_a_weierstrass_boundary_has_exponent_h(hurst):
    """The region below the graph of W(x) = sum_k 3^(-k H) cos(3^k x) (k = 0..11, finer than a
    cell) over 1000 columns: the boundary's dimension is 2 - H, so alpha = H; the grid's finite
    resolution pulls the fit up a little (measured +0.05 to +0.08), within 0.1."""
    n = 1000
    xs = np.linspace(0, 2 * np.pi, n)
    w = sum(3.0 ** (-k * hurst) * np.cos(3.0 ** k * xs) for k in range(12))
    w = (w - w.mean()) / np.ptp(w)
    labels = (np.linspace(-1, 1, n)[:, None] > w[None, :]).astype(int)
    u = uncertainty_exponent(labels)
    assert u.alpha == pytest.approx(hurst, abs=0.1)
    assert u.alpha < 0.95 and u.dimension > 1.05


def _newton_basins(n=N):
    x, y = _grid(n, 1.5)
    z = x + 1j * y
    with np.errstate(all="ignore"):
        for _ in range(60):
            z = z - (z ** 3 - 1) / (3 * z ** 2)
    roots = np.exp(2j * np.pi * np.arange(3) / 3)
    return np.argmin(np.abs(z[..., None] - roots), axis=-1)


def test_newton_basins_are_wada():
    """The three basins of Newton's method for z^3 = 1 share one boundary (a classical Wada
    example): the merged boundaries lie within a few cells of one another, and nearly every
    boundary cell is near all three; their boundary is fractal (alpha < 1)."""
    w = wada_merging(_newton_basins())
    assert w.basins == 3 and w.wada
    assert w.hausdorff_max <= w.dilation
    assert w.wada_share > 0.99 and w.wada_share_error < 0.01
    assert uncertainty_exponent(_newton_basins()).alpha < 0.9


def test_three_sectors_are_not_wada():
    """Three sectors meeting at the centre: each pair shares a ray, far from the third basin's
    boundary."""
    x, y = _grid()
    labels = (((np.arctan2(y, x) + np.pi) / (2 * np.pi) * 3).astype(int)) % 3
    w = wada_merging(labels)
    assert w.basins == 3 and not w.wada
    assert w.hausdorff_max > 100 and w.wada_share < 0.05


def test_two_basins_are_never_wada():
    x, _ = _grid()
    w = wada_merging((x > 0).astype(int))
    assert w.basins == 2 and not w.wada and w.hausdorff_max <= 1.5
