"""Kernels against independent oracles: scipy solve_ivp (tests/oracle.py), finite differences,
Liouville's formula, the linear response, and physical identities (mean contact force = 1)."""
from __future__ import annotations

import time
from math import exp, pi

import numpy as np
import pytest

import oracle
from kernels import shoot, shoot_batch, simulate, status


def assert_liouville(orbit, tol=1e-6):
    """det M = exp(-2 zeta P) for every converged orbit (P = period * 2 pi / omega), to the
    precision a 2x2 determinant can have: relative to |m11 m22| + |m12 m21| when that is larger
    (heavy damping makes det M ~ 1e-55 from entries ~ 1e-2)."""
    if orbit.converged:
        P = orbit.period * 2 * pi / orbit.omega
        expected = exp(-2 * orbit.zeta * P)
        M = orbit.monodromy
        scale = max(expected, abs(M[0, 0] * M[1, 1]) + abs(M[0, 1] * M[1, 0]))
        assert abs(np.linalg.det(M) - expected) <= tol * scale, (orbit, expected)


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
def test_monodromy_matches_finite_differences(omega, sigma, zeta, m, guess, n, model, loses):
    orbit = shoot(omega, sigma, zeta, m, guess=guess, exponent=n, model=model, rtol=1e-12)
    M_fd = oracle.monodromy_fd(orbit.x0, omega, sigma, zeta, m, n=n, model=model, delta=1e-5)
    np.testing.assert_allclose(orbit.monodromy, M_fd, rtol=0, atol=2e-6 * np.abs(M_fd).max())
    mu = np.sort_complex(np.linalg.eigvals(M_fd))
    np.testing.assert_allclose(np.sort_complex(orbit.multipliers), mu, atol=1e-5 * abs(mu).max())


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


def test_simulate_matches_scipy_transient():
    x0 = (0.3, -0.2)
    T = 2 * pi / 0.8
    r = simulate(0.8, 1.5, 0.01, x0, t_end=3 * T, t_eval=np.linspace(0, 3 * T, 7), rtol=1e-12)
    ref = [oracle.flow(x0, 0.0, t, 0.8, 1.5, 0.01) for t in r["t"][1:]]
    np.testing.assert_allclose(np.c_[r["q"][1:], r["v"][1:]], np.array(ref), atol=1e-8)
    assert np.all(r["force"][r["q"] < -1.5] == 0.0)


def test_flight_fraction_and_impacts_against_simulated_history():
    o = shoot(0.8, 1.5, 0.01, 1, guess=(-7.7, 0.17), rtol=1e-12)
    T = 2 * pi / 0.8
    t = np.linspace(0, T, 200001)
    r = simulate(0.8, 1.5, 0.01, o.x0, t_end=T, t_eval=t, rtol=1e-12)
    in_flight = r["q"] < -1.5
    assert abs(in_flight.mean() - o.flight_fraction) < 2e-5
    assert abs(r["q"].min() - o.min_q) < 1e-7 and abs(r["q"].max() - o.max_q) < 1e-7
    # contact-force harmonics against a plain FFT of the dense history
    c = np.fft.rfft(r["force"][:-1]) / (t.size - 1)
    np.testing.assert_allclose(2 * np.abs(c[1:5]), o.force_harmonics, atol=2e-4)


def test_batch_equals_single_calls():
    om = np.array([1.5, 0.8])
    r = shoot_batch(om, [0.2, 1.5], 0.01, 1, [-0.16, -7.7], [0.006, 0.17])
    for i in range(2):
        o = shoot(om[i], [0.2, 1.5][i], 0.01, 1, guess=([-0.16, -7.7][i], [0.006, 0.17][i]))
        assert r["q0"][i] == o.x0[0] and r["v0"][i] == o.x0[1]


EXTREME = [
    (0.05, 0.5, 0.01, 1, 1.5), (10.0, 0.5, 0.01, 1, 1.5), (1.0, 10.0, 0.01, 1, 1.5),
    (0.3, 10.0, 0.01, 1, 1.5), (1.9, 0.5, 1e-4, 2, 1.5), (1.0, 0.5, 10.0, 1, 1.5),
    (0.05, 5.0, 10.0, 1, 1.5), (1.9, 0.5, 0.01, 2, 1.0), (0.8, 2.0, 0.01, 1, 10 / 9),
    (2.0, 0.5, 0.0, 2, 1.5), (1.0, 1.0, 0.01, 1, 1.5), (3.0, 9.0, 0.001, 2, 1.5),
]


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


