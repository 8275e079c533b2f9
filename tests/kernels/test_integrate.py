"""kernels.integrate (through kernels.simulate and directly) against the scipy oracle: transients
through contact loss and recontact, flight fraction and impacts, grazing dips inside a step,
spans that end on the way down to contact loss, the crossing guess."""
from __future__ import annotations

from math import exp, pi

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels import shoot, simulate, status
from tests.helpers import assert_liouville


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


def test_crossing_guess_is_the_hermite_interpolants_root():
    # Oracle: numpy's polynomial fit through the same end values and derivatives, and its roots.
    from hypothesis import given, settings, strategies as hs

    from hertzmap.kernels.integrate import _hermite_root

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
    from hertzmap.kernels.integrate import N_HARMONICS, N_STATS, integrate

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
