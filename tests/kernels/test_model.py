"""kernels.model: the forcing by a shifted cosine against long double, the Taylor force (paper
Eq. 10) against the polynomial written here, and the Taylor model's contact-loss threshold
against the root of that polynomial (closed form and scipy's brentq) and the printed Eq. 12
(study.analytic.paper); every declared contact law against the oracle's independent twin."""
from __future__ import annotations

from math import sqrt

from scipy.optimize import brentq
import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels.model import (LAWS, MODELS, TAYLOR, TAYLOR_CONTACT_LOSS, contact_side_force,
                                    contact_side_force_and_stiffness, rhs_force,
                                    rhs_force_and_stiffness)
from hertzmap.study.analytic.paper import TAYLOR_CONTACT_LOSS_PRINTED


def test_cos_shifted_against_long_double():
    """The stages' excitation cos(phi0 + theta) from cos/sin(phi0): to round-off, against a
    long-double cosine of the exact sum (libm on the rounded sum errs by |phi0| eps)."""
    from math import cos, sin

    from hertzmap.kernels.model import cos_shifted

    rng = np.random.default_rng(0)
    phi = rng.uniform(-200.0, 200.0, 20000)
    theta = np.concatenate([rng.uniform(-1.0, 1.0, 10000), rng.uniform(-30.0, 30.0, 10000)])
    got = np.array([cos_shifted(cos(p), sin(p), p, t) for p, t in zip(phi, theta)])
    ref = np.cos(phi.astype(np.longdouble) + theta.astype(np.longdouble)).astype(float)
    small = np.abs(theta) <= 1.0
    assert np.abs(got - ref)[small].max() < 1e-15
    # beyond |theta| = 1 it falls back to libm on the rounded sum
    assert np.abs(got - ref)[~small].max() < 400 * np.finfo(float).eps


def taylor_force_eq10(q):
    """Paper Eq. 10, written here: the third-order Taylor expansion of (1 + 2q/3)^(3/2)."""
    return 1.0 + q + q * q / 6.0 - q ** 3 / 54.0


#: The root of Eq. 10 where the force first vanishes as q falls from the static point q = 0:
#: -54 F(q) = q^3 - 9 q^2 - 54 q - 54 = (q + 3)(q^2 - 12 q - 18), roots -3 and 6 -+ 3 sqrt(6);
#: F > 0 on (6 - 3 sqrt(6), 0], so this is the one.
TAYLOR_ROOT_CLOSED_FORM = 6.0 - 3.0 * sqrt(6.0)      # -1.3484692283...


def test_taylor_force_is_eq10():
    q = np.linspace(-3.0, 3.0, 61)
    got = np.array([rhs_force(x, 1.5, TAYLOR) for x in q])
    np.testing.assert_allclose(got, taylor_force_eq10(q), rtol=1e-15, atol=1e-15)


def test_taylor_force_root_closed_form():
    """The closed form above against scipy's brentq on the polynomial and on the kernel's force."""
    assert brentq(taylor_force_eq10, -2.0, -1.0, xtol=1e-15) == pytest.approx(
        TAYLOR_ROOT_CLOSED_FORM, abs=1e-14)
    assert brentq(lambda q: rhs_force(q, 1.5, TAYLOR), -2.0, -1.0, xtol=1e-15) == pytest.approx(
        TAYLOR_ROOT_CLOSED_FORM, abs=1e-14)


def test_taylor_contact_loss_rounds_to_the_printed_value():
    # paper Eq. 12 prints q >= -1.348 (four digits)
    assert round(TAYLOR_CONTACT_LOSS, 3) == TAYLOR_CONTACT_LOSS_PRINTED
    assert round(TAYLOR_ROOT_CLOSED_FORM, 3) == TAYLOR_CONTACT_LOSS_PRINTED


def test_taylor_contact_loss_is_the_root_of_the_taylor_force():
    """The threshold kernels.model documents as "the Taylor force ... vanishes at this q"."""
    assert TAYLOR_CONTACT_LOSS == pytest.approx(TAYLOR_ROOT_CLOSED_FORM, abs=1e-14)
    assert abs(rhs_force(TAYLOR_CONTACT_LOSS, 1.5, TAYLOR)) < 1e-14


@pytest.mark.parametrize("law", LAWS, ids=lambda law: law.name)
@pytest.mark.parametrize("n", [1.0, 10 / 9, 1.5, 2.3])
def test_every_law_matches_the_oracles_own(law, n):
    """Every declared contact law: force, stiffness and the force seen by the integrator's
    contact steps (its continuous extension) against benchmarks/oracle.py's independent twin
    of the same name, in contact and (for a law with a switching surface) in flight; and the
    declared loss level is where the oracle's force vanishes."""
    assert law.name in oracle.LAWS, f"no oracle force for the law {law.name!r}"
    level = law.loss_level(n)
    for q in np.linspace(level + 1e-3, 4.0, 37):
        f, k = oracle.force(q, n, law.name), oracle.stiffness(q, n, law.name)
        assert rhs_force(q, n, law.code) == pytest.approx(f, rel=1e-13, abs=1e-15)
        assert rhs_force_and_stiffness(q, n, law.code) == pytest.approx((f, k), rel=1e-13,
                                                                        abs=1e-15)
        assert contact_side_force(q, n, law.code) == pytest.approx(f, rel=1e-13, abs=1e-15)
        assert contact_side_force_and_stiffness(q, n, law.code) == pytest.approx(
            (f, k), rel=1e-13, abs=1e-15)
    assert abs(oracle.force(level, n, law.name)) < 1e-12
    if law.switches:
        for q in (level - 1e-9, level - 0.5, level - 7.0):
            assert rhs_force(q, n, law.code) == 0.0 == oracle.force(q, n, law.name)
    assert MODELS[law.name] == law.code
