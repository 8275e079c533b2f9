"""kernels.attractors (issue 21) against independent oracles: scipy's Benettin and period-m
shooting with the variational equations, its finite-difference monodromy, its dense
trajectories (tests/oracle.py: shares no code with kernels/), and synthetic stroboscopic
sequences whose period is known by construction.

The examples (paper Eq. 7, n = 1.5, zeta = 0.01) come from benchmarks/archive/attractor_scan.py:
* (omega, sigma) = (0.5, 2.5): a chaotic attractor (q down to -268, 90 % of the time in flight);
  8 initial states over 70,000 periods each never settle, exponents 0.0439-0.0447 per unit tau
  (``attractor_scan.py chaos 0.5 2.5 --states 8 --transient 50000 --budgets 20000``).
* (2.0, 1.0): a stable 3T orbit (from x0 = (2, 2); a 2T orbit attracts (0, 0)) (``grid``).
* sigma = 2.5: the 2T orbit flips near omega = 1.907 (2T stable above, a stable 4T below)
  (``grid``, then ``flip 1.95 1.88 2.5 --steps 15``).
* (1.0, 2.0): the issue's point: a chaotic transient of thousands of periods, then a 2T orbit.
"""
from __future__ import annotations

from math import log, pi

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels import attractor, attractor_batch, lyapunov, shoot, status
from hertzmap.kernels.attractors import (M_MAX, MAX_REFINEMENTS, RING, detect_period,
                                detect_period_in)

ZETA = 0.01


# ---- period detection on sequences of known period --------------------------------------

def _ring(points):
    ring = np.zeros((RING, 2))
    for j, p in enumerate(points):
        ring[j % RING] = p
    return ring, len(points)


def _cycle(m, count, rng, noise=0.0):
    base = rng.uniform(-5.0, 5.0, (m, 2))
    pts = np.array([base[j % m] for j in range(count)])
    return pts + noise * rng.standard_normal(pts.shape)


@pytest.mark.parametrize("m", [1, 2, 3, 4, 6, 9, 12, 16])
def test_detects_the_smallest_period(m):
    rng = np.random.default_rng(m)
    pts = _cycle(m, 200, rng, noise=1e-9)
    got, res = detect_period(*_ring(pts), M_MAX, 1e-6, 3)
    assert got == m and res <= 1e-6
    # the chronological form (as the kernel returns the strobe points)
    assert detect_period_in(np.ascontiguousarray(pts), len(pts), M_MAX, 1e-6, 3) == m


def test_no_period_in_noise_or_beyond_tolerance():
    rng = np.random.default_rng(0)
    assert detect_period(*_ring(rng.uniform(-5, 5, (200, 2))), M_MAX, 1e-6, 3)[0] == 0
    # a 3-cycle blurred above the tolerance (relative to 1 + |x|) is not a cycle
    pts = _cycle(3, 200, rng, noise=1e-4)
    assert detect_period(*_ring(pts), M_MAX, 1e-6, 3)[0] == 0
    assert detect_period(*_ring(pts), M_MAX, 1e-2, 3)[0] == 3
    # a period longer than M_MAX is not reported
    assert detect_period(*_ring(_cycle(17, 200, rng)), M_MAX, 1e-6, 3)[0] == 0


def test_needs_the_stated_number_of_returns():
    rng = np.random.default_rng(1)
    chaos = rng.uniform(-5, 5, (100, 2))
    cyc = _cycle(4, 4 * 3 + 4, rng)            # (repeats + 1) m points: just enough
    assert detect_period(*_ring(np.vstack([chaos, cyc])), M_MAX, 1e-6, 3)[0] == 4
    assert detect_period(*_ring(np.vstack([chaos, cyc[1:]])), M_MAX, 1e-6, 3)[0] == 0


# ---- a chaotic attractor ------------------------------------------------------------------

