"""kernels.shooting through kernels.shoot against independent oracles: scipy solve_ivp
(benchmarks/oracle.py), its variational equations for the monodromy, Liouville's formula, the
linear response, the T-shift of 2T orbits, bounded failure on extreme cases."""
from __future__ import annotations

from math import pi
import time

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels import shoot, simulate, status
from tests.helpers import assert_liouville


# (omega, sigma, zeta, period, guess, exponent, model, loses contact?)
ORACLE_CASES = [
    pytest.param(1.5, 0.2, 0.01, 1, (-0.16, 0.006), 1.5, "hertz", False, id="1T-contact"),
    pytest.param(0.8, 1.5, 0.01, 1, (-7.7, 0.17), 1.5, "hertz", True, id="1T-long-flight"),
    pytest.param(1.9, 0.5, 0.01, 2, (-0.09, 1.5), 1.5, "hertz", True, id="2T-contact-loss"),
    pytest.param(1.9, 0.5, 0.01, 2, (0.19, 1.42), 10 / 9, "hertz", True, id="2T-n10/9"),
    pytest.param(0.5, 0.8, 0.05, 1, (0.7, 0.0), 1.0, "hertz", True, id="1T-n1-impacts"),
    pytest.param(1.9, 0.5, 0.01, 2, (-1.0, 0.5), 1.5, "taylor", True, id="2T-taylor"),
]



@pytest.mark.parametrize("omega,sigma,zeta,m,guess,n,model,loses", ORACLE_CASES)
def test_force_measures_match_scipy(omega, sigma, zeta, m, guess, n, model, loses):
    """mean, rms and peak contact force of an orbit against the oracle's integrals of F and F^2
    carried along its own flow from the same start point, and F of its own max q."""
    orbit = shoot(omega, sigma, zeta, m, guess=guess, exponent=n, model=model, rtol=1e-12)
    assert orbit.converged, orbit.status_name
    mean, rms, max_q = oracle.force_moments(orbit.x0, omega, sigma, zeta, m, n=n, model=model)
    assert orbit.mean_force == pytest.approx(mean, rel=1e-8, abs=1e-8)
    assert orbit.rms_force == pytest.approx(rms, rel=1e-8)
    assert orbit.peak_force == pytest.approx(float(oracle.force(max_q, n, model)), rel=1e-8)
    assert orbit.rms_force > mean      # F varies over the orbit

EXTREME = [
    (0.05, 0.5, 0.01, 1, 1.5), (10.0, 0.5, 0.01, 1, 1.5), (1.0, 10.0, 0.01, 1, 1.5),
    (0.3, 10.0, 0.01, 1, 1.5), (1.9, 0.5, 1e-4, 2, 1.5), (1.0, 0.5, 10.0, 1, 1.5),
    (0.05, 5.0, 10.0, 1, 1.5), (1.9, 0.5, 0.01, 2, 1.0), (0.8, 2.0, 0.01, 1, 10 / 9),
    (2.0, 0.5, 0.0, 2, 1.5), (1.0, 1.0, 0.01, 1, 1.5), (3.0, 9.0, 0.001, 2, 1.5),
]


@pytest.mark.parametrize("omega,sigma,zeta,m,guess,n,model,loses", ORACLE_CASES)
def test_orbit_matches_scipy(omega, sigma, zeta, m, guess, n, model, loses):
    orbit = shoot(omega, sigma, zeta, m, guess=guess, exponent=n, model=model, rtol=1e-12)
    assert orbit.converged, orbit.status_name
    assert orbit.loses_contact == loses
    assert orbit.minimal_period == m
    # the oracle solves with its own integrator and root finder, from a point 1e-3 away, and
    # must itself land on a periodic orbit (its residual is checked below)
    x_ref, _ = oracle.fixed_point(orbit.x0 + 1e-3, omega, sigma, zeta, m, n=n, model=model)
    residual = np.abs(oracle.period_map(x_ref, omega, sigma, zeta, m, n=n, model=model) - x_ref)
    assert residual.max() < 1e-10, "oracle did not converge to a periodic orbit"
    np.testing.assert_allclose(orbit.x0, x_ref, rtol=0, atol=1e-9)
    assert_liouville(orbit, 1e-9)
    assert abs(orbit.mean_force - 1.0) < 1e-8   # the mean contact force is the static load


