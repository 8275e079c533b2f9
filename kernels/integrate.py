"""Event-driven integration of paper Eq. 7 with exact contact loss and recontact.

In contact: adaptive DOP853 (kernels/_dop853.py), with the variational equations when a
monodromy matrix is wanted. When a step ends below q = -n, or q' changes sign inside a step
that comes close to q = -n (a grazing dip the step ends cannot see), the crossing is located
on the step's 7th-order continuous extension and then refined by Newton on partial steps from
the step start (each partial step lies wholly in contact, so it is as accurate as a full step).
In flight: the closed form of kernels/flight.py up to the exact recontact.

The vector field is continuous at q = -n (F(-n) = 0), so the saltation matrix is the identity:
the monodromy is the plain product of the contact flow Jacobians (variational equations) and
the flight Jacobians [[1, phi1], [0, E]].

One driver serves three uses, selected by flags: Newton iterations (variational), the final
measure pass (variational + orbit measures), and time histories (dense output at given times).
"""
from math import cos, pi, sin, sqrt

import numpy as np
from numba import boolean, float64, int64, njit

from kernels import status as st
from kernels._dop853 import dense_coefficients, step_state, step_var
from kernels.flight import flight_state, flight_until_recontact
from kernels.model import HERTZ, rhs_force, rhs_force_and_stiffness

# layout of the ``stats`` array filled by ``integrate``
S_ACCEPTED, S_REJECTED, S_EVENTS, S_FLIGHT_TIME, S_MIN_Q, S_MAX_Q, S_MAX_IMPACT, S_H_FIRST = range(8)
N_STATS = 8
N_HARMONICS = 4
BIG = 1e6              # |q| or |v| beyond this: diverged

# 8-point Gauss-Legendre nodes and weights on [0, 1] (for the contact-force harmonics)
_GL_X = np.array([0.019855071751231856, 0.10166676129318664, 0.2372337950418355,
                  0.4082826787521751, 0.5917173212478249, 0.7627662049581645,
                  0.8983332387068134, 0.9801449282487681])
_GL_W = np.array([0.05061426814518813, 0.11119051722668724, 0.15685332293894363,
                  0.18134189168918100, 0.18134189168918100, 0.15685332293894363,
                  0.11119051722668724, 0.05061426814518813])


@njit(float64(float64[:, ::1], int64, float64, float64), cache=True, nogil=True)
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


@njit(float64(float64[:, ::1], float64[::1], float64, float64, float64, int64),
      cache=True, nogil=True)
def _dense_root(P, y_old, lo, hi, target, comp):
    """Root of dense component comp minus target in [lo, hi] (bisection: sign change given)."""
    flo = dense_eval(P, comp, y_old[comp], lo) - target
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        fm = dense_eval(P, comp, y_old[comp], mid) - target
        if (fm < 0.0) == (flo < 0.0):
            lo = mid
            flo = fm
        else:
            hi = mid
        if hi - lo < 1e-15:
            break
    return 0.5 * (lo + hi)