def test_chaotic_exponent_matches_scipy_benettin():
    """Chaos makes trajectories diverge, so the exponents of two different trajectories on the
    attractor are compared (kernels: 20,000 periods after 500; scipy: 800 after 50, its
    integrator and event handling its own), within three combined standard errors (each the
    standard error of the mean over 8 blocks; on this attractor the scatter of 30 windows of
    1,500 periods, 0.0011, matches the stated 0.0014). The oracle's steps are capped at 0.1:
    with free steps, short contact excursions fall between its sign tests, and its exponent
    came out 1.5-2 standard errors high here and at (1.0, 1.5) (there 0.0582 +- 0.0024 from 4
    windows, 0.0536 +- 0.0010 capped, kernels 0.0539 +- 0.0006). The exponent must also be
    positive beyond ten of its standard errors, and the same from a second initial state."""
    omega, sigma = 0.5, 2.5
    a = attractor(omega, sigma, ZETA, (0.0, 0.0), transient_periods=500, record_periods=20_000)
    assert a.status == status.UNSETTLED and a.period == 0
    assert a.lyapunov > 10 * a.lyapunov_error > 0
    assert a.lyapunov_halves < 5 * a.lyapunov_error * np.sqrt(8)
    assert a["liouville_error"] < 1e-6      # det M_k = exp(-2 zeta T) every period
    # both exponents' sum over the window: -2 zeta exactly (Liouville), here to the integration
    assert 0 <= a.lyapunov_sum_error < 1e-8 * ZETA, a.lyapunov_sum_error
    b = attractor(omega, sigma, ZETA, (-3.0, 0.0), transient_periods=500, record_periods=20_000)
    assert abs(a.lyapunov - b.lyapunov) <= 3 * np.hypot(a.lyapunov_error, b.lyapunov_error)
    lam, err, _ = oracle.lyapunov_benettin((0.0, 0.0), omega, sigma, ZETA, 800, discard=50,
                                           max_step=0.1)
    assert lam > 5 * err
    assert abs(a.lyapunov - lam) <= 3 * np.hypot(a.lyapunov_error, err), (a.lyapunov, lam, err)
    # the measures of a long flight regime (q far below the contact surface)
    assert a.min_q < -200 and 0.85 < a.flight_fraction < 0.95
    assert a.peak_force > a.rms_force > a.mean_force > 0.9
    assert a.force_quadrature_error < 1e-4
    assert a.strobe.shape == (20_000, 2)


def _flight_time(switches, x0, P, n=1.5):
    """Time spent below q = -n over [0, P] from the located switches (t, v, +1 recontact /
    -1 loss of contact)."""
    in_flight = x0[0] < -n
    t_prev = 0.0
    total = 0.0
    for t, _, kind in switches:
        if in_flight:
            total += t - t_prev
        in_flight = kind < 0
        t_prev = t
    return total + (P - t_prev if in_flight else 0.0)


# ---- a stable period-3 orbit ---------------------------------------------------------------

@pytest.fixture(scope="module")
def period3():
    return attractor(2.0, 1.0, ZETA, (2.0, 2.0), transient_periods=3000, record_periods=400)


def test_period3_orbit_matches_scipy_shooting(period3):
    a = period3
    assert a.status == status.CONVERGED and a.period == 3, a.status_name
    assert a["orbit_period"] == 3 and a["refinements"] >= 1
    o = a.orbit
    assert o.converged and o.stable and o.minimal_period == 3
    # scipy's Newton with its own variational equations, from 1e-3 away
    x_ref, M_ref = oracle.shoot_period(o.x0 + 1e-3, 2.0, 1.0, ZETA, 3)
    np.testing.assert_allclose(o.x0, x_ref, rtol=0, atol=1e-8)
    mu_ref = np.sort_complex(np.linalg.eigvals(M_ref))
    np.testing.assert_allclose(np.sort_complex(o.multipliers), mu_ref, rtol=0, atol=1e-7)
    # the exponent of a periodic attractor: log |mu_max| / (3 T), from the oracle's multipliers
    T = 2 * pi / 2.0
    assert abs(a.lyapunov - log(np.abs(mu_ref).max()) / (3 * T)) < 1e-8
    # the transient's last points: a 3-cycle, not a 1-cycle
    s = a.strobe
    assert np.abs(s[-3:] - s[-6:-3]).max() < 1e-3
    assert np.abs(s[-1] - s[-2]).max() > 0.1


