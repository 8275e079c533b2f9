"""The paper's own scheme (section 3.2), kept as the baseline for benchmarks.

Central differences with a fixed step h = P / N (N = 10000 steps per response period in the
paper), contact force evaluated at the current displacement (F = 0 below q = -n, no event
location), and Newton shooting with a forward-difference Jacobian ("evaluated via a numerical
rule"): three integrations per Newton iteration.

    (q_{k+1} - 2 q_k + q_{k-1}) / h^2 + 2 zeta (q_{k+1} - q_{k-1}) / (2 h) + F(q_k) = 1 + sigma cos(w t_k)
"""
from math import cos, hypot, pi

import numpy as np
from numba import njit

from kernels import status as st
from kernels.model import rhs_force


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
def cd_shoot(omega, sigma, zeta, m, q_guess, v_guess, n, model, N, max_iter, xtol, out):
    """Newton shooting on cd_map with a forward-difference Jacobian.

    out = [status, q0, v0, iterations, residual, m11, m12, m21, m22].
    """
    P = m * 2.0 * pi / omega
    x = q_guess
    v = v_guess
    y = np.empty(2)
    yq = np.empty(2)
    yv = np.empty(2)
    out[0] = st.NOT_CONVERGED
    for it in range(1, max_iter + 1):
        cd_map(x, v, P, N, omega, sigma, zeta, n, model, y)
        dq_ = 1e-7 * (1.0 + abs(x))
        dv_ = 1e-7 * (1.0 + abs(v))
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
