"""Event-driven integration of paper Eq. 7 with exact contact loss and recontact.

The switching surface is the contact law's loss level, q = level = switch_level(n, model) as
the law declares it (kernels.model.LAWS): q = -n for the Hertz law, the only law with one
(``switches``). Below, "q = -n" and "q + n" stand for q = level and q - level.

In contact: adaptive DOP853 (kernels/_dop853.py), with the variational equations when a
monodromy matrix is wanted. When a trial step ends below q = -n, or q' changes sign inside an
accepted step that comes close to q = -n (a grazing dip the step ends cannot see), the crossing
time is located by bracketed Newton on partial steps from the step start (each lies in contact
up to the root, so it is as accurate as a step) to |q + n| < 1e-14.
In flight: the closed form of kernels/flight.py up to the exact recontact.

Next to a switch, F'(q) = (1 + q/n)^(n-1) ~ |t - t_switch|^(n-1) is singular, so the solution
is not smooth in t there and t-steps could only grow geometrically away from it. Instead the
integrator steps in w with t = t_switch + sgn w^2, in which the solution is smooth: after a
recontact (sgn = +1, w from 0 up to W_EXIT) and onto a located loss of contact (sgn = -1, w
from -sqrt(t_stop - t) up to 0, landing exactly on the switch). The error control covers the
state and the variational matrix in every mode.
Heading down to a loss of contact, t-steps shrink towards the singular point (each about half
the time left). Once the local parabola puts the surface within HEIGHT_TRIGGER t-steps, with a
landing speed within a factor 2 of the current one (no turn before the surface), the approach
steps in x = -sqrt(q + n) instead, with tau = t - t_ref in place of q and dt/dx = 2 x / q': the
solution is smooth in x (x is a smooth function of w there), and x = 0 is the surface, so the
last step lands on it with no crossing to locate (3-6 step evaluations fewer per loss on
long-flight orbits). If q' turns, or the span's end or an output time comes first, the
approach goes on in t from the last accepted step.

The vector field is continuous at q = -n (F(-n) = 0), so the saltation matrix is the identity:
the monodromy is the plain product of the contact flow Jacobians (variational equations) and
the flight Jacobians [[1, phi1], [0, E]].

One driver serves three uses, selected by flags: Newton iterations (variational), the final
measure pass (variational + orbit measures), and time histories (dense output at given times).
"""
from math import cos, pi, sin, sqrt

import numpy as np
from numba import boolean, float64, int64

from hertzmap.kernels import status as st
from hertzmap.kernels._jit import kernel
from hertzmap.kernels._dop853 import (dense_coefficients, dense_coefficients_h, dense_coefficients_w,
                             step_state, step_state_h, step_state_w, step_var, step_var_h,
                             step_var_w)
from hertzmap.kernels.flight import flight_state, flight_until_recontact
from hertzmap.kernels.model import SWITCHES, rhs_force, rhs_force_and_stiffness, switch_level
from hertzmap.kernels.records import N_HARMONICS

# layout of the ``stats`` array filled by ``integrate``
(S_ACCEPTED, S_REJECTED, S_EVENTS, S_FLIGHT_TIME, S_MIN_Q, S_MAX_Q, S_MAX_IMPACT, S_H_FIRST,
 S_H_RECONTACT, S_PARTIAL) = range(10)
N_STATS = 10
# rows of the ``harm`` array: the integrals of F cos(k w t), F sin(k w t), and (column 0) of F^2
H_COS, H_SIN, H_SQUARE = 0, 1, 2
BIG = 1e6              # |q| or |v| beyond this: diverged
W_EXIT = 0.5           # after a recontact, step in w = sqrt(t - t_r) up to t - t_r = W_EXIT^2
MODE_T, MODE_RECONTACT, MODE_LOSS, MODE_HEIGHT = 0, 1, -1, 2
# Heading for a loss of contact, t-steps shrink with the time left to the singular point (each
# about half of it). Once the surface is this many t-steps away on the local parabola, the
# approach steps in x = -sqrt(q + n) instead: the solution is smooth in x, and x = 0 is the
# surface itself, so the last step lands on it without the crossing being located first.
HEIGHT_TRIGGER = 2.5

# 8-point Gauss-Legendre nodes and weights on [0, 1] (for the contact-force harmonics)
_GL_X = np.array([0.019855071751231856, 0.10166676129318664, 0.2372337950418355,
                  0.4082826787521751, 0.5917173212478249, 0.7627662049581645,
                  0.8983332387068134, 0.9801449282487681])
_GL_W = np.array([0.05061426814518813, 0.11119051722668724, 0.15685332293894363,
                  0.18134189168918100, 0.18134189168918100, 0.15685332293894363,
                  0.11119051722668724, 0.05061426814518813])