def test_grazing_dip_inside_one_step_is_seen():
    """An orbit whose minimum dips below -n by 1e-8..1e-6, for a tiny fraction of a step."""
    # bisection on sigma (with continuation) until the 1T orbit dips just below -1.5
    lo, hi, guess = 0.9, 1.0, (0.0, 0.0)
    for sigma in np.linspace(0.1, 0.9, 9):   # continuation along the lower (in-contact) branch
        guess = shoot(0.6, sigma, 0.05, 1, guess=guess, rtol=1e-12).x0
    o = None
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        o = shoot(0.6, mid, 0.05, 1, guess=guess, rtol=1e-12)
        assert o.converged
        assert (o.min_q < -1.5) == o.loses_contact, o    # measures agree with the events
        if -1.5 - 1e-6 < o.min_q < -1.5 - 1e-8:
            break
        if o.min_q < -1.5:
            hi = mid
        else:
            lo, guess = mid, o.x0
    assert o.loses_contact and 0 < o.flight_fraction < 1e-3, o
    assert -1.5 - 1e-6 < o.min_q < -1.5 - 1e-8
    assert_liouville(o, 1e-8)
    x_ref, _ = oracle.fixed_point(o.x0 + 1e-4, 0.6, o.sigma, 0.05, 1)
    np.testing.assert_allclose(o.x0, x_ref, atol=1e-9)


def test_bad_arguments_are_reported_not_crashed():
    o = shoot(-1.0, 0.5, 0.01)
    assert o.status == status.DIVERGED and not o.converged
    o = shoot(1.0, float("nan"), 0.01)
    assert not o.converged
    with pytest.raises(ValueError, match="exponent"):
        shoot(1.0, 0.5, 0.01, exponent=-1)
    with pytest.raises(ValueError, match="model"):
        shoot(1.0, 0.5, 0.01, model="linear")


def test_block_keeps_1t_multipliers_when_a_2t_solve_lands_on_the_1t_orbit():
    """Regression: a 2T solve landing on the 1T orbit must not store the 2T monodromy."""
    from study.block import solve_block
    omega = np.linspace(1.0, 2.4, 8)
    r = solve_block(omega, np.array([0.3]), np.array([0.01]))
    one = r["period"] == 1
    T = 2 * pi / omega[:, None, None, None] * np.ones_like(r["q0"])
    det = (r["multipliers"][..., 0] * r["multipliers"][..., 1]).real
    np.testing.assert_allclose(det[one], np.exp(-2 * 0.01 * T[one]), rtol=1e-6)
    # no duplicated 1T orbit at a point
    for i in range(omega.size):
        q = r["min_q"][i, 0, 0][r["period"][i, 0, 0] == 1]
        assert np.unique(np.round(q, 8)).size == q.size


@pytest.mark.parametrize("omega, sigma, zeta, m, guess", [
    (1.5, 0.2, 0.01, 1, (-0.16, 0.006)),     # in contact
    (0.8, 1.5, 0.01, 1, (-7.7, 0.17)),       # long flights
    (1.9, 0.5, 0.01, 2, (-0.09, 1.5)),       # 2T with contact loss (minimal-period check)
])
def test_harmonics_off_changes_nothing_else(omega, sigma, zeta, m, guess):
    """harmonics=False only skips the force quadrature: every other field is bit-identical."""
    on = shoot_batch(omega, sigma, zeta, m, guess[0], guess[1], rtol=1e-10)
    off = shoot_batch(omega, sigma, zeta, m, guess[0], guess[1], rtol=1e-10, harmonics=False)
    assert on["status"] == 0
    for name, value in on.items():
        if name.startswith("force_h") or name == "mean_force":
            assert np.isfinite(value).all() and np.isnan(off[name]).all(), name
        else:
            np.testing.assert_array_equal(off[name], value, err_msg=name)