@njit("void(float64, float64[::1], float64[::1], float64, float64, float64, float64, int64)",
      cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
def _step(dim, t, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol, atol):
    if dim == 6:
        return step_var(t, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol, atol)
    return step_state(t, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol, atol)


@njit(cache=True, nogil=True)
def integrate(y, t0, t1, omega, sigma, zeta, n, model, rtol, atol, h, max_steps,
              variational, measure, period_harm, harm, t_eval, out_eval, stats,
              f, y_new, f_new, K, P):
    """Advance y (length 6 with the variational matrix, else 2) from t0 to t1 in place.

    Parameters (all dimensionless): omega, sigma, zeta, n (contact exponent), model (HERTZ or
    TAYLOR); rtol, atol tolerances of the local error on (q, q'); h initial step; max_steps
    bound on steps + rejections + events. With ``measure``, fills stats (min/max q, flight time,
    largest impact velocity) and accumulates into harm[0, k], harm[1, k] the integrals of
    F(q) cos(k w t) and F(q) sin(k w t), w = 2 pi / period_harm, k = 0..N_HARMONICS.
    With ``t_eval`` (sorted, inside [t0, t1]) writes q, q', F at those times into out_eval (3, m).
    Work arrays: f, y_new, f_new (len(y)), K (16, 2), P (7, 2).

    Returns a status code (kernels.status); stats[S_H_FIRST] is the first accepted step, a good
    initial step for the next call over the same interval.
    """
    dim = y.shape[0]
    hertz = model == HERTZ
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
    if hertz:
        if y[0] < -n:
            in_flight = True
        elif y[0] == -n:
            acc0 = 1.0 + sigma * cos(omega * t0) - 2.0 * zeta * y[1]
            in_flight = y[1] < 0.0 or (y[1] == 0.0 and acc0 < 0.0)
    derivative(t, y, f, omega, sigma, zeta, n, model)
    work = 0
    pending = False
    t_stop = t1
    if h <= 0.0 or h > span:
        h = min(span, 0.1)
    while t < t1:
        work += 1
        if work > max_steps:
            return st.STEP_LIMIT
        if in_flight:
            s_max = t1 - t
            s, qmin_f, found = flight_until_recontact(y[0], y[1], t, s_max, omega, sigma, zeta, n)
            # dense output inside the flight: closed form
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
                y[0] = -n
                y[1] = v1
                t = t + s
                if t >= t1 - 1e-15 * max(1.0, abs(t1)):
                    t = t1
                stats[S_EVENTS] += 1
                if measure and v1 > stats[S_MAX_IMPACT]:
                    stats[S_MAX_IMPACT] = v1
                in_flight = False
                derivative(t, y, f, omega, sigma, zeta, n, model)
            else:
                y[0] = q1
                y[1] = v1
                t = t1
            continue

        # ---- contact: one adaptive step -------------------------------------------------
        # With an event pending, steps land exactly on the located crossing t_stop under full
        # error control: F'(q) ~ (1 + q/n)^(n-1) is singular there, and a single uncontrolled
        # partial step onto it would cost the monodromy half its digits (error ~ sqrt(rtol)).
        t_target = t_stop if pending else t1
        lands = False
        if t + h >= t_target - 1e-13 * max(1.0, abs(t_target)):
            h = t_target - t
            lands = True
        err = _step(dim, t, h, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol, atol)
        if not (err <= 1.0):   # also catches NaN
            stats[S_REJECTED] += 1
            if err != err:
                h *= 0.2
            else:
                h *= max(0.2, 0.9 * err ** (-0.125))
            if h < h_min:
                return st.STEP_SIZE
            continue
        have_dense = False
        if hertz and not pending:
            event = False
            x_hi = 1.0
            q0_, v0_ = y[0], y[1]
            q1_, v1_ = y_new[0], y_new[1]
            if q1_ < -n:
                event = True
            elif v0_ < 0.0 and v1_ > 0.0 and min(q0_, q1_) + n < h * max(-v0_, v1_):
                # a minimum inside the step near the surface: look at it on the interpolant
                dense_coefficients(t, h, y, y_new, K, omega, sigma, zeta, n, model, P)
                have_dense = True
                xm = _dense_root(P, y, 0.0, 1.0, 0.0, 1)
                if dense_eval(P, 0, y[0], xm) < -n:
                    event = True
                    x_hi = xm
            if event:
                if not have_dense:
                    dense_coefficients(t, h, y, y_new, K, omega, sigma, zeta, n, model, P)
                s = _dense_root(P, y, 0.0, x_hi, -n, 0) * h
                # Newton on partial steps from t: q(t + s) = -n to round-off
                for it in range(8):
                    _step(dim, t, s, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, rtol,
                          atol)
                    g = y_new[0] + n
                    if abs(g) <= 1e-14 * n or y_new[1] == 0.0 or it == 7:
                        break
                    s_new = s - g / y_new[1]
                    if not (0.0 < s_new < h * x_hi * (1.0 + 1e-6)):
                        break
                    s = s_new
                pending = True
                t_stop = t + s
                h = s
                continue
        elif pending and not lands and y_new[0] < -n:
            lands = True    # the crossing came a round-off early: take it here
        # ---- accepted step ------------------------------------------------------------------
        if n_eval > 0 or measure:
            if not have_dense:
                dense_coefficients(t, h, y, y_new, K, omega, sigma, zeta, n, model, P)
            i_eval = _emit(P, y, t, h, t_eval, out_eval, i_eval, n, model)
            if measure:
                _measure_step(P, y, y_new, t, h, n, model, w_h, harm, stats)
        stats[S_ACCEPTED] += 1
        if stats[S_H_FIRST] == 0.0:
            stats[S_H_FIRST] = h
        t = t_target if lands else t + h
        for i in range(dim):
            y[i] = y_new[i]
            f[i] = f_new[i]
        if abs(y[0]) > BIG or abs(y[1]) > BIG or y[0] != y[0]:
            return st.DIVERGED
        if pending and lands:
            pending = False
            y[0] = -n
            stats[S_EVENTS] += 1
            in_flight = y[1] < 0.0
            derivative(t, y, f, omega, sigma, zeta, n, model)
        if err == 0.0:
            h *= 10.0
        else:
            h *= min(10.0, max(0.2, 0.9 * err ** (-0.125)))
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


@njit(cache=True, nogil=True)
def _emit(P, y, t, h, t_eval, out_eval, i_eval, n, model):
    """Write the dense output at every t_eval inside (t, t + h]."""
    n_eval = t_eval.shape[0]
    while i_eval < n_eval and t_eval[i_eval] <= t + h:
        x = (t_eval[i_eval] - t) / h if h > 0.0 else 1.0
        qe = dense_eval(P, 0, y[0], x)
        out_eval[0, i_eval] = qe
        out_eval[1, i_eval] = dense_eval(P, 1, y[1], x)
        out_eval[2, i_eval] = rhs_force(qe, n, model)
        i_eval += 1
    return i_eval


@njit(cache=True, nogil=True)
def _measure_step(P, y, y_new, t, h, n, model, w_h, harm, stats):
    """Orbit measures over one contact step: extrema of q and the contact-force harmonics."""
    q0, q1 = y[0], y_new[0]
    for qq in (q0, q1):
        if qq < stats[S_MIN_Q]:
            stats[S_MIN_Q] = qq
        if qq > stats[S_MAX_Q]:
            stats[S_MAX_Q] = qq
    if (y[1] < 0.0) != (y_new[1] < 0.0):
        xm = _dense_root(P, y, 0.0, 1.0, 0.0, 1)
        qm = dense_eval(P, 0, y[0], xm)
        if qm < stats[S_MIN_Q]:
            stats[S_MIN_Q] = qm
        if qm > stats[S_MAX_Q]:
            stats[S_MAX_Q] = qm
    for j in range(8):
        x = _GL_X[j]
        qe = dense_eval(P, 0, y[0], x)
        Fe = rhs_force(qe, n, model) * _GL_W[j] * h
        if Fe == 0.0:
            continue
        tt = t + x * h
        c1 = cos(w_h * tt)
        s1 = sin(w_h * tt)
        ck = 1.0
        sk = 0.0
        for k in range(N_HARMONICS + 1):
            harm[0, k] += Fe * ck
            harm[1, k] += Fe * sk
            # angle addition: cos/sin of (k+1) w t from those of k w t
            ck, sk = ck * c1 - sk * s1, sk * c1 + ck * s1