@kernel("Tuple((float64[::1], float64[::1], float64[::1], float64[::1]))(int64)", inline="ir")
def state_arrays(dim):
    """The state arrays ``integrate`` takes: y, f, y_new, f_new (dim: 2, or 6 with the
    variational matrix)."""
    return np.empty(dim), np.empty(dim), np.empty(dim), np.empty(dim)


@kernel("Tuple((float64[::1], float64[::1], float64[::1], float64[::1], float64[:, ::1], float64[:, ::1], float64[::1], float64[:, ::1]))(int64)", inline="ir")
def integrator_scratch(dim):
    """Everything ``integrate`` works in, once per caller: y, f, y_new, f_new (state_arrays),
    K (the stages), W (the continuous extension), stats (zeroed) and harm (the force
    harmonics, zeroed)."""
    y, f, y_new, f_new = state_arrays(dim)
    return (y, f, y_new, f_new, np.empty((16, 2)), np.empty((7, 2)), np.zeros(N_STATS),
            np.zeros((3, N_HARMONICS + 1)))


@kernel(float64(float64[:, ::1], int64, float64, float64))
def dense_eval(P, i, y_old_i, x):
    """Component i of the continuous extension at fraction x of the step (scipy's layout)."""
    y = 0.0
    for r in range(6, -1, -1):
        y += P[r, i]
        if (6 - r) % 2 == 0:
            y *= x
        else:
            y *= 1.0 - x
    return y + y_old_i


@kernel(float64(float64[:, ::1], float64[::1], float64, float64, float64, int64))
def _dense_root(P, y_old, lo, hi, target, comp):
    """Root of dense component comp minus target in [lo, hi] (a sign change given), to a
    bracket of 1e-15: Illinois regula falsi, about 10 evaluations where bisection took 50."""
    flo = dense_eval(P, comp, y_old[comp], lo) - target
    fhi = dense_eval(P, comp, y_old[comp], hi) - target
    side = 0
    for _ in range(60):
        mid = (lo * fhi - hi * flo) / (fhi - flo) if fhi != flo else 0.5 * (lo + hi)
        if not (lo < mid < hi):
            mid = 0.5 * (lo + hi)
        fm = dense_eval(P, comp, y_old[comp], mid) - target
        if fm == 0.0:
            return mid
        if (fm < 0.0) == (flo < 0.0):
            lo = mid
            flo = fm
            if side == -1:
                fhi *= 0.5       # the same end kept twice: halve it (Illinois)
            side = -1
        else:
            hi = mid
            fhi = fm
            if side == 1:
                flo *= 0.5
            side = 1
        if hi - lo < 1e-15:
            break
    return lo if abs(flo) < abs(fhi) else hi


@kernel("void(float64, float64[::1], float64[::1], float64, float64, float64, float64, int64)")
def derivative(t, y, f, omega, sigma, zeta, n, model):
    """f = dy/dt for the state (q, v) and, if len(y) == 6, the variational matrix."""
    F, dF = rhs_force_and_stiffness(y[0], n, model)
    tz = 2.0 * zeta
    f[0] = y[1]
    f[1] = 1.0 + sigma * cos(omega * t) - tz * y[1] - F
    if y.shape[0] == 6:
        f[2] = y[4]
        f[3] = y[5]
        f[4] = -dF * y[2] - tz * y[4]
        f[5] = -dF * y[3] - tz * y[5]


# inlined, with step_var (kernels/_codegen.py source()), into the integration loop
@kernel("float64(int64, int64, float64, float64, float64[::1], float64[::1], float64[::1], float64[::1], float64[:, ::1], float64, float64, float64, float64, int64, float64, float64, float64)", inline="ir")
def _step(dim, mode, x, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol, atol,
          t_ref):
    """One step in the mode's variable (t; w with t = t_ref + mode w^2; or x = -sqrt(q + n))."""
    if mode == MODE_T:
        if dim == 6:
            return step_var(x, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol, atol)
        return step_state(x, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol, atol)
    if mode == MODE_HEIGHT:
        if dim == 6:
            return step_var_h(x, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol,
                              atol, t_ref, 1.0)
        return step_state_h(x, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol,
                            atol, t_ref, 1.0)
    sgn = float(mode)
    if dim == 6:
        return step_var_w(x, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol, atol,
                          t_ref, sgn)
    return step_state_w(x, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol, atol,
                        t_ref, sgn)


@kernel("void(int64, float64, float64, float64[::1], float64[::1], float64[:, ::1], float64, float64, float64, float64, int64, float64[:, ::1], float64)")
def _dense(mode, x, h, y, y_new, K, omega, sigma, zeta, n, model, P, t_ref):
    if mode == MODE_T:
        dense_coefficients(x, h, y, y_new, K, omega, sigma, zeta, n, model, P)
    else:
        dense_coefficients_w(x, h, y, y_new, K, omega, sigma, zeta, n, model, P, t_ref,
                             float(mode))


