"""kernels.simulate's stroboscopic sampling (issue 21) and the integrator's grazing-recontact
loop, against independent references (exact section times, scipy's oracle)."""
from __future__ import annotations

from math import pi

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels import shoot, simulate, status
from hertzmap.kernels.api import section_times
from hertzmap.kernels.integrate import N_HARMONICS, N_STATS, S_H_RECONTACT, integrate

# omegas where ceil(periods T / T) was one too many (found by brute force over periods 1..600),
# the three, and random ones
RNG_OMEGAS = np.random.default_rng(21).uniform(0.05, 10.0, 40)
OMEGAS = [0.55, 1.1, 2.2, *RNG_OMEGAS]
PERIODS = [1, 2, 3, 7, 50, 100, 600]


@pytest.mark.parametrize("periods", PERIODS)
def test_section_times_on_the_section(periods):
    for omega in OMEGAS:
        T = 2.0 * pi / omega
        t = section_times(T, periods * T, 1)
        assert t.size == periods + 1, (omega, periods)
        # exactly k T: the product of two doubles, no accumulated drift
        assert np.array_equal(t, np.arange(periods + 1) * T), (omega, periods)
        t64 = section_times(T, periods * T, 64)
        assert t64.size == 64 * periods + 1
        assert np.array_equal(t64[::64], t), (omega, periods)


def test_section_times_known_bad_quotients():
    # 7 T / T rounds to 7.000000000000001 at these omegas: ceil() gave 9 samples, not 8
    for omega in (0.55, 1.1, 2.2):
        T = 2.0 * pi / omega
        assert (7 * T) / T > 7.0
        assert section_times(T, 7 * T, 1).size == 8


def test_section_times_partial_period():
    T = 2.0 * pi / 0.8
    np.testing.assert_array_equal(section_times(T, 2.5 * T, 1), [0.0, T, 2 * T])
    assert section_times(T, 2.5 * T, 4).size == 11


@pytest.mark.parametrize("omega", [0.55, 1.1, 2.2])
def test_simulate_samples_are_stroboscopic(omega):
    periods = 7
    r = simulate(omega, 0.2, 0.05, (0.0, 0.0), periods=periods, samples_per_period=1)
    assert r["status"] == status.CONVERGED
    T = 2.0 * pi / omega
    np.testing.assert_array_equal(r["t"], np.arange(periods + 1) * T)
    np.testing.assert_array_equal(r["q"][-1], r["final"][0])


@pytest.mark.parametrize("omega,sigma,zeta,m,guess", [
    (1.1, 0.2, 0.01, 1, (-0.1, 0.0)),      # in contact
    (0.55, 1.0, 0.1, 1, (-8.8, 3.0)),      # an omega of the issue, contact loss
    (1.9, 0.5, 0.01, 2, (-0.09, 1.5)),     # 2T with contact loss, sampled every T
])
def test_periodic_orbit_samples_repeat(omega, sigma, zeta, m, guess):
    """Sampled once per period on the section, a period-m orbit repeats every m samples."""
    o = shoot(omega, sigma, zeta, m, guess=guess, rtol=1e-12)
    assert o.converged and o.minimal_period == m, o.status_name
    periods = 60 * m + 1    # an odd count, as 7 T above
    r = simulate(omega, sigma, zeta, o.x0, periods=periods, samples_per_period=1, rtol=1e-12)
    assert r["t"].size == periods + 1
    x = np.stack([r["q"], r["v"]], axis=1)
    np.testing.assert_allclose(x[m:], x[:-m], rtol=0, atol=1e-9)
    np.testing.assert_allclose(x[0], o.x0, rtol=0, atol=0)


def test_grazing_recontact_does_not_loop():
    """A recontact with a small upward velocity, followed by a contact excursion shorter than
    the first w-step (carried over from an earlier recontact): the crossing out was located at
    the step start, and a zero-length contact repeated until the step limit. The period map
    must now complete and agree with scipy's event-restarted solution."""
    omega, sigma, zeta = 2.0, 3.0, 0.01
    T = 2.0 * pi / omega
    x0 = np.array([-1.752310929466541, -1.580970448487131])
    y = x0.copy()
    stats = np.zeros(N_STATS)
    stats[S_H_RECONTACT] = 0.2597385760632551      # the step that looped
    code = integrate(y, 0.0, T, omega, sigma, zeta, 1.5, 0, 1e-8, 1e-8, 0.18482875496553547,
                     200_000, False, False, False, T, np.zeros((2, N_HARMONICS + 1)),
                     np.empty(0), np.empty((3, 0)), stats, np.empty(2), np.empty(2),
                     np.empty(2), np.empty((16, 2)), np.empty((7, 2)))
    assert code == status.CONVERGED, status.NAMES[code]
    ref = oracle.flow(x0, 0.0, T, omega, sigma, zeta)
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-6)
