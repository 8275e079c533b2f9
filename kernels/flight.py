"""Closed-form flight phase (loss of contact, paper Eq. 7 second line).

In flight F(q) = 0 and the equation q'' + 2 zeta q' = 1 + sigma cos(omega tau) is linear with
constant coefficients. With a = 2 zeta, s = tau - tau0 and E = exp(-a s):

    v(s) = E v0 + phi1(s) + sigma [P(tau0 + s) - E P(tau0)]
    q(s) = q0 + phi1(s) v0 + phi2(s) + sigma [Q(tau0 + s) - Q(tau0) - P(tau0) phi1(s)]

    phi1 = (1 - E)/a,  phi2 = (s - phi1)/a,
    P(t) = (a cos wt + w sin wt)/(a^2 + w^2)   (P' + a P = cos wt),  Q = integral of P.

The flow Jacobian of the flight is [[1, phi1], [0, E]] (used for the exact monodromy).
Recontact is the first upward crossing of the contact law's loss level (kernels.model.LAWS,
``switch_level``: q = -n for the Hertz law), found by scanning the flight in short intervals,
splitting each at the extremum of q (root of v) and refining with safeguarded Newton.
"""
from math import cos, expm1, pi, sin

from numba import float64, int64
from numba.types import UniTuple

from hertzmap.kernels._jit import kernel

_SCAN_PER_PERIOD = 32.0   # scan intervals per forcing period: v has at most one root in each


@kernel(UniTuple(float64, 2)(float64, float64))
def _phi12(a, s):
    x = a * s
    if x < 0.05:
        # series: phi1 = s (1 - x/2 + x^2/6 - ...), phi2 = s^2 (1/2 - x/6 + x^2/24 - ...)
        phi1 = s * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0
                    - x * (1.0 / 720.0 - x / 5040.0))))))
        phi2 = s * s * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0
                        - x * (1.0 / 720.0 - x * (1.0 / 5040.0 - x / 40320.0))))))
        return phi1, phi2
    phi1 = -expm1(-x) / a
    return phi1, (s - phi1) / a


@kernel(UniTuple(float64, 3)(float64, float64))
def _phi12E(a, s):
    """phi1, phi2 and E = exp(-a s) = 1 - a phi1 (one expm1, no exp)."""
    phi1, phi2 = _phi12(a, s)
    return phi1, phi2, 1.0 - a * phi1


@kernel(UniTuple(float64, 2)(float64, float64, float64, float64, float64, float64, float64,
                           float64, float64, float64, float64, float64))
def _state(q0, v0, a, omega, sigma, d, c0, s0, P0, s, c1, s1):
    """(q, v) after a flight of duration s, given the flight's constants (a = 2 zeta,
    d = a^2 + omega^2, c0, s0 = cos, sin omega t0, P0 = P(t0)) and c1, s1 = cos, sin
    omega (t0 + s)."""
    phi1, phi2, E = _phi12E(a, s)
    P1 = (a * c1 + omega * s1) / d
    dQ = (a * (s1 - s0) - omega * (c1 - c0)) / (omega * d)
    return (q0 + phi1 * v0 + phi2 + sigma * (dQ - P0 * phi1),
            E * v0 + phi1 + sigma * (P1 - E * P0))


@kernel(UniTuple(float64, 4)(float64, float64, float64, float64, float64, float64, float64))
def flight_state(q0, v0, t0, s, omega, sigma, zeta):
    """State after a flight of duration s from (q0, v0) at time t0: (q, v, phi1, E)."""
    a = 2.0 * zeta
    d = a * a + omega * omega
    c0 = cos(omega * t0)
    s0 = sin(omega * t0)
    P0 = (a * c0 + omega * s0) / d
    t1 = t0 + s
    q, v = _state(q0, v0, a, omega, sigma, d, c0, s0, P0, s, cos(omega * t1), sin(omega * t1))
    phi1, _, E = _phi12E(a, s)
    return q, v, phi1, E


@kernel(float64(float64, float64, float64, float64, float64, float64, float64, float64, int64,
              int64))