def test_cos_shifted_against_long_double():
    """The stages' excitation cos(phi0 + theta) from cos/sin(phi0): to round-off, against a
    long-double cosine of the exact sum (libm on the rounded sum errs by |phi0| eps)."""
    from math import cos, sin

    from kernels.model import cos_shifted

    rng = np.random.default_rng(0)
    phi = rng.uniform(-200.0, 200.0, 20000)
    theta = np.concatenate([rng.uniform(-1.0, 1.0, 10000), rng.uniform(-30.0, 30.0, 10000)])
    got = np.array([cos_shifted(cos(p), sin(p), p, t) for p, t in zip(phi, theta)])
    ref = np.cos(phi.astype(np.longdouble) + theta.astype(np.longdouble)).astype(float)
    small = np.abs(theta) <= 1.0
    assert np.abs(got - ref)[small].max() < 1e-15
    # beyond |theta| = 1 it falls back to libm on the rounded sum
    assert np.abs(got - ref)[~small].max() < 400 * np.finfo(float).eps


def test_crossing_guess_is_the_hermite_interpolants_root():
    # Oracle: numpy's polynomial fit through the same end values and derivatives, and its roots.
    from hypothesis import given, settings, strategies as hs

    from kernels.integrate import _hermite_root

    val = hs.floats(0.01, 10.0)
    der = hs.floats(-20.0, 20.0)

    @settings(max_examples=300, deadline=None)
    @given(val, val, der, der, der, der, hs.booleans())
    def check(g0, mg1, d0, d1, a0, a1, quintic):
        g1 = -mg1
        if quintic:
            # p(0) = g0, p'(0) = d0, p''(0) = a0, p(1) = g1, p'(1) = d1, p''(1) = a1
            rows = [[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0],
                    [1, 1, 1, 1, 1, 1], [0, 1, 2, 3, 4, 5], [0, 0, 2, 6, 12, 20]]
            rhs = [g0, d0, a0, g1, d1, a1]
        else:
            rows = [[1, 0, 0, 0], [0, 1, 0, 0], [1, 1, 1, 1], [0, 1, 2, 3]]
            rhs = [g0, d0, g1, d1]
            a0 = a1 = np.nan
        c = np.linalg.solve(np.array(rows, float), np.array(rhs, float))
        p = np.polynomial.Polynomial(c)
        x = _hermite_root(g0, d0, a0, g1, d1, a1)
        assert 0.0 < x < 1.0
        roots = [r.real for r in p.roots() if abs(r.imag) < 1e-9 and 0.0 < r.real < 1.0]
        # a sign change on (0, 1) guarantees a root; the guess must be one of them
        assert roots
        assert min(abs(x - r) for r in roots) <= 1e-9 * max(1.0, max(abs(c)))

    check()


@pytest.mark.parametrize("dim", [2, 6])
def test_spans_ending_on_the_way_down_to_contact_loss(dim):
    """Spans that end anywhere on the approach to a loss of contact (where the integrator steps
    in x = -sqrt(q + n) with t - t_ref in place of q), just before it and just after: the state
    at the end agrees with scipy, and with the variational matrix det Phi = exp(-2 zeta t).
    (A span whose last t-step started the approach in x once returned t - t_ref as q.)"""
    from kernels.integrate import N_HARMONICS, N_STATS, integrate

    omega, sigma, zeta = 0.8, 1.5, 0.01
    x0 = shoot(omega, sigma, zeta, 1, guess=(-7.7, 0.17), rtol=1e-12).x0
    # the loss of contact of this orbit is at t = 5.3365 (benchmarks/step_trace.py)
    for t1 in np.r_[np.linspace(4.6, 5.336, 23), 5.3365, 5.337, 5.4]:
        y = np.r_[x0, 1.0, 0.0, 0.0, 1.0][:dim].astype(float)
        code = integrate(y, 0.0, t1, omega, sigma, zeta, 1.5, 0, 1e-10, 1e-10, 0.1, 100_000,
                         dim == 6, False, False, 1.0, np.zeros((2, N_HARMONICS + 1)),
                         np.empty(0), np.empty((3, 0)), np.zeros(N_STATS), np.empty(dim),
                         np.empty(dim), np.empty(dim), np.empty((16, 2)), np.empty((7, 2)))
        assert code == status.CONVERGED
        np.testing.assert_allclose(y[:2], oracle.flow(x0, 0.0, t1, omega, sigma, zeta),
                                   atol=1e-8, err_msg=f"t1 = {t1}")
        if dim == 6:
            assert abs(y[2] * y[5] - y[3] * y[4] - exp(-2 * zeta * t1)) < 1e-8