@kernel("float64(int64, float64, float64)")
def _time(mode, x, t_ref):
    """Physical time of the mode's variable x."""
    if mode == MODE_T:
        return x
    return t_ref + mode * x * x


@kernel("float64(int64, float64, float64)")
def _variable(mode, t, t_ref):
    """The mode's variable at physical time t (inverse of _time)."""
    if mode == MODE_T:
        return t
    return mode * sqrt(max(0.0, mode * (t - t_ref)))


@kernel("float64(int64, float64, float64, float64[::1], float64[::1], float64, float64, float64, float64, int64)")
def _enter(mode, t, t_ref, y, f, omega, sigma, zeta, n, model):
    """Variable value at t in the new mode, and f = dy/dx in its units (FSAL restart)."""
    derivative(t, y, f, omega, sigma, zeta, n, model)
    x = _variable(mode, t, t_ref)
    if mode != MODE_T:
        m = 2.0 * mode * x
        for i in range(y.shape[0]):
            f[i] *= m
    return x


@kernel("Tuple((float64, boolean))(float64, float64[::1], float64[::1], float64[::1], float64, float64, float64, float64, int64, float64)")
def _lose_contact(t, y, f, stats, omega, sigma, zeta, n, model, level):
    """Contact is lost at t: q = level (the law's loss level, -n for Hertz) exactly and one
    more event. Returns the t-mode variable (with f the derivative there) and whether flight
    follows (q' < 0)."""
    y[0] = level
    stats[S_EVENTS] += 1
    return _enter(MODE_T, t, t, y, f, omega, sigma, zeta, n, model), y[1] < 0.0


@kernel(float64(float64, float64, float64))
def _time_to_surface(g, v, a):
    """First s > 0 with g + v s + a s^2 / 2 = 0 (g = q - level >= 0 the height above the contact
    surface, v and a the velocity and acceleration): when contact would be lost on the local
    parabola; inf if never."""
    if g <= 0.0:
        return 0.0
    disc = v * v - 2.0 * a * g
    if disc < 0.0:
        return np.inf
    r = sqrt(disc)
    # roots -g / (v/2 -+ ...) written without cancellation: s = 2 g / (-v +- r)
    best = np.inf
    for den in (-v + r, -v - r):
        if den > 0.0:
            best = min(best, 2.0 * g / den)
    return best


@kernel(boolean(float64, float64, float64))
def _lands_steeply(g, v, a):
    """On the local parabola (height g above the surface, velocity v < 0, acceleration a),
    does q reach the surface at a speed between |v| / 2 and 2 |v|? The condition for stepping
    in x = -sqrt(q + n): dt/dx = 2 x / q' stays bounded and well scaled on the way down."""
    if not v < 0.0:
        return False
    landing2 = v * v - 2.0 * a * g
    return 0.25 * v * v <= landing2 <= 4.0 * v * v


@kernel(float64(float64, float64, float64, float64, float64, float64))
def _hermite_root(g0, d0, a0, g1, d1, a1):
    """Root in (0, 1) of the Hermite interpolant with values g0 > 0 > g1, slopes d0, d1 and
    (if finite) second derivatives a0, a1 (per unit of the fraction) at the ends: the first
    guess of a crossing inside a step. Quintic with a0, a1, else cubic: its error is the step's
    sixth- (fourth-) order term, where the secant's is the second, and the located crossing
    needs fewer partial steps (each costs a full step)."""
    # monomial coefficients of p(x) = c0 + c1 x + ... + c5 x^5
    c0 = g0
    c1 = d0
    if a0 == a0 and a1 == a1:
        c2 = 0.5 * a0
        dg = g1 - g0 - d0 - c2
        c3 = 10.0 * dg - 4.0 * (d1 - d0 - a0) + 0.5 * (a1 - a0)
        c4 = -15.0 * dg + 7.0 * (d1 - d0 - a0) - (a1 - a0)
        c5 = 6.0 * dg - 3.0 * (d1 - d0 - a0) + 0.5 * (a1 - a0)
    else:
        c2 = 3.0 * (g1 - g0) - 2.0 * d0 - d1
        c3 = 2.0 * (g0 - g1) + d0 + d1
        c4 = 0.0
        c5 = 0.0
    lo = 0.0
    hi = 1.0
    x = g0 / (g0 - g1)
    for _ in range(40):
        p = c0 + x * (c1 + x * (c2 + x * (c3 + x * (c4 + x * c5))))
        dp = c1 + x * (2.0 * c2 + x * (3.0 * c3 + x * (4.0 * c4 + x * 5.0 * c5)))
        if p == 0.0:
            return x
        if p > 0.0:
            lo = x
        else:
            hi = x
        x_new = x - p / dp if dp != 0.0 else 0.5 * (lo + hi)
        if not (lo < x_new < hi):
            x_new = 0.5 * (lo + hi)
        if abs(x_new - x) <= 1e-15:
            return x_new
        x = x_new
    return x


