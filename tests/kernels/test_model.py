"""kernels.model: the forcing by a shifted cosine against long double, and the Taylor model's
contact-loss threshold against paper Eq. 12 (its printed value, study.analytic.paper)."""
from __future__ import annotations

from hypothesis import strategies as st
from scipy.optimize import brentq
import numpy as np
import pytest


# (omega, sigma, zeta, period, guess, exponent, model, loses contact?)
ORACLE_CASES = [
    pytest.param(1.5, 0.2, 0.01, 1, (-0.16, 0.006), 1.5, "hertz", False, id="1T-contact"),
    pytest.param(0.8, 1.5, 0.01, 1, (-7.7, 0.17), 1.5, "hertz", True, id="1T-long-flight"),
    pytest.param(1.9, 0.5, 0.01, 2, (-0.09, 1.5), 1.5, "hertz", True, id="2T-contact-loss"),
    pytest.param(1.9, 0.5, 0.01, 2, (0.19, 1.42), 10 / 9, "hertz", True, id="2T-n10/9"),
    pytest.param(0.5, 0.8, 0.05, 1, (0.7, 0.0), 1.0, "hertz", True, id="1T-n1-impacts"),
    pytest.param(1.9, 0.5, 0.01, 2, (-1.0, 0.5), 1.5, "taylor", True, id="2T-taylor"),
]


EXTREME = [
    (0.05, 0.5, 0.01, 1, 1.5), (10.0, 0.5, 0.01, 1, 1.5), (1.0, 10.0, 0.01, 1, 1.5),
    (0.3, 10.0, 0.01, 1, 1.5), (1.9, 0.5, 1e-4, 2, 1.5), (1.0, 0.5, 10.0, 1, 1.5),
    (0.05, 5.0, 10.0, 1, 1.5), (1.9, 0.5, 0.01, 2, 1.0), (0.8, 2.0, 0.01, 1, 10 / 9),
    (2.0, 0.5, 0.0, 2, 1.5), (1.0, 1.0, 0.01, 1, 1.5), (3.0, 9.0, 0.001, 2, 1.5),
]


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


ZETAS = st.floats(1e-4, 0.02)


# ---------------------------------------------------------------------------------------------
# scipy oracle for Eq. 11 (Taylor model): 1T/2T orbits by Newton shooting with the monodromy
# ---------------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------------
# the reconstructed response (Eq. 19)
# ---------------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------------
# against the project's kernels (skipped until kernels.shoot exists)
# ---------------------------------------------------------------------------------------------


def test_taylor_contact_loss_root_eq12():
    r = brentq(lambda q: 1 + q + q**2 / 6 - q**3 / 54, -2, -1)
    assert round(r, 3) == -1.348
