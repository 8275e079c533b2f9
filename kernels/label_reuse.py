"""Dense basin maps by label reuse on a grid of cells (the kernels of study.solve.dense_basins):
stroboscopic transients of paper Eq. 7 from the cells' centres (a map's initial states (q, q')
at tau = 0) that stop as soon as their fate is plain from what earlier transients found.

The idea of Attractors.jl's recurrences mapper on the stroboscopic map, made cautious. A grid of
*evidence* holds, per cell, the attractor that the states seen in it reached: the cell's own
centre once its transient is done, and every cell an earlier transient passed through on its
way (one label; -2 once two transients through the cell reached different attractors: a basin
boundary crosses it, and it is never evidence again). A transient stops (``reuse_into``) when
its stroboscopic point lies

* in a certified neighbourhood of a stable orbit (V(x) <= level: study.solve.certificate)
  and, m periods later, in it again with V decreased by the certificate's factor kappa (the
  contraction the certificate predicts, seen on the transient itself, as the census's
  transients are recognised): it is on that orbit for good; or
* in a cell whose (2 r + 1)^2 block of cells around it all hold one label as evidence, for
  ``visits`` consecutive periods (``uniform_label``): the point is surrounded, a cell or more
  away on every side, by states known to reach that attractor.

A point near a basin boundary sees mixed or conflicting evidence and goes on integrating until
its fate is plain: no label is taken from a mixed neighbourhood. Everything here is arrays in,
arrays out; no allocation per period.
"""
from math import pi

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels._jit import kernel
from hertzmap.kernels.attractors import (C_KAPPA, C_LEVEL, C_P11, C_P12, C_P22, C_PERIOD, C_Q,
                                         C_V)
from hertzmap.kernels.integrate import S_H_FIRST, integrate, integrator_scratch

#: The grid's geometry (the ``box`` argument): the lower left corner (q, q') and the cell sides
B_Q, B_V, B_HQ, B_HV = 0, 1, 2, 3
#: reuse_into's label of a state whose budget ran out / whose integration failed
OPEN, FAILED = -1, -2
#: evidence: a cell no state has been seen in / one where two states reached two attractors
UNSEEN, CONFLICT = -1, -2


@kernel("int64(int16[:, ::1], float64, float64, float64[::1], int64)", inline="llvm")
def uniform_label(labels, q, v, box, radius):
    """The label of the (2 radius + 1)^2 cells around the cell holding (q, v) when all of
    them lie on the grid ``box`` (B_* columns) and carry that one label (>= 0); -1 otherwise
    (off the grid, a cell not labelled, or two labels: a basin boundary may be near)."""
    nv = labels.shape[0]
    nq = labels.shape[1]
    u = (q - box[B_Q]) / box[B_HQ]
    w = (v - box[B_V]) / box[B_HV]
    if not (u >= radius and u < nq - radius and w >= radius and w < nv - radius):
        return -1
    j = int(u)
    i = int(w)
    first = labels[i, j]
    if first < 0:
        return -1
    for a in range(i - radius, i + radius + 1):
        for b in range(j - radius, j + radius + 1):
            if labels[a, b] != first:
                return -1
    return first


@kernel("void(float64, float64, float64, float64, int64, float64, int64, float64[::1], "
        "float64[::1], int64, int16[:, ::1], float64[::1], int64, int64, float64[:, ::1], "
        "int64[::1], int64[::1], int64[::1], float64[:, ::1])")