@kernel("UniTuple(float64, 2)(int64, int64, float64, float64, float64[::1], float64[::1], float64[::1], float64[::1], float64[:, ::1], float64, float64, float64, float64, int64, float64, float64, float64, float64, float64[::1], float64)")
def _locate_crossing(dim, mode, x, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol,
                     atol, t_ref, s_guess, stats_partial, level):
    """Increment s in (0, h] of the mode's variable from x where q = level (the law's loss
    level, switch_level: -n for Hertz; "q + n" below is q - level), the step over h ending
    below (or dipping below) the surface. Bracketed Newton on partial steps from x (each lies in
    contact up to the root, so it is as accurate as a step) from a Hermite first guess, to
    |q + n| <= g_tol = max(1e-2 rtol, 1e-14) n; dq/dx is the FSAL derivative f_new[0]. Counts
    the partial steps (full steps in cost, in no other counter) in stats_partial[0].

    Returns (s, err): err is the error estimate of the partial step onto the root when y_new
    holds its end state (|q + n| <= g_tol), else -1 (y_new left arbitrary)."""
    lo = 0.0
    hi = h
    # The switch state is set to q = -n exactly, so a residual g is a local error of the step
    # onto it: 1e-2 rtol n is far inside the step's own error budget, and saves the partial
    # step that would take g from ~1e-11 to round-off. (n here is a scale of q, not the level.)
    g_tol = max(1e-2 * rtol, 1e-14) * n
    g_hi = y_new[0] - level
    g_lo = y[0] - level
    if s_guess > 0.0:
        s = s_guess
    elif g_lo - g_hi > 0.0:
        # t-steps: q'' = dv/dt = f[1] (quintic); w-steps: cubic on dq/dw alone
        a0 = h * h * f[1] if mode == MODE_T else np.nan
        a1 = h * h * f_new[1] if mode == MODE_T else np.nan
        s = h * _hermite_root(g_lo, h * f[0], a0, g_hi, h * f_new[0], a1)
    else:
        s = 0.5 * h
    for _ in range(30):
        err = _step(dim, mode, x, s, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol,
                    atol, t_ref)
        g = y_new[0] - level
        stats_partial[0] += 1
        if abs(g) <= g_tol:
            return s, err
        if g > 0.0:
            lo = s
        else:
            hi = s
        if hi - lo <= 1e-15 * max(1.0, abs(x)):
            return hi, -1.0
        dg = f_new[0]
        if mode == MODE_T and dg != 0.0:
            # Close enough for a Taylor step instead of another partial step: d solves
            # g + d dq/dt + d^2 q''/2 = 0, and the end state moves by d y' (the stages use the
            # law's smooth continuation across the surface, so y' = f_new holds on both
            # sides); d^2 <= g_tol keeps what is left out, d^2 y''/2, at g_tol |y''| / 2
            d = -g / dg
            d = -(g + 0.5 * f_new[1] * d * d) / dg
            if d * d <= g_tol and lo < s + d < hi:
                for i in range(dim):
                    y_new[i] += d * f_new[i]
                y_new[0] = level
                return s + d, err
        s_new = s - g / dg if dg != 0.0 else 0.5 * (lo + hi)
        if not (lo < s_new < hi):
            s_new = 0.5 * (lo + hi)
        s = s_new
    return s, -1.0


