"""The paper's scheme, the benchmarks' baseline (kernels/central_difference.py), against the
independent scipy oracle (benchmarks/oracle.py): it must be the scheme the paper describes,
converge as a second-order scheme should, and its tuned version must compute the same thing."""
from __future__ import annotations

from math import pi

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels.central_difference import cd_map, cd_map3, cd_shoot, cd_shoot_tuned


# (omega, sigma, zeta, m, start point near the orbit, n): in contact; 60 % flight; n = 1 impacts
ORBITS = {
    "in contact": (1.5, 0.2, 0.01, 1, (-0.1616, 0.0057), 1.5),
    "long flights": (0.8, 1.5, 0.01, 1, (-7.70, 0.169), 1.5),
    "impacts n=1": (0.5, 0.8, 0.05, 1, (0.70, 0.0), 1.0),
}


@pytest.mark.parametrize("name", ["in contact", "impacts n=1"])
def test_map_converges_at_second_order_to_the_oracle(name):
    """Second order in h. With contact switches the kink at q = -n falls anywhere between grid
    points (no event location), so the order shows only over several doublings."""
    w, s, z, m, x0, n = ORBITS[name]
    ref = oracle.period_map(np.array(x0), w, s, z, m, n=n)
    out = np.empty(2)
    errs = []
    for N in (2000, 4000, 8000):
        cd_map(x0[0], x0[1], m * 2 * pi / w, N, w, s, z, n, 0, out)
        errs.append(np.abs(out - ref).max())
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert errs[-1] < 1e-5
    if name == "in contact":
        assert np.all(np.abs(rates - 2.0) < 0.1), (errs, rates)
    else:
        assert np.all(rates > 1.5) and abs(rates.mean() - 2.0) < 0.25, (errs, rates)


@pytest.mark.parametrize("name", sorted(ORBITS))
def test_three_lane_map_equals_three_maps(name):
    """cd_map3 (the tuned baseline's inner loop): the same three maps as cd_map, the forcing
    from a rotation recurrence instead of cos at every step."""
    w, s, z, m, (q0, v0), n = ORBITS[name]
    P = m * 2 * pi / w
    dq, dv = 1e-3, -2e-3
    lanes = np.empty((3, 2))
    cd_map3(q0, v0, dq, dv, P, 10000, w, s, z, n, 0, lanes)
    one = np.empty(2)
    for lane, (q, v) in enumerate(((q0, v0), (q0 + dq, v0), (q0, v0 + dv))):
        cd_map(q, v, P, 10000, w, s, z, n, 0, one)
        np.testing.assert_allclose(lanes[lane], one, rtol=1e-9, atol=1e-10)


@pytest.mark.parametrize("name", sorted(ORBITS))
def test_tuned_newton_finds_the_same_orbit(name):
    w, s, z, m, x0, n = ORBITS[name]
    ref, _ = oracle.fixed_point(np.array(x0), w, s, z, m, n=n)
    plain, tuned = np.zeros(9), np.zeros(9)
    guess = ref + 1e-2
    cd_shoot(w, s, z, m, guess[0], guess[1], n, 0, 10000, 40, 1e-9, plain)
    cd_shoot_tuned(w, s, z, m, guess[0], guess[1], n, 0, 10000, 40, 1e-9, tuned)
    assert plain[0] == 0 and tuned[0] == 0
    assert plain[3] == tuned[3]                       # same Newton iterations
    # the scheme's own error at N = 10000 is 1e-8..4e-7; the two codes agree far inside it
    assert np.abs(plain[1:3] - ref).max() < 1e-6
    assert np.abs(tuned[1:3] - plain[1:3]).max() < 1e-8
