"""study.identify.profile_likelihood: 95 % intervals read off profiles of known shape (a
quadratic profile's interval is x_hat -+ 1.96 s in closed form), open sides, cliffs, and the
Jacobian columns that leave out the readings a step moved onto another branch."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2, norm

from hertzmap.study.identify.profile_likelihood import (R_CRITICAL, THRESHOLD, column,
                                                        crossings, interval, signed_root)


def test_the_thresholds_are_chi_square_and_normal_quantiles():
    assert THRESHOLD == pytest.approx(chi2.ppf(0.95, 1) / 2, rel=1e-12)
    assert R_CRITICAL == pytest.approx(norm.ppf(0.975), rel=1e-12)


def test_a_quadratic_profile_gives_the_estimate_plus_minus_1_96_standard_errors():
    x_hat, s, l_max = 3.0, 0.2, -10.0
    x = x_hat + s * np.array([-3.0, -2.0, -1.0, 1.0, 2.0, 3.0])
    p = l_max - (x - x_hat) ** 2 / (2 * s * s)
    assert np.allclose(signed_root(x, p, x_hat, l_max), [-3, -2, -1, 1, 2, 3])
    lo, hi, lo_c, hi_c = interval(x, p, x_hat, l_max, 0.0, 10.0)
    assert lo_c and hi_c
    assert lo == pytest.approx(x_hat - R_CRITICAL * s, rel=1e-12)
    assert hi == pytest.approx(x_hat + R_CRITICAL * s, rel=1e-12)


def test_a_profile_flat_to_a_bound_is_open_there_and_flat_everywhere_is_not_identified():
    x = np.array([1.0, 2.0, 4.0, 5.0])
    flat = np.full(4, -10.01)
    assert interval(x, flat, 3.0, -10.0, 1.0, 5.0) == (1.0, 5.0, False, False)
    one_sided = np.array([-10.0, -10.0, -12.5, -20.0])
    lo, hi, lo_c, hi_c = interval(x, one_sided, 3.0, -10.0, 1.0, 5.0)
    assert (lo, lo_c, hi_c) == (1.0, False, True) and 3.0 < hi < 4.0


def test_a_cliff_puts_the_end_inside_its_bracket_and_says_where_it_is():
    x = np.array([1.0, 2.0, 4.0, 5.0])
    p = np.array([-60.0, -10.2, -10.3, -60.0])      # within the threshold, then a drop of 50
    lo, hi, lo_c, hi_c = interval(x, p, 3.0, -10.0, 0.0, 6.0)
    assert lo_c and hi_c and 1.0 < lo < 2.0 and 4.0 < hi < 5.0
    brackets = crossings(x, p, 3.0, -10.0)
    assert [(b[0], b[1]) for b in brackets] == [(2.0, 1.0), (4.0, 5.0)]
    assert all(abs(b[3] - b[2]) > 5 for b in brackets)       # a cliff: halved by the fit


def test_a_jacobian_column_leaves_out_the_readings_a_jump_passed():
    R0, R1 = np.array([1.0, 2.0, 3.0, 0.1, 0.2, 0.3]), np.array([1.1, 9.0, 3.2, 0.1, 0.9, 0.3])
    seg0, seg1 = np.array([0, 0, 1]), np.array([0, 1, 1])       # reading 1 changed branch
    col = column(R0, seg0, R1, seg1, 0.1)
    assert np.allclose(col, [1.0, 0.0, 2.0, 0.0, 0.0, 0.0])