@kernel("int64(float64[::1], float64, float64, float64, float64, float64, float64, int64, float64, float64, float64, int64, boolean, boolean, boolean, float64, float64[:, ::1], float64[::1], float64[:, ::1], float64[::1], float64[::1], float64[::1], float64[::1], float64[:, ::1], float64[:, ::1])")
def integrate(y, t0, t1, omega, sigma, zeta, n, model, rtol, atol, h, max_steps,
              variational, measure, harmonics, period_harm, harm, t_eval, out_eval, stats,
              f, y_new, f_new, K, P):
    """Advance y (length 6 with the variational matrix, else 2) from t0 to t1 in place.

    Parameters (all dimensionless): omega, sigma, zeta, n (contact exponent), model (a contact
    law's code, kernels.model.LAWS); rtol, atol tolerances of the local error on (q, q') and Phi; h initial step;
    max_steps bound on steps + rejections + events. With ``measure``, fills stats (min/max q,
    flight time, largest impact velocity); with ``harmonics`` too, accumulates into harm[H_COS, k],
    harm[H_SIN, k] the integrals of F(q) cos(k w t) and F(q) sin(k w t), w = 2 pi / period_harm,
    k = 0..N_HARMONICS, and into harm[H_SQUARE, 0] that of F(q)^2 (8-point Gauss-Legendre on
    the continuous extension of every step: about as costly as the step itself, so only when asked for).
    With ``t_eval`` (sorted, inside [t0, t1]) writes q, q', F at those times into out_eval (3, m).
    Work arrays: f, y_new, f_new (len(y)), K (16, 2), P (7, 2).

    Returns a status code (kernels.status); stats[S_H_FIRST] is the first accepted t-step and
    stats[S_H_RECONTACT] the first accepted w-step after a recontact: good initial steps for the
    next call over the same orbit.
    """
    dim = y.shape[0]
    switches = SWITCHES[model]
    # the switching surface q = level, as the law declares it (-n for the Hertz law, bit for
    # bit): every "-n" of the comments below is this level, every "q + n" q - level
    level = switch_level(n, model)
    t = t0
    n_eval = t_eval.shape[0]
    i_eval = 0
    while i_eval < n_eval and t_eval[i_eval] < t0:
        i_eval += 1
    w_h = 2.0 * pi / period_harm
    span = t1 - t0
    h_min = 1e-14 * max(1.0, abs(t1))
    stats[S_H_FIRST] = 0.0
    if measure:
        stats[S_MIN_Q] = y[0]
        stats[S_MAX_Q] = y[0]
    # which phase do we start in?
    in_flight = False
    if switches:
        if y[0] < level:
            in_flight = True
        elif y[0] == level:
            acc0 = 1.0 + sigma * cos(omega * t0) - 2.0 * zeta * y[1]
            in_flight = y[1] < 0.0 or (y[1] == 0.0 and acc0 < 0.0)
    mode = MODE_T
    t_ref = 0.0
    x = _enter(mode, t, t_ref, y, f, omega, sigma, zeta, n, model)
    work = 0
    first_w_step = False
    if h <= 0.0 or h > span:
        h = min(span, 0.1)
    h_t = h                     # the t-step to resume with after a w-mode
    height_ok = True            # until the next contact switch, after an approach in x gave up
    t_zero = -np.inf            # where a crossing was last located at the very start of a step
    while t < t1:
        work += 1
        if work > max_steps:
            return st.STEP_LIMIT
        if in_flight:
            s_max = t1 - t
            s, qmin_f, found = flight_until_recontact(y[0], y[1], t, s_max, omega, sigma, zeta,
                                                      level)
            while i_eval < n_eval and t_eval[i_eval] <= t + s:
                qe, ve, _, _ = flight_state(y[0], y[1], t, t_eval[i_eval] - t, omega, sigma, zeta)
                out_eval[0, i_eval] = qe
                out_eval[1, i_eval] = ve
                out_eval[2, i_eval] = 0.0
                i_eval += 1
            q1, v1, phi1, E = flight_state(y[0], y[1], t, s, omega, sigma, zeta)
            if dim == 6:
                # Phi <- [[1, phi1], [0, E]] Phi
                a, b, c, d = y[2], y[3], y[4], y[5]
                y[2] = a + phi1 * c
                y[3] = b + phi1 * d
                y[4] = E * c
                y[5] = E * d
            if measure:
                stats[S_FLIGHT_TIME] += s
                if qmin_f < stats[S_MIN_Q]:
                    stats[S_MIN_Q] = qmin_f
            if found > 0.5:
                y[0] = level
                y[1] = v1
                t = t + s
                if t >= t1 - 1e-15 * max(1.0, abs(t1)):
                    t = t1
                stats[S_EVENTS] += 1
                if measure and v1 > stats[S_MAX_IMPACT]:
                    stats[S_MAX_IMPACT] = v1
                in_flight = False
                height_ok = True
                # the contact phase starts on the singularity of F': step in w = sqrt(t - t_r)
                # (n = 1: F is linear in contact, the contact solution analytic from the switch
                # on: plain t-steps, 2-3 fewer steps per recontact)
                mode = MODE_T if n == 1.0 else MODE_RECONTACT
                t_ref = t
                x = _enter(mode, t, t_ref, y, f, omega, sigma, zeta, n, model)
                if mode == MODE_T and dim == 6:
                    # F'(-n) is taken as 0 (the flight side); the contact side's is 1/n = 1,
                    # and the first stage must see it, or the step's error estimate sees a jump
                    f[4] -= y[2]
                    f[5] -= y[3]
                h = stats[S_H_RECONTACT] if stats[S_H_RECONTACT] > 0.0 else 0.05
                first_w_step = True
            else:
                y[0] = q1
                y[1] = v1
                t = t1
            continue

        # ---- contact: one adaptive step in the mode's variable -------------------------------
        if mode == MODE_T:
            x_target = t1
        elif mode == MODE_LOSS or mode == MODE_HEIGHT:
            x_target = 0.0
        else:
            x_target = min(W_EXIT, sqrt(max(0.0, t1 - t_ref)))
        at_target = False
        if x + h >= x_target - 1e-13 * max(1.0, abs(x_target)):
            h = x_target - x
            at_target = True
        err = _step(dim, mode, x, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol,
                    atol, t_ref)
        if mode == MODE_HEIGHT:
            # y[0] holds tau = t - t_ref here, and q = x^2 + level (x^2 - n)
            t_new = t_ref + y_new[0]
            leave = (not (y_new[1] < 0.0) or t_new >= t1
                     or (i_eval < n_eval and t_eval[i_eval] <= t_new))
            if not leave:
                if not (err <= 1.0):
                    stats[S_REJECTED] += 1
                    h *= 0.2 if err != err else max(0.2, 0.9 / sqrt(sqrt(sqrt(err))))
                    if h < h_min:
                        return st.STEP_SIZE
                    continue
                stats[S_ACCEPTED] += 1
                if measure:
                    # q falls monotonically here: its lowest value is at the step end
                    q_end = level if at_target else (x + h) * (x + h) + level
                    if q_end < stats[S_MIN_Q]:
                        stats[S_MIN_Q] = q_end
                    if harmonics:
                        dense_coefficients_h(x, h, y, y_new, K, omega, sigma, zeta, n, model,
                                             P, t_ref, 1.0)
                        _height_step_harmonics(P, y, x, h, t_ref, n, model, w_h, harm, level)
                for i in range(dim):
                    y[i] = y_new[i]
                    f[i] = f_new[i]
                t = t_new
                if at_target:
                    # on the surface: contact is lost here
                    x, in_flight = _lose_contact(t, y, f, stats, omega, sigma, zeta, n, model,
                                                 level)
                    mode = MODE_T
                    h = h_t
                    continue
                x += h
                h *= max(0.2, min(10.0, 0.9 / sqrt(sqrt(sqrt(err))) if err > 0.0 else 10.0))
                leave = not _lands_steeply(x * x, y[1], f[1] / f[0])
            if leave:
                # q may turn before the surface (dt/dx = 2 x / q' would blow up), or the span's
                # end or an output time comes first: go on in t from the last accepted point
                y[0] = x * x + level
                mode = MODE_T
                height_ok = False
                x = _enter(mode, t, t_ref, y, f, omega, sigma, zeta, n, model)
                h = h_t
            continue
        land_on_switch = False
        if switches and mode != MODE_LOSS and y_new[0] < level:
            # The trial step crossed the surface. Its error estimate is meaningless (a kink
            # inside): locate the crossing now and approach it in w = -sqrt(t_stop - t).
            s, err_s = _locate_crossing(dim, mode, x, h, y, f, y_new, f_new, K, omega, sigma,
                                        zeta, n, model, rtol, atol, t_ref, 0.0, stats[S_PARTIAL:],
                                        level)
            if s == 0.0:
                if t == t_zero:
                    # On the surface with q' > 0 (a grazing recontact) and a step longer than
                    # the short contact excursion that follows: the crossing out is located at
                    # the step start (the surface itself), a zero-length contact follows, and
                    # the same step from the same state would repeat it forever. Shrink the
                    # step until it ends inside the excursion (as a rejected step).
                    stats[S_REJECTED] += 1
                    h *= 0.2
                    if h < h_min:
                        return st.STEP_SIZE
                    continue
                t_zero = t
            t_stop = _time(mode, x + s, t_ref)
            if mode == MODE_T:
                h_t = h
            if n == 1.0 and mode == MODE_T and 0.0 <= err_s <= 1.0:
                # n = 1: the continued law is exactly linear, the solution smooth in t up to the
                # switch, and the partial step onto it passed the error control: it is the step
                # that lands (the w-approach would take 2-3 more steps, for nothing)
                h = s
                err = err_s
                t_ref = t_stop
                land_on_switch = True
            else:
                mode = MODE_LOSS
                t_ref = t_stop
                x = _enter(mode, t, t_ref, y, f, omega, sigma, zeta, n, model)
                h = -x
                continue
        if not (err <= 1.0):   # also catches NaN
            stats[S_REJECTED] += 1
            if err != err:
                h *= 0.2
            else:
                h *= max(0.2, 0.9 / sqrt(sqrt(sqrt(err))))
            if h < h_min:
                return st.STEP_SIZE
            continue
        have_dense = False
        if switches and mode == MODE_T:
            q0_, v0_ = y[0], y[1]
            q1_, v1_ = y_new[0], y_new[1]
            if v0_ < 0.0 and v1_ > 0.0 and min(q0_, q1_) - level < h * max(-v0_, v1_):
                # a minimum inside the step near the surface: look at it on the interpolant
                dense_coefficients(x, h, y, y_new, K, omega, sigma, zeta, n, model, P)
                have_dense = True
                xm = _dense_root(P, y, 0.0, 1.0, 0.0, 1)
                if dense_eval(P, 0, y[0], xm) < level:
                    x0g = _dense_root(P, y, 0.0, xm, level, 0)
                    s, _ = _locate_crossing(dim, mode, x, xm * h, y, f, y_new, f_new, K,
                                            omega, sigma, zeta, n, model, rtol, atol, t_ref,
                                            x0g * h, stats[S_PARTIAL:], level)
                    h_t = h
                    mode = MODE_LOSS
                    t_ref = t + s
                    x = _enter(mode, t, t_ref, y, f, omega, sigma, zeta, n, model)
                    h = -x
                    continue
        lands = land_on_switch or (mode == MODE_LOSS and (at_target or y_new[0] < level))
        # ---- accepted step ------------------------------------------------------------------
        if n_eval > 0 or measure:
            # the continuous extension costs 3 more stages: only on steps that need it (an
            # output time inside, an extremum of q inside, or the harmonics' quadrature)
            emit = i_eval < n_eval and t_eval[i_eval] <= _time(mode, x + h, t_ref)
            extremum = measure and (y[1] < 0.0) != (y_new[1] < 0.0)
            if not have_dense and (emit or extremum or (measure and harmonics)):
                _dense(mode, x, h, y, y_new, K, omega, sigma, zeta, n, model, P, t_ref)
            if emit:
                i_eval = _emit(P, y, mode, x, h, t_ref, t_eval, out_eval, i_eval, n, model)
            if measure:
                _measure_step(P, y, y_new, mode, x, h, t_ref, n, model, extremum, harmonics,
                              w_h, harm, stats)
        stats[S_ACCEPTED] += 1
        if mode == MODE_T and stats[S_H_FIRST] == 0.0:
            stats[S_H_FIRST] = h
        if first_w_step:
            stats[S_H_RECONTACT] = h
            first_w_step = False
        elif mode == MODE_RECONTACT and not at_target and h > stats[S_H_RECONTACT]:
            # the next recontact starts with the largest accepted w-step of this one: the first
            # step is cautious (the layer's scale is unknown), and a first step kept that small
            # would cost a tiny step and a rejected one at every recontact
            stats[S_H_RECONTACT] = h
        approach = 1.0
        d1 = np.inf
        if switches and mode == MODE_T and y_new[1] < 0.0 and not lands:
            # Heading for contact loss: the solution's high derivatives grow like
            # (time to the surface)^-k, so the error of a step of given h grows as that time
            # shrinks; scale h by its ratio over this step (without this, every step of the
            # approach was followed by a rejected one: 5 rejections per contact loss)
            d1 = _time_to_surface(y_new[0] - level, y_new[1], f_new[1])
            if d1 <= 0.0:
                d1 = np.inf     # ended exactly on the surface: the next trial crosses anyway
            elif d1 < 4.0 * h:
                d0 = _time_to_surface(y[0] - level, y[1], f[1])
                if d1 < d0 < np.inf:
                    approach = max(0.2, d1 / d0)
        x = x_target if at_target else x + h
        t = _time(mode, x, t_ref)
        if mode == MODE_T and at_target:
            t = t1
        for i in range(dim):
            y[i] = y_new[i]
            f[i] = f_new[i]
        if abs(y[0]) > BIG or abs(y[1]) > BIG or y[0] != y[0]:
            return st.DIVERGED
        if err == 0.0:
            h *= 10.0
        else:
            # err^(-1/8) by three square roots: the next step waits for this factor, and libm's
            # pow takes longer on that critical path
            h *= min(10.0, max(0.2, 0.9 / sqrt(sqrt(sqrt(err))))) * approach
        to_height = (d1 < HEIGHT_TRIGGER * h and height_ok and n != 1.0 and t + d1 < t1
                     and not at_target and _lands_steeply(y[0] - level, y[1], f[1]))
        if h >= 0.7 * d1 and not to_height:
            # the surface is within about one (scaled) step: aim past it, so that the next
            # trial crosses and the crossing is located
            h = 1.2 * d1
        if to_height:
            # step in x = -sqrt(q + n) from here: tau = t - t_ref replaces q, and the FSAL
            # derivative is taken to x units (dt/dx = 2 x / q'); the first step is the proposed
            # t-step in x units
            h_t = h
            t_ref = t
            x = -sqrt(max(0.0, y[0] - level))
            m = 2.0 * x / y[1]
            f[0] = 1.0
            for i in range(dim):
                f[i] *= m
            y[0] = 0.0
            mode = MODE_HEIGHT
            h = min(-x, h_t / m)
        elif lands:
            # contact is lost exactly at t_stop
            t = t_ref
            x, in_flight = _lose_contact(t, y, f, stats, omega, sigma, zeta, n, model, level)
            mode = MODE_T
            h = h_t
        elif mode == MODE_RECONTACT and at_target:
            # out of the singular layer: back to t, with the t-length of the last w-step
            h_w = h
            mode = MODE_T
            x = _enter(mode, t, t_ref, y, f, omega, sigma, zeta, n, model)
            h = max(h_min, 2.0 * W_EXIT * h_w)
    if mode == MODE_HEIGHT:     # (not reached: a step in x never ends at t1; q from x if it did)
        y[0] = x * x + level
    # outputs at t1 exactly (t_eval may end at t1)
    while i_eval < n_eval and t_eval[i_eval] <= t1 * (1.0 + 1e-15) + 1e-300:
        out_eval[0, i_eval] = y[0]
        out_eval[1, i_eval] = y[1]
        out_eval[2, i_eval] = rhs_force(y[0], n, model)
        i_eval += 1
    if measure:
        if y[0] < stats[S_MIN_Q]:
            stats[S_MIN_Q] = y[0]
        if y[0] > stats[S_MAX_Q]:
            stats[S_MAX_Q] = y[0]
    return st.CONVERGED