def _root(q0, v0, t0, lo, hi, omega, sigma, zeta, which, negative_at_lo):
    """Root in [lo, hi] of v(s) (which = 1) or of q(s) (which = 0; the caller shifts q0 so that
    the contact surface is at 0).

    The sign at ``lo`` is given (the surface itself counts as just below it). Safeguarded
    Newton: dq/ds = v, dv/ds = the acceleration. 60 iterations bound the work.
    """
    a = 2.0 * zeta
    d = a * a + omega * omega
    c0 = cos(omega * t0)
    s0 = sin(omega * t0)
    P0 = (a * c0 + omega * s0) / d
    lo_negative = negative_at_lo == 1
    s = 0.5 * (lo + hi)
    for _ in range(60):
        c1 = cos(omega * (t0 + s))
        q, v = _state(q0, v0, a, omega, sigma, d, c0, s0, P0, s, c1, sin(omega * (t0 + s)))
        if which == 1:
            g = v
            dg = 1.0 + sigma * c1 - a * v
        else:
            g = q
            dg = v
        if g == 0.0:
            return s
        if (g < 0.0) == lo_negative:
            lo = s
        else:
            hi = s
        if hi - lo <= 4e-16 * max(1.0, abs(hi)):
            return 0.5 * (lo + hi) if g != 0.0 else s
        s_new = s - g / dg if dg != 0.0 else 0.5 * (lo + hi)
        if not (lo < s_new < hi):
            s_new = 0.5 * (lo + hi)
        if abs(s_new - s) <= 2e-16 * max(1.0, abs(s)):
            return s_new
        s = s_new
    return s


@kernel(UniTuple(float64, 3)(float64, float64, float64, float64, float64, float64, float64, float64))
def flight_until_recontact(q0, v0, t0, s_max, omega, sigma, zeta, level):
    """First upward crossing of q = level after t0, searched in (0, s_max]: ``level`` is the
    contact law's loss level (kernels.model.switch_level; -n for the Hertz law).

    Returns (s, min_q, found): s = duration of the flight (s_max if no recontact), min_q = lowest
    q reached in the flight (for the orbit measures), found = 1.0 if recontact happens.
    Starting exactly on q = level with v0 < 0 (just lost contact) is the usual case.
    The scan points are equally spaced: cos and sin of omega t there advance by one rotation
    (no trig per point; re-anchored every 8 points, the drift stays at round-off), and only the
    roots are refined on the exact closed form.
    """
    period = 2.0 * pi / omega
    ds = period / _SCAN_PER_PERIOD
    a = 2.0 * zeta
    d = a * a + omega * omega
    c0 = cos(omega * t0)
    s0 = sin(omega * t0)
    P0 = (a * c0 + omega * s0) / d
    cd = cos(omega * ds)
    sd = sin(omega * ds)
    ck = c0
    sk = s0
    # q0 is shifted so that the contact surface is at 0: g = q - level (q + n for Hertz)
    g0 = q0 - level
    qmin = q0
    s_lo = 0.0
    g_lo = g0 if g0 < 0.0 else -1e-300   # starting on the surface counts as just below it
    v_lo = v0
    nseg = int(s_max / ds) + 1
    for k in range(nseg):
        if (k + 1) % 8 == 0:
            ck = cos(omega * (t0 + (k + 1) * ds))
            sk = sin(omega * (t0 + (k + 1) * ds))
        else:
            ck, sk = ck * cd - sk * sd, sk * cd + ck * sd
        s_hi = (k + 1) * ds
        if s_hi >= s_max:
            s_hi = s_max
            ck = cos(omega * (t0 + s_max))
            sk = sin(omega * (t0 + s_max))
        if s_hi <= s_lo:
            break
        g_hi, v_hi = _state(g0, v0, a, omega, sigma, d, c0, s0, P0, s_hi, ck, sk)
        left = s_lo
        g_left = g_lo
        if (v_lo < 0.0) and (v_hi > 0.0):
            # minimum of q inside: the crossing (if any) lies after it
            sm = _root(g0, v0, t0, s_lo, s_hi, omega, sigma, zeta, 1, 1)
            gm, _, _, _ = flight_state(g0, v0, t0, sm, omega, sigma, zeta)
            if gm + level < qmin:
                qmin = gm + level
            left = sm
            g_left = gm
        elif (v_lo > 0.0) and (v_hi < 0.0):
            # maximum of q inside: a crossing before it is the first one
            sm = _root(g0, v0, t0, s_lo, s_hi, omega, sigma, zeta, 1, 0)
            gm, _, _, _ = flight_state(g0, v0, t0, sm, omega, sigma, zeta)
            if g_lo < 0.0 and gm >= 0.0:
                s = _root(g0, v0, t0, s_lo, sm, omega, sigma, zeta, 0, 1)
                return s, qmin, 1.0
            left = sm
            g_left = gm
        if g_left < 0.0 and g_hi >= 0.0:
            s = _root(g0, v0, t0, left, s_hi, omega, sigma, zeta, 0, 1)
            return s, qmin, 1.0
        if g_hi + level < qmin:
            qmin = g_hi + level
        s_lo = s_hi
        g_lo = g_hi
        v_lo = v_hi
    return s_max, qmin, 0.0