def test_period3_measures_match_scipy_trajectory(period3):
    """Window measures of the 3T orbit against scipy's trajectory over 3 T: extrema and rms
    from 30,000 uniform samples of its dense output, flight time and impact velocity from its
    located switches."""
    a = period3
    omega, sigma = 2.0, 1.0
    P = 3 * 2 * pi / omega
    t = np.linspace(0.0, P, 30_000, endpoint=False)
    q, v, sw = oracle.trajectory(a.orbit.x0, 0.0, P, t, omega, sigma, ZETA)
    F = np.where(q > -1.5, np.maximum(1 + q / 1.5, 0.0) ** 1.5, 0.0)
    np.testing.assert_allclose(a.rms_force, np.sqrt(np.mean(F ** 2)), rtol=1e-5)
    np.testing.assert_allclose(a.mean_force, 1.0, atol=1e-5)   # a periodic orbit: <F> = 1
    # extrema: the samples are within q'' (P / 30000)^2 / 2 < 1e-6 of them
    np.testing.assert_allclose(a.min_q, q.min(), atol=2e-6)
    np.testing.assert_allclose(a.max_q, q.max(), atol=2e-6)
    np.testing.assert_allclose(a.peak_force, F.max(), rtol=1e-5)
    assert len(sw) >= 2
    np.testing.assert_allclose(a.flight_fraction, _flight_time(sw, a.orbit.x0, P) / P,
                               atol=1e-9)
    np.testing.assert_allclose(a.max_impact_velocity, sw[sw[:, 2] == 1.0, 1].max(), atol=1e-8)


# ---- the flip of a 2T orbit, and the exponent of a stable one ---------------------------

SIGMA_FLIP = 2.5


def _flip_test(M):
    return 1.0 + np.trace(M) + np.linalg.det(M)


@pytest.fixture(scope="module")
def orbit_2t():
    a = attractor(1.92, SIGMA_FLIP, ZETA, (0.0, 0.0), transient_periods=3000,
                  record_periods=400)
    assert a.status == status.CONVERGED and a.period == 2, a.status_name
    return a.orbit.x0


def test_2t_flip_where_the_scipy_monodromy_says(orbit_2t):
    """The 2T orbit's test function 1 + tr M + det M, located by bisection on the kernels'
    monodromy, changes sign where the oracle's (its own variational equations at its own fixed
    point) does: its signs 1e-4 on either side of the located flip."""
    x = orbit_2t
    lo, hi = 1.9065, 1.9075
    x_hi = shoot(hi, SIGMA_FLIP, ZETA, 2, guess=x, rtol=1e-12)
    x_lo = shoot(lo, SIGMA_FLIP, ZETA, 2, guess=x_hi.x0, rtol=1e-12)
    assert _flip_test(x_hi.monodromy) > 0 > _flip_test(x_lo.monodromy)
    guess = x_hi.x0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        o = shoot(mid, SIGMA_FLIP, ZETA, 2, guess=guess, rtol=1e-12)
        assert o.converged and o.minimal_period == 2
        if _flip_test(o.monodromy) > 0:
            hi, guess = mid, o.x0
        else:
            lo = mid
    flip = 0.5 * (lo + hi)
    for d, sign in ((+1e-4, +1.0), (-1e-4, -1.0)):
        w = flip + d
        o = shoot(w, SIGMA_FLIP, ZETA, 2, guess=guess, rtol=1e-12)
        # the oracle's own orbit: Newton (hybr) with its exact Jacobian from 1e-4 away, checked
        # by its residual (scipy's finite-difference hybr stalled here short of its xtol)
        x_ref, _, _ = oracle.shoot(o.x0 + 1e-4, w, SIGMA_FLIP, ZETA, 2, rtol=1e-12)
        # the oracle's monodromy: its own variational equations integrated by scipy at its own
        # fixed point (finite differences of its period map carry errors up to ~3e-4 here, on
        # an orbit that spends 41 % of its period in flight)
        _, M_ref = oracle.variational_flow(x_ref, 0.0, 2 * 2 * pi / w, w, SIGMA_FLIP, ZETA,
                                           rtol=1e-12, atol=1e-12, max_step=0.05)
        g_ref = _flip_test(M_ref)
        assert np.sign(g_ref) == sign, (w, g_ref)
        # |g| is 2.7e-3 here; the two monodromies agree to the integrations' accuracy
        assert abs(_flip_test(o.monodromy) - g_ref) < 1e-7
        mu = np.sort(np.linalg.eigvals(M_ref).real)
        assert (mu[0] < -1.0) == (sign < 0)   # a real multiplier crosses -1