@kernel("int64(float64[:, ::1], float64[::1], int64, float64, float64, float64, float64[::1], float64[:, ::1], int64, float64, int64)")
def _emit(P, y, mode, x, h, t_ref, t_eval, out_eval, i_eval, n, model):
    """Write the dense output at every t_eval inside the step (x, x + h] of the mode's variable."""
    n_eval = t_eval.shape[0]
    t_end = _time(mode, x + h, t_ref)
    while i_eval < n_eval and t_eval[i_eval] <= t_end:
        xi = (_variable(mode, t_eval[i_eval], t_ref) - x) / h if h > 0.0 else 1.0
        xi = min(1.0, max(0.0, xi))
        qe = dense_eval(P, 0, y[0], xi)
        out_eval[0, i_eval] = qe
        out_eval[1, i_eval] = dense_eval(P, 1, y[1], xi)
        out_eval[2, i_eval] = rhs_force(qe, n, model)
        i_eval += 1
    return i_eval


@kernel("void(float64[:, ::1], float64[::1], float64[::1], int64, float64, float64, float64, float64, int64, boolean, boolean, float64, float64[:, ::1], float64[::1])")
def _measure_step(P, y, y_new, mode, x, h, t_ref, n, model, extremum, harmonics, w_h, harm,
                  stats):
    """Orbit measures over one contact step: extrema of q (``extremum``: q' changes sign
    inside, P holds the continuous extension) and, with ``harmonics``, the contact-force
    harmonics."""
    q0, q1 = y[0], y_new[0]
    for qq in (q0, q1):
        if qq < stats[S_MIN_Q]:
            stats[S_MIN_Q] = qq
        if qq > stats[S_MAX_Q]:
            stats[S_MAX_Q] = qq
    if extremum:
        xm = _dense_root(P, y, 0.0, 1.0, 0.0, 1)
        qm = dense_eval(P, 0, y[0], xm)
        if qm < stats[S_MIN_Q]:
            stats[S_MIN_Q] = qm
        if qm > stats[S_MAX_Q]:
            stats[S_MAX_Q] = qm
    if not harmonics:
        return
    for j in range(8):
        xi = _GL_X[j]
        qe = dense_eval(P, 0, y[0], xi)
        xx = x + xi * h
        dtdx = 1.0 if mode == MODE_T else abs(2.0 * xx)
        Fq = rhs_force(qe, n, model)
        Fe = Fq * _GL_W[j] * h * dtdx
        if Fe != 0.0:
            _add_harmonics(Fe, _time(mode, xx, t_ref), w_h, harm)
            harm[H_SQUARE, 0] += Fq * Fe