@pytest.mark.parametrize("omega,sigma,zeta,m,guess,n,model,loses", ORACLE_CASES)
def test_monodromy_matches_the_variational_equations(omega, sigma, zeta, m, guess, n, model, loses):
    """The monodromy against the oracle's own: scipy integrates the variational equations with
    the orbit (no saltation at the switches: the force is continuous there), at the oracle's own
    fixed point, found by Newton (hybr) with that exact Jacobian from 1e-3 away. (Finite
    differences of the period map are no oracle here: across contact events their error at
    delta = 1e-5 reached 7.5e-6 on the 2T case, the integrations' event noise over delta.)"""
    orbit = shoot(omega, sigma, zeta, m, guess=guess, exponent=n, model=model, rtol=1e-12)
    x_ref, M_ref, _ = oracle.shoot(orbit.x0 + 1e-3, omega, sigma, zeta, m, n=n, model=model,
                                   rtol=1e-13)
    np.testing.assert_allclose(orbit.x0, x_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(orbit.monodromy, M_ref, rtol=0, atol=1e-8 * np.abs(M_ref).max())
    mu = np.sort_complex(np.linalg.eigvals(M_ref))
    np.testing.assert_allclose(np.sort_complex(orbit.multipliers), mu, atol=1e-7 * abs(mu).max())


def test_error_falls_with_tolerance():
    ref = shoot(0.8, 1.5, 0.01, 1, guess=(-7.7, 0.17), rtol=1e-14)
    errors = []
    for rtol in (1e-6, 1e-8, 1e-10, 1e-12):
        o = shoot(0.8, 1.5, 0.01, 1, guess=(-7.7, 0.17), rtol=rtol)
        assert o.converged
        errors.append((np.abs(o.x0 - ref.x0).max(), np.abs(o.monodromy - ref.monodromy).max()))
    errors = np.array(errors)
    # strictly falling at every tightening, and by >= 1e4 from rtol 1e-6 to 1e-12
    assert np.all(np.diff(np.log10(errors), axis=0) < -0.5), errors
    assert np.all(errors[0] / errors[-1] >= 1e4), errors
    assert errors[-1, 0] < 1e-10 and errors[-1, 1] < 1e-9


@pytest.mark.parametrize("omega", [0.3, 0.9, 1.7, 3.0])
def test_small_sigma_tends_to_linear_response(omega):
    zeta = 0.05
    dev = []
    for sigma in (1e-2, 1e-3):
        X = sigma / (1 - omega**2 + 2j * zeta * omega)
        lin = np.array([X.real, (1j * omega * X).real])
        o = shoot(omega, sigma, zeta, 1, guess=lin, rtol=1e-12)
        assert o.converged and o.stable and not o.loses_contact
        assert_liouville(o)
        dev.append(np.abs(o.x0 - lin).max() / sigma)
    # relative deviation from the linear response is O(sigma): falls ~10x per decade
    assert dev[1] < 0.2 * dev[0] + 1e-9, dev
    assert dev[1] < 0.05


def test_stall_ratio_ends_a_creeping_solve_and_leaves_converging_ones_alone():
    """stall_ratio < 1 (the atlas's continuations): a 1T start point of the default scene shot
    one grid step past where its branch ends creeps (the residual settles on a floor) and
    gives up within a few iterations instead of running to max_iter; solves that converge
    take the same iterations to the same orbit."""
    creep = dict(omega=0.95, sigma=0.075, zeta=0.01, period=1, guess=(0.691577, 0.13825),
                 max_iter=10, harmonics=False)
    full = shoot(**creep)
    early = shoot(**creep, stall_ratio=0.9)
    assert full.status == early.status == status.NOT_CONVERGED
    assert full.newton_iterations == 10
    assert early.newton_iterations <= 4
    assert early.steps < full.steps / 3
    for omega, sigma, zeta, m, guess, n, model, _ in (c.values for c in ORACLE_CASES[:3]):
        a = shoot(omega, sigma, zeta, m, guess=guess, exponent=n, model=model)
        b = shoot(omega, sigma, zeta, m, guess=guess, exponent=n, model=model, stall_ratio=0.9)
        assert a.converged and b.converged
        assert (a.newton_iterations, tuple(a.x0)) == (b.newton_iterations, tuple(b.x0))
    with pytest.raises(ValueError, match="stall_ratio"):
        shoot(1.5, 0.2, 0.01, stall_ratio=0.0)


def test_two_t_solve_that_lands_on_1t_orbit_is_flagged():
    one = shoot(1.9, 0.5, 0.01, 1, guess=(-0.19, 0.005))
    two = shoot(1.9, 0.5, 0.01, 2, guess=one.x0 + 1e-3)
    assert one.converged and two.converged
    assert two.minimal_period == 1
    np.testing.assert_allclose(two.x0, one.x0, atol=1e-8)


def test_two_copies_of_a_2t_orbit_are_shifted_by_T():
    o = shoot(1.9, 0.5, 0.01, 2, guess=(-0.09, 1.5))
    T = 2 * pi / 1.9
    shifted = simulate(1.9, 0.5, 0.01, o.x0, t_end=T, t_eval=[T], rtol=1e-12)["final"]
    o2 = shoot(1.9, 0.5, 0.01, 2, guess=shifted)
    assert o2.converged and np.abs(o2.x0 - shifted).max() < 1e-8
    # same orbit: same invariants
    assert abs(o2.min_q - o.min_q) < 1e-8 and abs(o2.ptp - o.ptp) < 1e-8
    np.testing.assert_allclose(np.sort_complex(o2.multipliers), np.sort_complex(o.multipliers),
                               atol=1e-7)


@pytest.mark.parametrize("omega,sigma,zeta,m,n", EXTREME)
def test_extreme_cases_return_status_in_bounded_time(omega, sigma, zeta, m, n):
    X = sigma / (1 - omega**2 + 2j * zeta * omega)
    for guess in [(X.real, (1j * omega * X).real), (0.0, 0.0), (-1.0, 2.0), (50.0, -50.0)]:
        t0 = time.perf_counter()
        o = shoot(omega, sigma, zeta, m, guess=guess, exponent=n, max_iter=30)
        elapsed = time.perf_counter() - t0
        assert o.status in status.NAMES and o.status != status.EMPTY
        assert elapsed < 20.0
        assert_liouville(o, 1e-6)
        if o.converged:
            # never a silently wrong converged orbit: it must map onto itself (state-only path)
            P = m * 2 * pi / omega
            back = simulate(omega, sigma, zeta, o.x0, t_end=P, t_eval=[P], exponent=n,
                            rtol=1e-12)["final"]
            assert np.abs(back - o.x0).max() < 1e-6 * (1 + np.abs(o.x0).max())