def test_4t_attractor_beyond_the_flip():
    """Below the flip the census finds a stable 4T orbit; the 2T orbit there is unstable with
    a multiplier below -1 (checked on the oracle's monodromy)."""
    a = attractor(1.90, SIGMA_FLIP, ZETA, (0.0, 0.0), transient_periods=3000, record_periods=400)
    assert a.status == status.CONVERGED and a.period == 4
    assert a.orbit.stable and a.orbit.minimal_period == 4
    o2 = shoot(1.90, SIGMA_FLIP, ZETA, 2, guess=a.orbit.x0, rtol=1e-12)
    assert o2.converged and o2.minimal_period == 2
    _, M_ref, _ = oracle.shoot(o2.x0 + 1e-4, 1.90, SIGMA_FLIP, ZETA, 2, rtol=1e-12)
    assert np.linalg.eigvals(M_ref).real.min() < -1.0


def test_stable_orbit_exponent_is_log_mu_over_period(orbit_2t):
    """Benettin on a stable orbit converges to log |mu_max| / P. At omega = 1.90705 the 2T
    orbit's multipliers are real (-0.98, -0.89; just above the flip), so the exponent
    (-0.0027) differs from the -zeta = -0.01 that any complex pair gives."""
    w = 1.90705
    o = shoot(w, SIGMA_FLIP, ZETA, 2, guess=orbit_2t, rtol=1e-12)
    assert o.converged and o.stable
    _, M_ref = oracle.shoot_period(o.x0 + 1e-3, w, SIGMA_FLIP, ZETA, 2)
    mu = np.linalg.eigvals(M_ref)
    assert np.all(np.abs(mu.imag) == 0) and abs(np.log(np.abs(mu).max()) - log(0.98)) < 0.01
    expected = log(np.abs(mu).max()) / (2 * 2 * pi / w)
    r = lyapunov(w, SIGMA_FLIP, ZETA, o.x0, periods=2000, discard=200, rtol=1e-10)
    assert r["status"] == status.CONVERGED
    # the tangent vector aligns at |mu2 / mu1|^(k/2) = 0.95^(k/2): after 200 periods the bias
    # is below 1e-8; what is left is the orbit's own error (rtol 1e-10)
    assert abs(r["lyapunov"] - expected) < 1e-6, (r["lyapunov"], expected)
    assert abs(expected + ZETA) > 5e-3


# ---- the long transient, and the budget -----------------------------------------

