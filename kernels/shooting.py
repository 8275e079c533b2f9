"""Periodic orbits by Newton shooting on the stroboscopic map (paper section 3.2), with exact
monodromy from the variational equations, Floquet multipliers and orbit measures.

A period-m orbit (m T, T = 2 pi / omega) is a fixed point x0 = (q, q') at tau = 0 of the map
Phi_{mT}. Newton: (M - I) dx = -(Phi(x) - x), M = dPhi/dx the monodromy matrix, with a
backtracking line search on |Phi(x) - x| where a full step does not reduce it.

Stability: the Floquet multipliers are the eigenvalues of M; by Liouville's formula
det M = exp(-2 zeta m T), a free check of every monodromy. Flip (period doubling) where
1 + tr M + det M = 0, fold where 1 - tr M + det M = 0.

``shoot_into`` fills one row of a float64 result array (layout ``FIELDS``); ``shoot_batch`` loops
it over arrays of parameters. Neither raises nor allocates per Newton iteration; the status
code says what happened (kernels.status).
"""
from math import exp, hypot, pi, sqrt

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels._jit import kernel
from hertzmap.kernels.integrate import (H_COS, H_SIN, H_SQUARE, N_HARMONICS, N_STATS, S_ACCEPTED, S_EVENTS, S_FLIGHT_TIME,
                               S_H_FIRST, S_H_RECONTACT, S_MAX_IMPACT, S_MAX_Q, S_MIN_Q,
                               S_REJECTED, BIG,
                               integrate, integrator_scratch)
from hertzmap.kernels.model import FIXED_LOSS_LEVEL, SWITCHES, rhs_force
from hertzmap.kernels.records import ORBIT

#: The result row's layout, from the orbit record (kernels.records.ORBIT)
FIELDS = ORBIT.columns
F = ORBIT.index
N_FIELDS = len(FIELDS)
# column indices, compile-time constants of the kernels below
I_STATUS, I_Q0, I_V0, I_STABLE, I_LIOU = (F["status"], F["q0"], F["v0"], F["stable"],
                                          F["liouville_residual"])
I_M1R, I_M1I, I_M2R, I_M2I = (F["multiplier1_re"], F["multiplier1_im"], F["multiplier2_re"],
                              F["multiplier2_im"])
I_MINQ, I_MAXQ, I_PTP, I_LOSES, I_FLIGHT, I_IMPACT, I_PEAKF = (
    F["min_q"], F["max_q"], F["ptp"], F["loses_contact"], F["flight_fraction"],
    F["max_impact_velocity"], F["peak_force"])
I_H1, I_RMSF, I_MEANF = F["force_h1"], F["rms_force"], F["mean_force"]
I_ITER, I_RES, I_TR, I_DET, I_MINPER = (F["newton_iterations"], F["residual"], F["trace_m"],
                                        F["det_m"], F["minimal_period"])
I_STEPS, I_REJ, I_EVENTS = F["steps"], F["rejected"], F["events"]
I_M11, I_M12, I_M21, I_M22 = F["m11"], F["m12"], F["m21"], F["m22"]

XTOL_MEASURE = 1e-3    # Newton hands over to the measure pass below this step (relative)
# Newton gives up after this many consecutive stalled steps: steps that the line search could
# not make decrease the residual below ``stall_ratio`` times the last (why 2: at the test in
# shoot_into)
STALL_LIMIT = 2


@kernel("void(float64[::1], float64, float64)")
def _start(y, q, v):
    """y = (q, v, Phi = I): the start of a period map with its variational matrix."""
    y[0] = q
    y[1] = v
    y[2] = 1.0
    y[3] = 0.0
    y[4] = 0.0
    y[5] = 1.0


@kernel("int64(float64, float64, float64, float64, float64, float64, float64, int64, float64, float64, float64, int64, float64[::1], float64[::1], float64[:, ::1], float64[::1], float64[:, ::1], float64[::1], float64[::1], float64[::1], float64[:, ::1], float64[:, ::1])", inline="ir")
def _map(x0, v0, P, omega, sigma, zeta, n, model, rtol, atol, h, max_steps, y, stats, harm,
         t_eval, out_eval, f, y_new, f_new, K, W):
    """Phi_P(x) and its Jacobian into y (6,). Returns the status."""
    _start(y, x0, v0)
    stats[S_ACCEPTED] = 0.0     # the integrator accumulates; the caller sums per map
    stats[S_REJECTED] = 0.0
    return integrate(y, 0.0, P, omega, sigma, zeta, n, model, rtol, atol, h, max_steps,
                     True, False, False, P, harm, t_eval, out_eval, stats, f, y_new, f_new, K, W)