def reuse_into(omega, sigma, zeta, n, model, rtol, max_steps, q0, v0, budget, evidence, box,
               radius, visits, cert, cert_label, label_out, periods_out, end_out):
    """The stroboscopic transient of paper Eq. 7 from each state (q0[i], v0[i]) at tau = 0 in
    turn, one forcing period at a time, for at most ``budget`` periods, stopping when its point
    has lain in a uniform block of ``evidence`` (uniform_label; ``radius`` cells each side) for
    ``visits`` consecutive periods, or lies in a certified neighbourhood and shows its
    contraction m periods later (``cert``: rows of kernels.attractors' C_* columns;
    ``cert_label``: its attractor's label). Once a state's
    label is known, its own cell and every cell its points passed through get it as evidence
    (CONFLICT where a cell held another), so later states in the list reuse it.

    ``evidence``: (cells along q', cells along q) on the grid ``box`` (B_* columns), updated in
    place. Outputs per state: label_out (OPEN when the budget ran out, FAILED when the
    integration failed), periods_out (the periods run), end_out (the last point). With budget 1
    and no evidence, end_out is the one-period image (the stroboscopic map)."""
    T = 2.0 * pi / omega
    nv = evidence.shape[0]
    nq = evidence.shape[1]
    y, f, y_new, f_new, K, P, stats, harm = integrator_scratch(2)
    no_eval = np.empty(0)
    out_none = np.empty((3, 0))
    n_cert = cert.shape[0]
    path = np.empty(budget + 1, np.int64)
    entered = np.empty(max(n_cert, 1), np.int64)
    entered_v = np.empty(max(n_cert, 1))
    for i in range(q0.shape[0]):
        for e in range(n_cert):
            entered[e] = -1
        y[0] = q0[i]
        y[1] = v0[i]
        h = min(0.1, T / 16.0)
        label = OPEN
        k = 0
        depth = 0
        streak = 0
        streak_label = -1
        u = (y[0] - box[B_Q]) / box[B_HQ]
        w = (y[1] - box[B_V]) / box[B_HV]
        if u >= 0.0 and u < nq and w >= 0.0 and w < nv:
            path[depth] = int(w) * nq + int(u)
            depth += 1
        while k < budget:
            code = integrate(y, 0.0, T, omega, sigma, zeta, n, model, rtol, rtol, h, max_steps,
                             False, False, False, T, harm, no_eval, out_none, stats, f, y_new,
                             f_new, K, P)
            k += 1
            if code != st.CONVERGED or not (np.isfinite(y[0]) and np.isfinite(y[1])):
                label = FAILED
                break
            if stats[S_H_FIRST] > 0.0:
                h = stats[S_H_FIRST]
            for e in range(n_cert):
                m_e = int(cert[e, C_PERIOD])
                dq = y[0] - cert[e, C_Q]
                dv = y[1] - cert[e, C_V]
                value = (cert[e, C_P11] * dq * dq + 2.0 * cert[e, C_P12] * dq * dv
                         + cert[e, C_P22] * dv * dv)
                if value <= cert[e, C_LEVEL]:
                    # on the orbit once the contraction its certificate predicts is seen on
                    # the transient itself, m periods later (as the census's transients)
                    if entered[e] >= 0 and k - entered[e] == m_e \
                            and value <= cert[e, C_KAPPA] * entered_v[e]:
                        label = cert_label[e]
                        break
                    if entered[e] < 0 or k - entered[e] >= m_e:
                        entered[e] = k
                        entered_v[e] = value
                elif entered[e] >= 0 and k - entered[e] >= m_e:
                    entered[e] = -1
            if label >= 0:
                break
            c = uniform_label(evidence, y[0], y[1], box, radius)
            if c >= 0 and c == streak_label:
                streak += 1
            elif c >= 0:
                streak = 1
                streak_label = c
            else:
                streak = 0
                streak_label = -1
            if streak >= visits:
                label = streak_label
                break
            u = (y[0] - box[B_Q]) / box[B_HQ]
            w = (y[1] - box[B_V]) / box[B_HV]
            if u >= 0.0 and u < nq and w >= 0.0 and w < nv:
                path[depth] = int(w) * nq + int(u)
                depth += 1
        label_out[i] = label
        periods_out[i] = k
        end_out[i, 0] = y[0]
        end_out[i, 1] = y[1]
        if label >= 0:
            for d in range(depth):
                a = path[d] // nq
                b = path[d] % nq
                held = evidence[a, b]
                if held == UNSEEN:
                    evidence[a, b] = label
                elif held != label:
                    evidence[a, b] = CONFLICT
