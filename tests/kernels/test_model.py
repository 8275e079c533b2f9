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
from hertzmap.kernels.model import (FIXED_LOSS_LEVEL, LAWS, MODELS, TAYLOR, TAYLOR_CONTACT_LOSS,
                                    contact_side_force, contact_side_force_and_stiffness,
                                    rhs_force, rhs_force_and_stiffness, switch_level)
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


@pytest.mark.parametrize("law", LAWS, ids=lambda law: law.name)
def test_the_kernels_switching_level_is_the_declared_loss_level(law):
    """switch_level, the level the integrator switches at, is the law's declared loss level
    (LAWS), to the bit; the Hertz law's is -n exactly (so the integrator's q - level is q + n
    bit for bit); a law whose level does not depend on n has it in FIXED_LOSS_LEVEL."""
    for n in (1.0, 10 / 9, 1.5, 2.3, 0.37, 7.0):
        assert switch_level(n, law.code) == law.loss_level(n)
        if law.name == "hertz":
            assert switch_level(n, law.code) == -n
    if law.loss_slope == 0.0:
        assert FIXED_LOSS_LEVEL[law.code] == law.loss_offset == law.loss_level(None)
    else:
        assert FIXED_LOSS_LEVEL[law.code] != FIXED_LOSS_LEVEL[law.code]     # NaN


def _integrate(y0, t1, omega, sigma, zeta, n, model):
    """Integrate (q, q') from t = 0 to t1 with the orbit measures; returns (status, y, stats)."""
    from hertzmap.kernels.integrate import N_HARMONICS, N_STATS, integrate

    y = np.array(y0, dtype=float)
    stats = np.zeros(N_STATS)
    code = integrate(y, 0.0, t1, omega, sigma, zeta, n, model, 1e-10, 1e-10, 0.1, 100_000,
                     False, True, False, 1.0, np.zeros((3, N_HARMONICS + 1)), np.empty(0),
                     np.empty((3, 0)), stats, np.empty(2), np.empty(2), np.empty(2),
                     np.empty((16, 2)), np.empty((7, 2)))
    return code, y, stats


@pytest.mark.parametrize("law", [law for law in LAWS if law.switches], ids=lambda law: law.name)
@pytest.mark.parametrize("n", [1.0, 1.5, 10 / 9])
def test_the_integrator_switches_at_the_declared_loss_level(law, n):
    """Contact is lost and regained where the law's declaration puts it: the flight the
    integrator runs after a loss of contact, taken back in closed form by the flight time the
    measures record, starts on law.loss_level(n), and a flight from below the level ends on it
    (both to 1e-14), whichever way the integrator approaches the loss (n = 1 in t-steps, the
    other exponents in w or in x = -sqrt(q - level))."""
    from hertzmap.kernels import status
    from hertzmap.kernels.flight import flight_state
    from hertzmap.kernels.integrate import S_EVENTS, S_FLIGHT_TIME

    level = law.loss_level(n)
    omega, sigma, zeta = 0.8, 1.5, 0.01
    # from the static point, the force 1 + 1.5 cos(0.8 t) < 0 pulls the contact open: the first
    # span end after the loss of contact, in flight
    for t1 in np.arange(0.05, 8.0, 0.05):
        code, y, stats = _integrate((0.0, 0.0), t1, omega, sigma, zeta, n, law.code)
        assert code == status.CONVERGED
        if stats[S_EVENTS] > 0:
            break
    assert stats[S_EVENTS] == 1 and y[0] < level, "no loss of contact"
    s = stats[S_FLIGHT_TIME]
    assert 0.0 < s <= 0.05 + 1e-12
    q_loss, v_loss, _, _ = flight_state(y[0], y[1], t1, -s, omega, sigma, zeta)
    assert abs(q_loss - level) <= 1e-14, (q_loss, level)
    assert v_loss < 0.0

    # a flight from below the level, going up: recontact is on the level (the first span end
    # after it, before the contact can open again)
    q0, v0 = level - 0.3, 0.4
    for t1 in np.arange(0.05, 3.0, 0.05):
        code, y, stats = _integrate((q0, v0), t1, omega, 0.2, zeta, n, law.code)
        assert code == status.CONVERGED
        if stats[S_EVENTS] > 0:
            break
    assert stats[S_EVENTS] == 1 and y[0] >= level, "no recontact"
    s = stats[S_FLIGHT_TIME]
    assert t1 - 0.05 - 1e-12 <= s < t1
    q_r, v_r, _, _ = flight_state(q0, v0, 0.0, s, omega, 0.2, zeta)
    assert abs(q_r - level) <= 1e-14, (q_r, level)
    assert v_r > 0.0


def test_the_model_value_reads_options_and_attrs_with_the_declared_defaults():
    """kernels.model.Model: the defaults are the declared ones, an options dict or a store's
    attrs fill what they hold (a law without an exponent stores "none" there), and a bad law
    or exponent is refused by name."""
    from hertzmap.kernels.model import (DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL, Model,
                                        contact_loss_level)

    assert Model() == Model.of({}) == Model(DEFAULT_LAW, DEFAULT_EXPONENT, DEFAULT_RTOL)
    m = Model.of({"model": "hertz", "exponent": 1.0, "rtol": 1e-9, "harmonics": False})
    assert (m.law, m.exponent, m.rtol, m.code) == ("hertz", 1.0, 1e-9, MODELS["hertz"])
    assert m.loss_level == -1.0 == contact_loss_level("hertz", 1.0)
    taylor = Model.of({"model": "taylor", "exponent": "none", "rtol": "1e-8"})
    assert (taylor.exponent, taylor.rtol) == (DEFAULT_EXPONENT, 1e-8)
    assert taylor.loss_level == TAYLOR_CONTACT_LOSS
    with pytest.raises(ValueError, match="model must be one of"):
        Model("hertzian")
    with pytest.raises(ValueError, match="exponent must be a finite number > 0"):
        Model(exponent=-1.0)