def test_long_chaotic_transient_is_unsettled_not_chaotic():
    """At (1.0, 2.0, 0.01) the only attractor is a stable 2T orbit with long flights, reached
    after a chaotic transient of thousands of periods. A short budget must say "unsettled"
    (whatever the window's exponent), a long one must find the 2T orbit and stop early."""
    short = attractor(1.0, 2.0, ZETA, (0.0, 0.0), transient_periods=600, record_periods=200)
    assert short.status == status.UNSETTLED and short.period == 0
    assert short.periods_run == 800
    assert short.lyapunov > 0          # the window was chaotic: still only "unsettled"
    long = attractor(1.0, 2.0, ZETA, (0.0, 0.0), transient_periods=20_000,
                     record_periods=200)
    assert long.status == status.CONVERGED and long.period == 2
    assert 1000 < long.periods_run < 20_200
    assert long.orbit.stable and long.orbit.minimal_period == 2
    assert long.flight_fraction > 0.3 and long.min_q < -9
    x_ref, _, _ = oracle.shoot(long.orbit.x0 + 1e-3, 1.0, 2.0, ZETA, 2, rtol=1e-12)
    np.testing.assert_allclose(long.orbit.x0, x_ref, rtol=0, atol=1e-8)


def test_step_budget_gives_a_status():
    a = attractor(0.5, 2.5, ZETA, (0.0, 0.0), transient_periods=100, record_periods=10,
                  max_steps=3)
    assert a.status == status.STEP_LIMIT
    assert a.periods_run <= 1


def test_repeating_points_that_shooting_cannot_confirm():
    """The 3T orbit's points repeat, but a step budget that one period fits and three do not
    makes every refinement (a 3T shooting) fail: "unconfirmed", with the period seen, a
    bounded number of shooting attempts, and the budget's end."""
    a = attractor(2.0, 1.0, ZETA, (2.0, 2.0), transient_periods=1000, record_periods=100,
                  max_steps=25)
    assert a.status == status.UNCONFIRMED and a.period == 3
    assert a.orbit is not None and a.orbit.status == status.STEP_LIMIT
    assert 1 <= a["refinements"] <= MAX_REFINEMENTS + 1
    assert a.periods_run == 1100


def test_batch_equals_single_calls():
    x0 = np.array([(0.0, 0.0), (2.0, 2.0), (-1.0, 1.0)])
    b = attractor_batch(2.0, 1.0, ZETA, x0, transient_periods=600, record_periods=100)
    for i, x in enumerate(x0):
        a = attractor(2.0, 1.0, ZETA, tuple(x), transient_periods=600, record_periods=100)
        np.testing.assert_array_equal(np.array([b[f][i] for f in ("status", "period",
                                                                  "periods_run", "q_end")]),
                                      [a["status"], a["period"], a["periods_run"], a["q_end"]])
        n = a.strobe.shape[0]
        np.testing.assert_array_equal(b["strobe"][i, :n], a.strobe)
    assert set(b["period"]) == {2.0, 3.0}


@pytest.mark.parametrize("kwargs", [
    dict(omega=0.0), dict(sigma=-1.0), dict(zeta=float("nan")), dict(record_periods=0),
    dict(transient_periods=-1), dict(cycle_repeats=8), dict(cycle_tol=0.0), dict(rtol=1.0),
    dict(lyapunov_discard=500), dict(max_steps=0), dict(x0=(float("inf"), 0.0)),
])
def test_bad_input_is_a_value_error(kwargs):
    args = dict(omega=1.0, sigma=1.0, zeta=ZETA, x0=(0.0, 0.0), record_periods=500)
    args.update(kwargs)
    name = next(iter(kwargs))
    with pytest.raises(ValueError, match=name):
        attractor(args.pop("omega"), args.pop("sigma"), args.pop("zeta"), args.pop("x0"), **args)


# ---- recognition ----------------------------------------------------------------------------

def _recognising_run(omega, sigma, x0, points, label, tol, visits, own_label=None,
                     budget=3000):
    """One transient of the batch kernel with known points to recognise."""
    from hertzmap.kernels import attractors as att
    from hertzmap.kernels.api import _attractor_options
    from hertzmap.kernels.shooting import N_FIELDS
    opts, cap = _attractor_options(budget, 64, False, None, 0, 1e-6, 3, 1e-8, None, 1e-10,
                                   200_000, None)
    rows = np.empty((1, att.N_ATTRACTOR_FIELDS))
    orbits = np.empty((1, N_FIELDS))
    strobes = np.empty((1, cap, 2))
    known = att.known_attractors(points, label, tol, visits)
    att.attractor_batch_into(omega, sigma, ZETA, np.array([x0[0]], float),
                             np.array([x0[1]], float), 1.5, 0, *opts, False, *known,
                             att.NO_LABEL if own_label is None else own_label, rows, orbits,
                             strobes)
    return {name: rows[0, i] for i, name in enumerate(att.ATTRACTOR_FIELDS)}


