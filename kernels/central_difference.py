"""The paper's own scheme (section 3.2), kept as the baseline for benchmarks.

Central differences with a fixed step h = P / N (N = 10000 steps per response period in the
paper), contact force evaluated at the current displacement (F = 0 below q = -n, no event
location), and Newton shooting with a forward-difference Jacobian ("evaluated via a numerical
rule"): three integrations per Newton iteration.

    (q_{k+1} - 2 q_k + q_{k-1}) / h^2 + 2 zeta (q_{k+1} - q_{k-1}) / (2 h) + F(q_k) = 1 + sigma cos(w t_k)

Two implementations of the same scheme: ``cd_shoot`` as the paper describes it (three maps
one after the other, cos(w t_k) at every step), and ``cd_shoot_tuned``, with the care hertzmap's
own kernels get: the three maps of a Newton iteration advance together in one loop (their
dependency chains overlap in the CPU), no division on those chains, and the forcing from a
rotation recurrence instead of a cosine per step (within ~1e-12 of it over 10000 steps). The
same Newton iterates to ~1e-9 (that round-off, amplified by the forward-difference Jacobian;
far inside the scheme's own error), several times less time (benchmarks/bench_kernels.py
prints both).
"""
from math import cos, hypot, pi, sin, sqrt

import numpy as np
from numba import njit

from hertzmap.kernels import status as st
from hertzmap.kernels.model import SWITCHES, rhs_force


@njit(cache=True, nogil=True)
def cd_map(q0, v0, P, N, omega, sigma, zeta, n, model, out):
    """(q, q') after one period P with N central-difference steps; writes out[0:2]."""
    h = P / N
    a0 = 1.0 + sigma - 2.0 * zeta * v0 - rhs_force(q0, n, model)
    q_prev = q0 - h * v0 + 0.5 * h * h * a0
    q = q0
    c_plus = 1.0 + zeta * h
    c_minus = 1.0 - zeta * h
    h2 = h * h
    for k in range(N + 1):
        t = k * h
        q_next = (h2 * (1.0 + sigma * cos(omega * t) - rhs_force(q, n, model)) + 2.0 * q
                  - c_minus * q_prev) / c_plus
        if k < N:
            q_prev = q
            q = q_next
        else:
            out[0] = q
            out[1] = (q_next - q_prev) / (2.0 * h)


@njit(cache=True, nogil=True)
def _force_no_division(q, inv_n, n, model):
    """rhs_force of a law with a switching surface (kernels.model.SWITCHES) with its division
    turned into a product (q / n -> q * (1 / n)): a division sits on the recurrence's
    dependency chain and costs ~13 cycles; same values to round-off. Other laws: rhs_force."""
    if not SWITCHES[model]:
        return rhs_force(q, n, model)
    s = 1.0 + q * inv_n
    if s <= 0.0:
        return 0.0
    if n == 1.5:
        return s * sqrt(s)
    if n == 1.0:
        return s
    return s ** n