@kernel("Tuple((boolean, float64, float64))(float64, float64, float64, float64, float64, float64)")
def _newton_step(m11, m12, m21, m22, rq, rv):
    """Solve (M - I) dx = -r for the 2x2 monodromy M; ok is False when M - I is singular to
    round-off (a multiplier +1: a fold)."""
    a = m11 - 1.0
    d = m22 - 1.0
    det = a * d - m12 * m21
    if abs(det) <= 1e-15 * (abs(a * d) + abs(m12 * m21) + 1e-300):
        return False, 0.0, 0.0
    return True, -(d * rq - m12 * rv) / det, -(-m21 * rq + a * rv) / det


@kernel("int64(float64, float64, float64, float64, float64, float64, float64, int64, float64, float64, float64, int64, float64[::1], float64[::1], boolean, float64[:, ::1], float64[::1], float64[:, ::1], float64[::1], float64[::1], float64[::1], float64[:, ::1], float64[:, ::1])", inline="ir")
def _measure_pass(x0, v0, P, omega, sigma, zeta, n, model, rtol, atol, h, max_steps, y, stats,
                  harmonics, harm, t_eval, out_eval, f, y_new, f_new, K, W):
    """Phi_P(x) and its Jacobian, with the orbit measures into stats (and, with
    ``harmonics``, the force harmonics into harm)."""
    _start(y, x0, v0)
    for i in range(N_STATS):
        if i != S_H_RECONTACT:
            stats[i] = 0.0
    harm[:, :] = 0.0
    return integrate(y, 0.0, P, omega, sigma, zeta, n, model, rtol, atol, h, max_steps,
                     True, True, harmonics, P, harm, t_eval, out_eval, stats, f, y_new, f_new,
                     K, W)