@kernel("void(float64[:, ::1], float64[::1], float64, float64, float64, float64, int64, float64, float64[:, ::1], float64)")
def _height_step_harmonics(P, y, x, h, t_ref, n, model, w_h, harm, level):
    """The contact-force harmonics over one step in x = -sqrt(q - level) (P: its continuous
    extension of (tau, q')): q = x^2 + level at the Gauss nodes (level = -n: the law's loss
    level), dt = 2 x / q' dx."""
    for j in range(8):
        xi = _GL_X[j]
        xx = x + xi * h
        dtdx = 2.0 * xx / dense_eval(P, 1, y[1], xi)
        Fq = rhs_force(xx * xx + level, n, model)
        Fe = Fq * _GL_W[j] * h * dtdx
        if Fe != 0.0:
            _add_harmonics(Fe, t_ref + dense_eval(P, 0, y[0], xi), w_h, harm)
            harm[H_SQUARE, 0] += Fq * Fe


@kernel("void(float64, float64, float64, float64[:, ::1])")
def _add_harmonics(Fe, tt, w_h, harm):
    """harm[H_COS, k] += Fe cos(k w_h tt), harm[H_SIN, k] += Fe sin(k w_h tt), k = 0..N_HARMONICS."""
    c1 = cos(w_h * tt)
    s1 = sin(w_h * tt)
    ck = 1.0
    sk = 0.0
    for k in range(N_HARMONICS + 1):
        harm[H_COS, k] += Fe * ck
        harm[H_SIN, k] += Fe * sk
        # angle addition: cos/sin of (k+1) w t from those of k w t
        ck, sk = ck * c1 - sk * s1, sk * c1 + ck * s1