@njit(cache=True, nogil=True)
def cd_map3(q0, v0, dq, dv, P, N, omega, sigma, zeta, n, model, out):
    """cd_map from (q0, v0), (q0 + dq, v0) and (q0, v0 + dv) in one loop; out (3, 2).

    Coded for speed, same scheme: the three recurrences are independent, so the CPU overlaps
    their dependency chains; no division on them (the step's 1 / (1 + zeta h) and the force's
    1 / n are factors computed once); the forcing cos(w t_k) by the rotation
    (c, s) <- (c cos wh - s sin wh, s cos wh + c sin wh).
    """
    h = P / N
    h2 = h * h
    inv_n = 1.0 / n
    inv_plus = 1.0 / (1.0 + zeta * h)
    h2_plus = h2 * inv_plus                     # q_next = h2_plus (f - F) + two_plus q - minus q_prev
    two_plus = 2.0 * inv_plus
    minus = (1.0 - zeta * h) * inv_plus
    a = _force_no_division(q0, inv_n, n, model)
    b = _force_no_division(q0 + dq, inv_n, n, model)
    q = q0
    r = q0 + dq
    u = q0
    q_prev = q0 - h * v0 + 0.5 * h2 * (1.0 + sigma - 2.0 * zeta * v0 - a)
    r_prev = r - h * v0 + 0.5 * h2 * (1.0 + sigma - 2.0 * zeta * v0 - b)
    u_prev = q0 - h * (v0 + dv) + 0.5 * h2 * (1.0 + sigma - 2.0 * zeta * (v0 + dv) - a)
    cw = cos(omega * h)
    sw = sin(omega * h)
    c = 1.0
    s = 0.0
    for k in range(N + 1):
        g = h2_plus * (1.0 + sigma * c)
        q_next = g - h2_plus * _force_no_division(q, inv_n, n, model) + two_plus * q - minus * q_prev
        r_next = g - h2_plus * _force_no_division(r, inv_n, n, model) + two_plus * r - minus * r_prev
        u_next = g - h2_plus * _force_no_division(u, inv_n, n, model) + two_plus * u - minus * u_prev
        c, s = c * cw - s * sw, s * cw + c * sw
        if k < N:
            q_prev = q
            q = q_next
            r_prev = r
            r = r_next
            u_prev = u
            u = u_next
    out[0, 0] = q
    out[0, 1] = (q_next - q_prev) / (2.0 * h)
    out[1, 0] = r
    out[1, 1] = (r_next - r_prev) / (2.0 * h)
    out[2, 0] = u
    out[2, 1] = (u_next - u_prev) / (2.0 * h)


@njit(cache=True, nogil=True)
def cd_shoot(omega, sigma, zeta, m, q_guess, v_guess, n, model, N, max_iter, xtol, out):
    """Newton shooting on cd_map with a forward-difference Jacobian, as in the paper.

    out = [status, q0, v0, iterations, residual, m11, m12, m21, m22].
    """
    _cd_newton(omega, sigma, zeta, m, q_guess, v_guess, n, model, N, max_iter, xtol, out, False)


@njit(cache=True, nogil=True)
def cd_shoot_tuned(omega, sigma, zeta, m, q_guess, v_guess, n, model, N, max_iter, xtol, out):
    """cd_shoot with its three maps per iteration in one loop, coded for speed (cd_map3): same
    scheme, same Newton, faster code."""
    _cd_newton(omega, sigma, zeta, m, q_guess, v_guess, n, model, N, max_iter, xtol, out, True)


@njit(cache=True, nogil=True)
def _cd_newton(omega, sigma, zeta, m, q_guess, v_guess, n, model, N, max_iter, xtol, out, tuned):
    P = m * 2.0 * pi / omega
    x = q_guess
    v = v_guess
    ys = np.empty((3, 2))
    y = ys[0]
    yq = ys[1]
    yv = ys[2]
    out[0] = st.NOT_CONVERGED
    for it in range(1, max_iter + 1):
        dq_ = 1e-7 * (1.0 + abs(x))
        dv_ = 1e-7 * (1.0 + abs(v))
        if tuned:
            cd_map3(x, v, dq_, dv_, P, N, omega, sigma, zeta, n, model, ys)
        else:
            cd_map(x, v, P, N, omega, sigma, zeta, n, model, y)
            cd_map(x + dq_, v, P, N, omega, sigma, zeta, n, model, yq)
            cd_map(x, v + dv_, P, N, omega, sigma, zeta, n, model, yv)
        m11 = (yq[0] - y[0]) / dq_
        m21 = (yq[1] - y[1]) / dq_
        m12 = (yv[0] - y[0]) / dv_
        m22 = (yv[1] - y[1]) / dv_
        rq = y[0] - x
        rv = y[1] - v
        a = m11 - 1.0
        d = m22 - 1.0
        det = a * d - m12 * m21
        if det == 0.0 or not np.isfinite(det):
            out[0] = st.SINGULAR
            break
        dq = -(d * rq - m12 * rv) / det
        dv = -(-m21 * rq + a * rv) / det
        x += dq
        v += dv
        out[3] = it
        out[4] = hypot(rq, rv)
        out[5] = m11
        out[6] = m12
        out[7] = m21
        out[8] = m22
        if abs(x) > 1e6 or abs(v) > 1e6:
            out[0] = st.DIVERGED
            break
        if hypot(dq, dv) <= xtol * (1.0 + hypot(x, v)):
            out[0] = st.CONVERGED
            break
    out[1] = x
    out[2] = v