@kernel("void(float64, float64, float64, int64, float64, float64, float64, int64, float64, float64, int64, float64, int64, boolean, float64[::1])")
def shoot_into(omega, sigma, zeta, m, q_guess, v_guess, n, model, rtol, atol, max_iter,
               stall_ratio, max_steps, harmonics, res):
    """Find the period-m orbit near (q_guess, v_guess); write FIELDS into res (float64[N_FIELDS]).

    Dimensionless inputs (paper Eq. 7): omega > 0, sigma >= 0, zeta >= 0, n > 0 the contact
    exponent, model a contact law's code (kernels.model.LAWS); rtol/atol the integrator's local tolerances on (q, q').
    ``harmonics``: also the contact-force harmonics, rms and mean force (a quadrature on every
    step of the measure pass, which it makes about twice as costly); else those fields are NaN.
    ``stall_ratio`` (<= 1): a damped Newton step stalls when it leaves the residual at or above
    this share of the last; STALL_LIMIT stalls running end the solve (not_converged). 1: only
    steps that do not decrease it at all (the searches from seeds); below 1, slow creep too
    (study.solve.atlas.STALL_RATIO: continuations from a neighbour's orbit).
    """
    for i in range(res.shape[0]):
        res[i] = np.nan
    res[I_ITER] = 0.0
    res[I_STEPS] = 0.0
    res[I_REJ] = 0.0
    y, f, y_new, f_new, K, W, stats, harm = integrator_scratch(6)
    no_eval = np.empty(0)
    out_none = np.empty((3, 0))
    if not (omega > 0.0 and sigma >= 0.0 and zeta >= 0.0 and n > 0.0 and m >= 1
            and np.isfinite(omega) and np.isfinite(sigma) and np.isfinite(zeta)
            and np.isfinite(q_guess) and np.isfinite(v_guess)):
        res[I_STATUS] = st.DIVERGED
        return
    T = 2.0 * pi / omega
    P = m * T
    h = min(0.1, P / 16.0)
    x = q_guess
    v = v_guess
    code = _map(x, v, P, omega, sigma, zeta, n, model, rtol, atol, h, max_steps, y, stats,
                harm, no_eval, out_none, f, y_new, f_new, K, W)
    steps = stats[S_ACCEPTED] + stats[S_REJECTED]
    if stats[S_H_FIRST] > 0.0:
        h = stats[S_H_FIRST]
    rq = y[0] - x
    rv = y[1] - v
    rn = hypot(rq, rv)
    m11, m12, m21, m22 = y[2], y[3], y[4], y[5]
    # Newton stops once it contracts quadratically to within XTOL_MEASURE: the next evaluation
    # is the measure pass itself, whose residual and monodromy give one last Newton correction
    # of the start point (no extra integration). If that correction exceeds tight, Newton
    # resumes from the measure pass.
    xtol = XTOL_MEASURE
    tight = max(10.0 * rtol, 1e-13)
    dx_prev = np.inf
    converged = False
    it = 0
    stalls = 0
    t_eval = np.empty(m - 1 if m > 1 else 0)
    for j in range(t_eval.shape[0]):
        t_eval[j] = (j + 1) * T
    out_eval = np.empty((3, t_eval.shape[0]))
    while code == st.CONVERGED and it < max_iter:
        it += 1
        ok, dq, dv = _newton_step(m11, m12, m21, m22, rq, rv)
        if not ok:
            code = st.SINGULAR
            break
        ndx = hypot(dq, dv)
        scale = 1.0 + hypot(x, v)
        # quadratic convergence: the correction after this one is about ndx^3 / dx_prev^2
        if ndx <= xtol * scale and ndx * (ndx / dx_prev) ** 2 <= tight * scale:
            # the next evaluation is the measure pass; repeat it while its correction is large
            while it < max_iter:
                x += dq
                v += dv
                it += 1
                code = _measure_pass(x, v, P, omega, sigma, zeta, n, model, rtol, atol, h,
                                     max_steps, y, stats, harmonics, harm, t_eval, out_eval,
                                     f, y_new, f_new, K, W)
                steps += stats[S_ACCEPTED] + stats[S_REJECTED]
                if code != st.CONVERGED:
                    break
                rq = y[0] - x
                rv = y[1] - v
                rn = hypot(rq, rv)
                m11, m12, m21, m22 = y[2], y[3], y[4], y[5]
                ok, dq, dv = _newton_step(m11, m12, m21, m22, rq, rv)
                if not ok:
                    code = st.SINGULAR
                    break
                if hypot(dq, dv) <= tight * scale:
                    converged = True
                    break
            break
        lam = 1.0
        while True:
            xt = x + lam * dq
            vt = v + lam * dv
            code = _map(xt, vt, P, omega, sigma, zeta, n, model, rtol, atol, h, max_steps, y,
                        stats, harm, no_eval, out_none, f, y_new, f_new, K, W)
            steps += stats[S_ACCEPTED] + stats[S_REJECTED]
            if code == st.CONVERGED:
                rqt = y[0] - xt
                rvt = y[1] - vt
                rnt = hypot(rqt, rvt)
                if rnt < (1.0 - 1e-4 * lam) * rn or lam < 1.0 / 64.0:
                    break
            elif lam < 1.0 / 64.0:
                break
            lam *= 0.5
        if code != st.CONVERGED:
            break
        stalls = 0 if rnt < min(1.0 - 1e-4 * lam, stall_ratio) * rn else stalls + 1
        if stalls >= STALL_LIMIT:
            # Stalled twice running (with stall_ratio 1: no decrease even at the smallest
            # damping): this run is not converging; give up (not_converged, at the last
            # iterate). Each such iteration was a
            # line search to the bottom (7 maps), and hopeless runs from exploratory seeds took
            # two thirds of a grid block's work. Giving up at the first such step cut more, but
            # lost 2T orbits of the isola reached by continuation (10 of 1531 on the band of
            # benchmarks/search_ab.py --save/--against); so did giving up on heavily damped decreasing steps.
            break
        if stats[S_H_FIRST] > 0.0:
            h = stats[S_H_FIRST]
        x, v = xt, vt
        rq, rv, rn = rqt, rvt, rnt
        m11, m12, m21, m22 = y[2], y[3], y[4], y[5]
        dx_prev = lam * ndx
        if abs(x) > BIG or abs(v) > BIG:
            code = st.DIVERGED
            break
    res[I_ITER] = it
    res[I_STEPS] = steps
    if code != st.CONVERGED:
        res[I_STATUS] = code
        res[I_Q0] = x
        res[I_V0] = v
        res[I_RES] = rn
        return
    if not converged:
        res[I_STATUS] = st.NOT_CONVERGED
        res[I_Q0] = x
        res[I_V0] = v
        res[I_RES] = rn
        return

    # ---- results of the measure pass at (x, v); the start point gets the last correction --
    res[I_STEPS] = steps
    res[I_REJ] = stats[S_REJECTED]
    res[I_Q0] = x + dq
    res[I_V0] = v + dv
    # residual of the measured orbit (before the last correction, whose size bounds the
    # distance between the measured orbit and the reported start point)
    res[I_RES] = rn
    res[I_M11] = m11
    res[I_M12] = m12
    res[I_M21] = m21
    res[I_M22] = m22
    tr = m11 + m22
    dt = m11 * m22 - m12 * m21
    res[I_TR] = tr
    res[I_DET] = dt
    liou = exp(-2.0 * zeta * P)
    # relative to what a 2x2 determinant can resolve (det M ~ 1e-55 under heavy damping)
    # (both can underflow to 0 under extreme damping: then det M = 0 = exp(-2 zeta P) exactly)
    res[I_LIOU] = abs(dt - liou) / max(liou, abs(m11 * m22) + abs(m12 * m21), 1e-300)
    disc = 0.25 * tr * tr - dt
    if disc >= 0.0:
        r = sqrt(disc)
        # the larger-modulus root first, the other from the product (no cancellation)
        mu1 = 0.5 * tr + r if tr >= 0.0 else 0.5 * tr - r
        mu2 = dt / mu1 if mu1 != 0.0 else 0.0
        res[I_M1R] = mu1
        res[I_M1I] = 0.0
        res[I_M2R] = mu2
        res[I_M2I] = 0.0
        rho = max(abs(mu1), abs(mu2))
    else:
        r = sqrt(-disc)
        res[I_M1R] = 0.5 * tr
        res[I_M1I] = r
        res[I_M2R] = 0.5 * tr
        res[I_M2I] = -r
        rho = sqrt(dt)
    res[I_STABLE] = 1.0 if rho < 1.0 else 0.0
    res[I_MINQ] = stats[S_MIN_Q]
    res[I_MAXQ] = stats[S_MAX_Q]
    res[I_PTP] = stats[S_MAX_Q] - stats[S_MIN_Q]
    res[I_FLIGHT] = stats[S_FLIGHT_TIME] / P
    res[I_IMPACT] = stats[S_MAX_IMPACT]
    res[I_PEAKF] = rhs_force(stats[S_MAX_Q], n, model)
    res[I_EVENTS] = stats[S_EVENTS]
    if SWITCHES[model]:
        res[I_LOSES] = 1.0 if stats[S_EVENTS] > 0 or stats[S_FLIGHT_TIME] > 0.0 else 0.0
    else:
        res[I_LOSES] = 1.0 if stats[S_MIN_Q] < FIXED_LOSS_LEVEL[model] else 0.0
    if harmonics:
        for k in range(1, N_HARMONICS + 1):
            res[I_H1 + k - 1] = 2.0 / P * hypot(harm[H_COS, k], harm[H_SIN, k])
        res[I_MEANF] = harm[H_COS, 0] / P
        res[I_RMSF] = sqrt(harm[H_SQUARE, 0] / P)
    # smallest j dividing m with Phi_{jT}(x0) = x0: a 2T solve that landed on the 1T orbit
    minimal = m
    scale = 1.0 + hypot(x, v)
    for j in range(1, m):
        if m % j == 0 and hypot(out_eval[0, j - 1] - x, out_eval[1, j - 1] - v) <= 1e-7 * scale:
            minimal = j
            break
    res[I_MINPER] = minimal
    # a converged orbit must map onto itself: guard against a silently wrong answer
    if rn > max(1e3 * rtol, 1e-9) * scale:
        res[I_STATUS] = st.NOT_CONVERGED
    else:
        res[I_STATUS] = st.CONVERGED


@kernel("void(float64[::1], float64[::1], float64[::1], int64[::1], float64[::1], float64[::1], float64, int64, float64, float64, int64, float64, int64, boolean, float64[:, ::1])")
def shoot_batch_into(omega, sigma, zeta, m, q_guess, v_guess, n, model, rtol, atol, max_iter,
                     stall_ratio, max_steps, harmonics, out):
    """shoot_into for each i over 1-D arrays of equal length; out has shape (len, N_FIELDS)."""
    for i in range(omega.shape[0]):
        shoot_into(omega[i], sigma[i], zeta[i], m[i], q_guess[i], v_guess[i], n, model, rtol,
                   atol, max_iter, stall_ratio, max_steps, harmonics, out[i])