def test_known_near_is_the_nearest_point_within_its_tolerance():
    """The cell grid's lookup against a brute-force search over every known point, with
    per-point tolerances, several labels and an excluded label."""
    from hertzmap.kernels.attractors import K_Q, K_TOL, K_V, known_attractors, known_near
    rng = np.random.default_rng(7)
    for n, spread in ((1, 1.0), (50, 3.0), (600, 40.0)):
        pts = rng.normal(0.0, spread, (n, 2))
        labels = rng.integers(-3, 3, n)
        tol = rng.uniform(0.01, 0.6, n)
        known, lab, start, grid = known_attractors(pts, labels, tol, 1.0)[:4]
        for _ in range(400):
            q, v = rng.normal(0.0, spread * 1.2, 2)
            own = int(rng.integers(-3, 4))
            d = np.hypot(known[:, K_Q] - q, known[:, K_V] - v)
            ok = (d <= known[:, K_TOL]) & (lab != own)
            expect = int(np.argmin(np.where(ok, d, np.inf))) if ok.any() else -1
            assert known_near(known, lab, start, grid, own, q, v) == expect
    # points that coincide (a zero tolerance, the smallest cell) and states far off the grid
    known, lab, start, grid = known_attractors([(1.0, 2.0)] * 3, 4, 0.0, 1.0)[:4]
    assert known_near(known, lab, start, grid, -1, 1.0, 2.0) >= 0
    for q, v in ((1.0 + 1e-9, 2.0), (1e300, -1e300), (np.nan, 0.0), (np.inf, 2.0)):
        assert known_near(known, lab, start, grid, -1, q, v) == -1


def test_a_transient_near_a_known_orbit_is_recognised_on_it():
    """(2.0, 1.0): from (2, 2) the transient settles on a stable 3T orbit (scipy's shooting
    confirms it). Told the orbit's three points, the same transient stops on them after the
    stated consecutive visits, labelled as told and there; not with its own label excluded,
    nor with points elsewhere."""
    plain = attractor(2.0, 1.0, ZETA, (2.0, 2.0), transient_periods=3000, record_periods=64,
                      lyapunov=False)
    assert plain.status == status.CONVERGED and plain.period == 3
    x_ref, _ = oracle.shoot_period(plain.orbit.x0, 2.0, 1.0, ZETA, 3)
    pts = [x_ref] + [oracle.period_map(x_ref, 2.0, 1.0, ZETA, j) for j in (1, 2)]
    tol = 1e-2 * (1 + np.hypot(*np.array(pts).T))
    row = _recognising_run(2.0, 1.0, (2.0, 2.0), pts, -1, tol, 12)
    assert row["status"] == status.RECOGNISED and row["recognised_as"] == -1
    assert row["periods_run"] < plain["periods_run"]
    last = np.array([row["q_end"], row["v_end"]])
    assert min(np.hypot(*(last - p)) for p in pts) <= tol.max()
    # its own label is never recognised; points elsewhere are not either
    assert _recognising_run(2.0, 1.0, (2.0, 2.0), pts, -1, tol, 12, own_label=-1)[
        "status"] == status.CONVERGED
    far = np.array(pts) + 5.0
    assert _recognising_run(2.0, 1.0, (2.0, 2.0), far, -1, tol, 12)[
        "status"] == status.CONVERGED
    # the visits are consecutive: more of them than the run has periods, never recognised
    assert _recognising_run(2.0, 1.0, (2.0, 2.0), pts, -1, tol, 10_000, budget=200)[
        "status"] != status.RECOGNISED
