"""study.solve.thresholds: sigma* (the lowest point of the 1T flip curve), sigma** (of the
isola's 2T fold curve) and the isola's join, against the scipy oracle (benchmarks/oracle.py:
solve_ivp, the monodromy from the variational equations, brentq / bounded minimisation; nothing
shared with kernels/), and continued in zeta (the multiple-scales limit 36 zeta as zeta -> 0,
paper Eq. 27)."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.study.solve import thresholds as th

#: the isola at zeta = 0.01 (paper Fig. 9): a rough start near its lowest point (a seed for the
#: corrector, not an expected value)
ISOLA_START = (0.85, 2.3, 1.5, 0.17)


@pytest.mark.parametrize("zeta", [0.005, 0.02])
def test_sigma_star_matches_the_scipy_oracle(zeta):
    """sigma* and omega* at two zeta values against the oracle's own minimum (the flip located
    by brentq in sigma at fixed omega, then minimize_scalar over omega): 1e-6 in sigma."""
    start = th.flip_start(zeta)
    low = th.curve_minimum("flip", 1, zeta, start, half_width=th.star_half_width(zeta))
    assert low is not None
    # the oracle's brackets from multiple scales (paper Eq. 25b-26), not from hertzmap
    s_mms = 36.0 * zeta
    s_ref, w_ref, _ = oracle.flip_curve_minimum(zeta, (2.0 - zeta, 2.0 + zeta / 2),
                                                (0.9 * s_mms, 1.5 * s_mms), (-12.0 * zeta, 0.0))
    assert abs(low.sigma - s_ref) <= 1e-6
    assert abs(low.omega - w_ref) <= 1e-4
    assert low.sigma_accuracy <= 1e-8 and low.omega_accuracy <= 1e-4
    # a minimum: the oracle's flip lies higher 0.1 zeta to either side
    for dw in (-0.1 * zeta, 0.1 * zeta):
        s_side, _ = oracle.flip_point(start[:2], (0.9 * s_mms, 1.5 * s_mms), fixed="omega",
                                      free="sigma", params={"omega": low.omega + dw,
                                                            "sigma": s_mms, "zeta": zeta},
                                      rtol=1e-11)
        assert s_side > low.sigma + 1e-7


def test_sigma_star_continued_in_zeta_lands_on_the_grid_and_tends_to_36_zeta():
    zetas = [0.0025, 0.004, 0.008]
    start = th.curve_minimum("flip", 1, 0.004, th.flip_start(0.004),
                             half_width=th.star_half_width(0.004))
    curve = th.continue_minimum("flip", 1, start, (0.0025, 0.008), land_on=zetas)
    z = np.array([v.zeta for v in curve.vertices])
    s = np.array([v.sigma for v in curve.vertices])
    assert curve.status == ("range", "range")
    assert np.all(np.diff(z) > 0) and z[0] == 0.0025 and z[-1] == 0.008
    assert len(z) >= th.MIN_VERTICES and np.all(np.diff(s) > 0)
    for zg in zetas:
        assert np.any(np.abs(z - zg) <= 1e-15), zg
    # the same minimum found directly at a zeta the continuation passed
    at = curve.vertices[int(np.argmin(np.abs(z - 0.008)))]
    direct = th.curve_minimum("flip", 1, 0.008, th.flip_start(0.008),
                              half_width=th.star_half_width(0.008))
    assert abs(at.sigma - direct.sigma) <= 1e-9
    # paper Eq. 27: sigma* / zeta -> 36 as zeta -> 0 (the departure is O(zeta^2))
    ratio = s / z
    assert abs(ratio[0] - 36.0) < 0.05 and np.all(np.diff(ratio) < 0)


def test_sigma_double_star_and_the_join_match_the_scipy_oracle():
    """zeta 0.01: sigma** against the oracle's 2T fold at omega** (the extremum of sigma along
    its branch at fixed omega, scipy's root and bounded minimisation), and the join against
    the oracle's 1T flip at omega_join (the join lies on the 1T flip curve)."""
    low = th.curve_minimum("fold", 2, 0.01, ISOLA_START, half_width=th.DOUBLE_STAR_HALF_WIDTH)
    assert low is not None and 1.4 < low.omega < 1.6
    s_ref, _ = oracle.fold_on_line((low.q0, low.v0), fixed="omega", free="sigma",
                                   params={"omega": low.omega, "sigma": low.sigma, "zeta": 0.01},
                                   m=2, half_width=0.05, rtol=1e-11, maximum=False)
    assert abs(low.sigma - s_ref) <= 1e-6
    join = th.isola_join(low)
    assert join is not None and join.accuracy <= 1e-6
    s_flip, _ = oracle.flip_point((-0.12, 0.0), (join.sigma - 0.01, join.sigma + 0.01),
                                  fixed="omega", free="sigma",
                                  params={"omega": join.omega, "sigma": join.sigma, "zeta": 0.01},
                                  rtol=1e-11)
    assert abs(join.sigma - s_flip) <= 1e-6


def test_a_curve_away_from_its_start_is_not_a_minimum():
    """A start that the corrector cannot bring onto the curve gives None, not a made-up point;
    a start outside the range is refused with the range named."""
    assert th.curve_minimum("flip", 1, 0.01, (50.0, 50.0, 2.0, 0.36), half_width=0.02) is None
    low = th.curve_minimum("flip", 1, 0.01, th.flip_start(0.01), half_width=0.02)
    with pytest.raises(ValueError, match="zeta_range"):
        th.continue_minimum("flip", 1, low, (0.02, 0.03))
