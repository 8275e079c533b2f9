"""study.orbit_rules: the class of an orbit and the identity rule, on hand-made orbits and on real
ones (a 2T orbit and its T-shift are one orbit; a 1T orbit is not the 2T solve that landed on
it)."""
from __future__ import annotations

from hypothesis import given, strategies as hs
import numpy as np

from hertzmap.kernels import shoot, simulate
from hertzmap.study.orbit_rules import (CLASS_LABELS, CLASS_NAMES, ORBIT_CLASSES, SAME_ORBIT_TOL, class_code,
                          class_codes, first_of_duplicates, same_orbit)


Z = 0.01

# (period, stable, loses contact) -> the class the paper's Fig. 6 (I-V) and its extension give
EXPECTED = {(1, True, False): 1, (2, True, False): 2, (2, True, True): 3, (2, False, False): 4,
            (2, False, True): 5, (1, True, True): 6, (1, False, False): 7, (1, False, True): 8,
            (3, True, False): 9, (4, True, True): 9, (16, True, False): 9,
            (3, False, True): 10, (6, False, False): 10}


def test_every_combination_has_its_own_class():
    for (p, s, lc), code in EXPECTED.items():
        assert class_code(dict(period=p, stable=s, loses_contact=lc)) == code
    assert sorted(set(EXPECTED.values())) == [c for c, _, _ in ORBIT_CLASSES if c]
    assert set(CLASS_NAMES) == {c for c, _, _ in ORBIT_CLASSES} and set(CLASS_LABELS) == set(EXPECTED.values())


def test_class_codes_vectorised_equals_scalar():
    keys = list(EXPECTED)
    ok = np.array([True] * len(keys) + [False])
    p = np.array([k[0] for k in keys] + [1])
    s = np.array([k[1] for k in keys] + [True])
    lc = np.array([k[2] for k in keys] + [False])
    assert class_codes(ok, p, s, lc).tolist() == [EXPECTED[k] for k in keys] + [0]


def test_a_real_orbit_is_classified_from_its_own_flags():
    o = shoot(1.5, 0.2, Z, 1, (0.0, 0.0))
    assert o.converged and o.stable and not o.loses_contact
    assert class_code(o) == 1


@given(hs.floats(-5, 5), hs.floats(-5, 5), hs.floats(-3, 3), hs.floats(1e-3, 1.0))
def test_identity_tolerance(lo, span, trace, rel):
    a = dict(period=2, min_q=lo, max_q=lo + abs(span), ptp=abs(span), trace_m=trace)
    tol = SAME_ORBIT_TOL * (1 + abs(span))
    assert same_orbit(a, dict(a))
    assert same_orbit(a, dict(a, min_q=lo + 0.5 * tol))
    assert not same_orbit(a, dict(a, min_q=lo + 2 * tol))
    assert not same_orbit(a, dict(a, trace_m=trace + 2 * SAME_ORBIT_TOL * (1 + abs(trace))))
    assert not same_orbit(a, dict(a, period=1))


def test_a_2t_orbit_and_its_t_shift_are_one_orbit_and_not_the_1t_orbit():
    w, s = 1.5, 0.2
    two = shoot(w, s, Z, 2, (-3.06, -1.40))
    assert two.converged and two.minimal_period == 2
    shifted = shoot(w, s, Z, 2, simulate(w, s, Z, two.x0, periods=1, samples_per_period=1)["final"])
    assert shifted.converged and np.hypot(*(shifted.x0 - two.x0)) > 0.1   # another start point
    assert same_orbit(two, shifted)
    one = shoot(w, s, Z, 1, (0.0, 0.0))
    assert one.converged and not same_orbit(one, shoot(w, s, Z, 2, one.x0))


def test_first_of_duplicates_keeps_the_first_of_each_orbit():
    per = np.array([[1, 2, 2, 1]])
    lo = np.array([[-1.0, -2.0, -2.0 + 1e-9, -1.0]])
    hi = np.array([[1.0, 3.0, 3.0, 1.0]])
    tr = np.array([[0.5, -1.0, -1.0, 0.25]])       # slot 3: the 1T orbit's square (a 2T solve)
    ok = np.array([[True, True, True, True]])
    assert first_of_duplicates(ok, per, lo, hi, tr).tolist() == [[True, True, False, True]]
    ok[0, 0] = False                                 # a failed slot duplicates nothing
    assert first_of_duplicates(ok, per, lo, hi, tr).tolist() == [[False, True, False, True]]
