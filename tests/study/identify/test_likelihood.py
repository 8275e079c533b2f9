"""study.identify.likelihood: the noise model's maximum likelihood against a direct numerical
maximisation of the written-out log-likelihood (scipy's Nelder-Mead), its estimates on samples
of known noise, the least-squares form of the log-likelihood, and f0's scan."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize

from hertzmap.study.identify.likelihood import (f0_scan_step, loglik_of_squares, noise_fit,
                                                pseudo_residuals, pseudo_residuals_dm)


def written_out(y, m, a, b):
    """log L of paper-free statistics: the normal density of each reading, sd^2 = (a m)^2 + b^2."""
    sd2 = (a * m) ** 2 + b * b
    return float(np.sum(-0.5 * np.log(2 * math.pi * sd2) - 0.5 * (y - m) ** 2 / sd2))


def sample(n, a, b, seed):
    rng = np.random.default_rng(seed)
    m = np.concatenate([rng.uniform(1.0, 100.0, n // 2), np.zeros(n - n // 2)])
    sd = np.sqrt((a * m) ** 2 + b * b)
    return m + sd * rng.standard_normal(n), m


@pytest.mark.parametrize("a, b", [(0.03, 0.05), (0.1, 1e-3), (1e-3, 2.0)])
def test_the_noise_fit_is_the_maximum_of_the_written_out_likelihood(a, b):
    y, m = sample(400, a, b, seed=5)
    fit = noise_fit(y, m, float(np.sqrt(np.mean(y * y))))
    assert fit.loglik == pytest.approx(written_out(y, m, fit.a, fit.b), abs=1e-8)
    # scipy's Nelder-Mead on (log a, log b), started at the truth, finds no better point
    res = minimize(lambda p: -written_out(y, m, math.exp(p[0]), math.exp(p[1])),
                   [math.log(a), math.log(b)], method="Nelder-Mead",
                   options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000})
    assert fit.loglik >= -res.fun - 1e-6


def test_the_noise_fit_recovers_known_noise_and_folded_readings_keep_their_moment():
    """20,000 readings (half of them of a model at 0): a and b within 2 % (their standard
    errors here are ~0.5 %); readings measured as amplitudes |m + e| (folded where m = 0)
    give the same estimates, the folding leaving the second moment unchanged."""
    y, m = sample(20000, 0.03, 0.05, seed=11)
    for ys in (y, np.abs(y)):
        fit = noise_fit(ys, m, float(np.sqrt(np.mean(ys * ys))))
        assert fit.a == pytest.approx(0.03, rel=0.02) and fit.b == pytest.approx(0.05, rel=0.02)


def test_the_pseudo_residuals_sum_of_squares_is_minus_twice_the_log_likelihood():
    y, m = sample(300, 0.04, 0.1, seed=2)
    for a, b in ((0.04, 0.1), (0.1, 0.5)):
        R = pseudo_residuals(y, m, a, b)
        assert loglik_of_squares(float(R @ R), y.size, b) == pytest.approx(
            written_out(y, m, a, b), abs=1e-9)
        # the derivative in m, reading by reading, against central differences
        h = 1e-6 * np.maximum(np.abs(m), 1.0)
        fd = (pseudo_residuals(y, m + h, a, b) - pseudo_residuals(y, m - h, a, b)) / np.tile(
            2 * h, 2)
        assert np.allclose(pseudo_residuals_dm(y, m, a, b), fd, rtol=1e-5, atol=1e-5)


def test_the_f0_scan_lets_a_jump_pass_one_measured_point_at_a_time():
    class P:
        frequency = np.r_[np.linspace(200.0, 600.0, 201), np.linspace(600.0, 200.0, 101)]
        direction = np.r_[np.zeros(201, int), np.ones(101, int)]
    # the smallest relative step: 2 Hz at 600 Hz; half of it
    assert f0_scan_step(P) == pytest.approx(0.5 * 2.0 / 600.0)
