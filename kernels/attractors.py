"""What the contact does in the long run from a given initial state: the attractor of paper
Eq. 7 reached by a transient, found on the stroboscopic map (the attractor census).

Stroboscopic transient. The forcing of Eq. 7 is T-periodic (T = 2 pi / omega, tau = Omega t),
so the stroboscopic map x_{k+1} = Phi_T(x_k) is one integration over [0, T]: each period is
integrated on its own, restarting at tau = 0 (kernels.integrate, 2-D state, closed-form flight,
exact contact switches), and every point x_k = (q, q') lies exactly on the section
tau = 0 mod T, with no time drift over thousands of periods.

Period detection. After each period, the smallest m in 1..M_MAX with
|x_j - x_{j-m}| <= tol (1 + |x_K|) for the last ``repeats`` m points j (``repeats`` returns of
the cycle, x_K the last point). A detected cycle is refined by Newton shooting with period m
from x_K (kernels.shooting.shoot_into): the census takes the orbit only if shooting converges
to a stable orbit of minimal period m near x_K. A refinement that fails backs the detection off
(the next check waits 16, 32, ... periods; at most MAX_REFINEMENTS shoots per transient); a
period-m orbit found unstable through a flip (multiplier < -1) is retried as period 2m.

Budget. ``transient_periods`` + ``record_periods`` forcing periods at most, each limited to
``max_steps`` integrator steps: the work is bounded; what the budget ends on is a status code
(kernels.status): CONVERGED (a stable periodic orbit, the orbit row holds it), UNSETTLED (no
repeating cycle within the budget: a non-periodic response over the record window, or a
period > M_MAX, or a transient longer than the budget), UNCONFIRMED (the points repeat but
shooting confirmed no stable orbit), or an integrator failure (STEP_LIMIT, STEP_SIZE, DIVERGED).
A transient that has not settled is never called periodic or chaotic by this module: a chaotic
transient (paper Eq. 7 at omega = 1, sigma = 2, zeta = 0.01 has one lasting thousands of
periods before a stable 2T orbit) looks chaotic over any window shorter than itself. The
exponent and measures describe the record window, and the status says the budget ran out.

Largest Lyapunov exponent (per unit tau), by Benettin's method over the record window: each
period is integrated with the variational equations from Phi = I (exact across contact loss and
recontact: the vector field is continuous at q = -n, so the saltation matrix is the identity),
giving the period map's Jacobian M_k; a tangent vector is propagated and renormalised,
w <- M_k w / |M_k w|, and lambda = sum log |M_k w| / (N T) over the periods after
``lyapunov_discard`` (the alignment of w). Its uncertainty: the standard error of the mean over
N_BLOCKS equal blocks (1 sigma, assuming blocks longer than the correlation time), and the
difference of the two halves' estimates. The second exponent is -2 zeta - lambda (Liouville:
det M_k = exp(-2 zeta T)); the largest deviation from Liouville over the window is reported as
a check of the tangent integration. For a stable periodic orbit the exponent is
log |mu_max| / (m T) from its Floquet multipliers.

Measures over a window (the record window of a non-periodic response, or one period m T of a
periodic one): flight fraction (time with q < -n over the window), largest impact velocity
(q' at recontact), min and max q (extrema located on the continuous extension in contact and in
closed form in flight), peak contact force F(max q), and the rms and mean contact force F/N from
``force_samples`` equally spaced samples per period (the rectangle rule on the continuous
extension). The quadrature's accuracy is measured in every call: the exact mean of F over the
window follows from Eq. 7 integrated over it, <F> = 1 - (dq'/tau + 2 zeta dq/tau) (the forcing
averages to zero over whole periods), and ``force_quadrature_error`` is the sampled mean's
distance to it.

Everything is dimensionless (paper Eq. 5-8). Kernels never raise and never allocate per period.
"""
from math import exp, hypot, log, pi, sqrt

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels._jit import kernel
from hertzmap.kernels.integrate import (N_STATS, S_ACCEPTED, S_EVENTS, S_FLIGHT_TIME,
                               S_H_FIRST, S_MAX_IMPACT, S_MAX_Q, S_MIN_Q, S_PARTIAL, S_REJECTED,
                               integrate, integrator_scratch, state_arrays)
from hertzmap.kernels.model import rhs_force
from hertzmap.kernels.records import ATTRACTOR
from hertzmap.kernels.shooting import (I_M1I, I_M1R, I_M2I, I_M2R, I_MINPER, I_Q0, I_STABLE, I_STATUS,
                              I_V0, shoot_into)

M_MAX = 16              # longest period (in forcing periods) looked for on the stroboscopic map
RING = 128              # stroboscopic points kept for detection: >= (MAX_REPEATS + 1) M_MAX
MAX_REPEATS = 7
MAX_REFINEMENTS = 6     # shooting attempts per transient
N_BLOCKS = 8            # blocks of the Lyapunov exponent's standard error
FORCE_DT = 0.05         # default spacing (in tau) of the contact-force samples

#: The result row's layout, from the attractor record (kernels.records.ATTRACTOR)
ATTRACTOR_FIELDS = ATTRACTOR.columns
A = ATTRACTOR.index
N_ATTRACTOR_FIELDS = len(ATTRACTOR_FIELDS)
# column indices, compile-time constants of the kernels below
(A_STATUS, A_PERIOD, A_RUN, A_SETTLED, A_CYCLE_RES, A_QEND, A_VEND, A_LYAP, A_LYAP_ERR,
 A_LYAP_HALVES, A_LYAP_PERIODS, A_LIOU, A_LYAP_SUM, A_WINDOW, A_FLIGHT, A_IMPACT, A_MINQ,
 A_MAXQ, A_PEAKF, A_RMSF, A_MEANF, A_QUAD_ERR, A_STEPS, A_REJ, A_EVENTS, A_REFINE,
 A_ORBIT_PERIOD, A_STROBE_COUNT, A_RECOGNISED) = (A[c] for c in (
    "status", "period", "periods_run", "settled_at", "cycle_residual", "q_end", "v_end",
    "lyapunov", "lyapunov_error", "lyapunov_halves", "lyapunov_periods", "liouville_error",
    "lyapunov_sum_error", "window_periods", "flight_fraction", "max_impact_velocity", "min_q",
    "max_q", "peak_force", "rms_force", "mean_force", "force_quadrature_error", "steps",
    "rejected", "events", "refinements", "orbit_period", "strobe_count", "recognised_as"))

#: Columns of a known attractor point (recognition: known_near): q, q', how near a
#: transient's stroboscopic point must come, and for how many consecutive periods
K_Q, K_V, K_TOL, K_VISITS = 0, 1, 2, 3
N_KNOWN_FIELDS = 4
#: The cell grid over the known points (grid argument): origin q, origin q', cell side, cells
#: along q (cells along q' follow from len(cell_start))
G_Q, G_V, G_SIDE, G_NQ = 0, 1, 2, 3
#: a label no known point has (own_label when every known attractor may be recognised)
NO_LABEL = -(1 << 62)
#: Columns of a certified stable orbit (recognition: a transient is on it once inside its
#: certified neighbourhood and contracting there, see attractor_into): the orbit's start point
#: x* (q, q'), the quadratic form P of V(x) = (x - x*)^T P (x - x*) (p11, p12, p22), the level
#: c of the neighbourhood V <= c where its m-period map was shown to contract, the factor
#: kappa < 1 of V's decrease over m periods there, and m
C_Q, C_V, C_P11, C_P12, C_P22, C_LEVEL, C_KAPPA, C_PERIOD = range(8)
N_CERT_FIELDS = 8

LYAPUNOV_FIELDS = ("status", "lyapunov", "lyapunov_error", "lyapunov_halves", "periods",
                   "liouville_error", "q_end", "v_end", "steps", "lyapunov_sum_error")
N_LYAPUNOV_FIELDS = len(LYAPUNOV_FIELDS)


# ---- period detection ----------------------------------------------------------------------

@kernel("float64(float64[:, ::1], int64, int64, int64)")
def cycle_mismatch(ring, count, m, repeats):
    """max |x_j - x_{j-m}| / (1 + |x_K|) over the last ``repeats`` m points j of the ring of
    stroboscopic points (x_K the last; ring[j % len] holds x_j, count points so far); inf when
    there are fewer than (repeats + 1) m points. Stops at the first pair beyond 1e300."""
    cap = ring.shape[0]
    need = (repeats + 1) * m
    if count < need or need > cap:
        return np.inf
    last = (count - 1) % cap
    scale = 1.0 + hypot(ring[last, 0], ring[last, 1])
    worst = 0.0
    for d in range(repeats * m):
        j = (count - 1 - d) % cap
        i = (count - 1 - d - m) % cap
        e = hypot(ring[j, 0] - ring[i, 0], ring[j, 1] - ring[i, 1]) / scale
        if e > worst:
            worst = e
    return worst


@kernel("Tuple((int64, float64))(float64[:, ::1], int64, int64, float64, int64)")
def detect_period(ring, count, m_max, tol, repeats):
    """Smallest m in 1..m_max whose cycle repeats within tol over ``repeats`` returns (see
    cycle_mismatch); (0, inf) if none. The last pair is tested first: most m fail on it."""
    cap = ring.shape[0]
    if count < 2:
        return 0, np.inf
    last = (count - 1) % cap
    scale = 1.0 + hypot(ring[last, 0], ring[last, 1])
    for m in range(1, m_max + 1):
        if count < (repeats + 1) * m or (repeats + 1) * m > cap:
            break
        i = (count - 1 - m) % cap
        if hypot(ring[last, 0] - ring[i, 0], ring[last, 1] - ring[i, 1]) > tol * scale:
            continue
        e = cycle_mismatch(ring, count, m, repeats)
        if e <= tol:
            return m, e
    return 0, np.inf


@kernel("int64(float64[:, ::1], int64, int64, float64, int64)")
def detect_period_in(points, count, m_max, tol, repeats):
    """detect_period on the first ``count`` rows of a chronological array of stroboscopic
    points (as written by attractor_into): the smallest m, 0 if none."""
    ring = np.empty((max(count, 1), 2))
    for j in range(count):
        ring[j, 0] = points[j, 0]
        ring[j, 1] = points[j, 1]
    m, _ = detect_period(ring, count, m_max, tol, repeats)
    return m


# ---- recognition ---------------------------------------------------------------------------

@kernel("int64(float64[:, ::1], int64[::1], int64[::1], float64[::1], int64, float64, float64)")
def known_near(known, labels, cell_start, grid, own_label, q, v):
    """Row of the known point nearest (q, v) among those within their own tolerance
    known[:, K_TOL] and not labelled ``own_label``; -1 if none. ``known`` is sorted by cell of
    a grid of side grid[G_SIDE] >= every tolerance (cell_start[c]: the first row in cell c),
    so only the 3 x 3 cells around (q, v) are looked at."""
    count = known.shape[0]
    if count == 0:
        return -1
    side = grid[G_SIDE]
    nq = int(grid[G_NQ])
    nv = (cell_start.shape[0] - 1) // nq
    fq = np.floor((q - grid[G_Q]) / side)
    fv = np.floor((v - grid[G_V]) / side)
    # compared as floats first: a state far off the grid (or a tiny cell) must not overflow
    # the integer conversion
    if not (fq >= -1.0 and fq <= nq and fv >= -1.0 and fv <= nv):
        return -1
    cq = int(fq)
    cv = int(fv)
    best = -1
    best_d = np.inf
    for a in range(max(cq - 1, 0), min(cq + 2, nq)):
        for b in range(max(cv - 1, 0), min(cv + 2, nv)):
            c = a * nv + b
            for i in range(cell_start[c], cell_start[c + 1]):
                if labels[i] == own_label:
                    continue
                d = hypot(q - known[i, K_Q], v - known[i, K_V])
                if d <= known[i, K_TOL] and d < best_d:
                    best = i
                    best_d = d
    return best


# ---- one forcing period ------------------------------------------------------------------

@kernel("Tuple((int64, float64))(float64[::1], float64, float64, float64, float64, float64, int64, float64, float64, float64, int64, boolean, float64[::1], float64[:, ::1], float64[::1], float64[:, ::1], float64[::1], float64[::1], float64[::1], float64[:, ::1], float64[:, ::1])", inline="ir")
def _period(y, T, omega, sigma, zeta, n, model, rtol, atol, h, max_steps, measure, t_eval,
            out_eval, stats, harm, f, y_new, f_new, K, P):
    """Advance y (2-D, or 6-D with the variational matrix) over one forcing period [0, T]
    (Eq. 7 restarted at tau = 0). Returns (status, initial step for the next period)."""
    code = integrate(y, 0.0, T, omega, sigma, zeta, n, model, rtol, atol, h, max_steps,
                     y.shape[0] == 6, measure, False, T, harm, t_eval, out_eval, stats, f, y_new,
                     f_new, K, P)
    if stats[S_H_FIRST] > 0.0:
        h = stats[S_H_FIRST]
    return code, h


@kernel("void(float64[::1], float64, float64)")
def _start_tangent(y6, q, v):
    y6[0] = q
    y6[1] = v
    y6[2] = 1.0
    y6[3] = 0.0
    y6[4] = 0.0
    y6[5] = 1.0


@kernel("UniTuple(float64, 3)(float64[::1], float64[::1], float64, float64)")
def _tangent_step(y6, w, zeta, T):
    """w <- M w / |M w| with M = Phi_T's Jacobian in y6[2:6]; returns (log |M w|, Liouville
    error of M: |det M - exp(-2 zeta T)| relative to what a 2x2 determinant resolves,
    log |det M|: the growth of an area, whose mean per unit tau is the sum of both Lyapunov
    exponents, -2 zeta exactly (Liouville's formula; Benettin with two vectors in the plane))."""
    m11, m12, m21, m22 = y6[2], y6[3], y6[4], y6[5]
    a = m11 * w[0] + m12 * w[1]
    b = m21 * w[0] + m22 * w[1]
    g = hypot(a, b)
    w[0] = a / g
    w[1] = b / g
    liou = exp(-2.0 * zeta * T)
    det = m11 * m22 - m12 * m21
    return (log(g), abs(det - liou) / max(liou, abs(m11 * m22) + abs(m12 * m21), 1e-300),
            log(abs(det)))


@kernel("void(float64[::1], int64, float64, float64, float64, float64[::1])")
def _block_statistics(blocks, nb, tau_per_block, total_log, total_tau, out):
    """out[0..2] = (lambda, standard error over the nb blocks, |first half - second half|)."""
    lam = total_log / total_tau
    out[0] = lam
    if nb >= 2:
        mean = 0.0
        for b in range(nb):
            mean += blocks[b] / tau_per_block
        mean /= nb
        var = 0.0
        for b in range(nb):
            d = blocks[b] / tau_per_block - mean
            var += d * d
        out[1] = sqrt(var / (nb - 1) / nb)
        half = nb // 2
        first = 0.0
        second = 0.0
        for b in range(half):
            first += blocks[b]
        for b in range(half, 2 * half):
            second += blocks[b]
        out[2] = abs(first - second) / (half * tau_per_block)
    else:
        out[1] = np.nan
        out[2] = np.nan


# ---- the stand-alone exponent ----------------------------------------------------------------

@kernel("void(float64, float64, float64, float64, float64, float64, int64, int64, int64, float64, float64, int64, float64[::1])")
def lyapunov_into(omega, sigma, zeta, q0, v0, n, model, periods, discard, rtol, atol, max_steps,
                  out):
    """Largest Lyapunov exponent (per unit tau) of paper Eq. 7 along the trajectory from
    (q0, v0) at tau = 0 by Benettin's method (module docstring): ``discard`` periods to align
    the tangent vector, then ``periods`` periods averaged. out (LYAPUNOV_FIELDS) gets the
    status, the exponent, its standard error over N_BLOCKS blocks, the halves' difference, the
    periods used, the worst Liouville error, the final state and the integrator steps."""
    for i in range(out.shape[0]):
        out[i] = np.nan
    T = 2.0 * pi / omega
    y6, f, y_new, f_new, K, P, stats, harm = integrator_scratch(6)
    no_eval = np.empty(0)
    out_none = np.empty((3, 0))
    w = np.array([1.0, 1.0]) / sqrt(2.0)
    blocks = np.zeros(N_BLOCKS)
    per_block = max(1, periods // N_BLOCKS)
    q, v = q0, v0
    h = min(0.1, T / 16.0)
    total = 0.0
    area = 0.0
    liou_worst = 0.0
    code = st.CONVERGED
    done = 0
    if not (omega > 0.0 and np.isfinite(omega) and periods >= 1 and discard >= 0):
        out[0] = st.DIVERGED
        return
    for k in range(discard + periods):
        _start_tangent(y6, q, v)
        code, h = _period(y6, T, omega, sigma, zeta, n, model, rtol, atol, h, max_steps, False,
                          no_eval, out_none, stats, harm, f, y_new, f_new, K, P)
        if code != st.CONVERGED:
            break
        g, e, log_area = _tangent_step(y6, w, zeta, T)
        if not np.isfinite(g):
            code = st.DIVERGED
            break
        q, v = y6[0], y6[1]
        if k >= discard:
            j = k - discard
            total += g
            area += log_area
            done += 1
            b = j // per_block
            if b < N_BLOCKS:
                blocks[b] += g
            if e > liou_worst:
                liou_worst = e
    out[0] = code
    out[6] = q
    out[7] = v
    out[8] = stats[S_ACCEPTED] + stats[S_REJECTED] + stats[S_PARTIAL]
    if done > 0:
        tmp = np.empty(3)
        full = periods >= N_BLOCKS and done >= N_BLOCKS * per_block
        _block_statistics(blocks, N_BLOCKS if full else 0, per_block * T, total, done * T, tmp)
        out[1] = tmp[0]
        out[2] = tmp[1]
        out[3] = tmp[2]
        out[4] = done
        out[5] = liou_worst
        out[9] = abs(area / (done * T) + 2.0 * zeta)


# ---- measures over a window --------------------------------------------------------------

@kernel("void(float64[::1])")
def _window_start(acc):
    """acc: (flight time, max impact, min q, max q, sum F, sum F^2, samples, q0, v0, tau)."""
    acc[0] = 0.0
    acc[1] = 0.0
    acc[2] = np.inf
    acc[3] = -np.inf
    acc[4] = 0.0
    acc[5] = 0.0
    acc[6] = 0.0
    acc[9] = 0.0


@kernel("void(float64[::1], float64[::1], float64[:, ::1], float64)")
def _window_add(acc, stats, out_eval, T):
    """Fold one measured period into acc (stats as left by integrate with ``measure``)."""
    acc[0] += stats[S_FLIGHT_TIME]
    stats[S_FLIGHT_TIME] = 0.0
    if stats[S_MAX_IMPACT] > acc[1]:
        acc[1] = stats[S_MAX_IMPACT]
    stats[S_MAX_IMPACT] = 0.0
    if stats[S_MIN_Q] < acc[2]:
        acc[2] = stats[S_MIN_Q]
    if stats[S_MAX_Q] > acc[3]:
        acc[3] = stats[S_MAX_Q]
    for j in range(out_eval.shape[1]):
        Fj = out_eval[2, j]
        acc[4] += Fj
        acc[5] += Fj * Fj
    acc[6] += out_eval.shape[1]
    acc[9] += T


@kernel("void(float64[::1], float64, float64, float64, float64, int64, float64[::1])")
def _window_finish(acc, q1, v1, zeta, n, model, row):
    tau = acc[9]
    row[A_FLIGHT] = acc[0] / tau
    row[A_IMPACT] = acc[1]
    row[A_MINQ] = acc[2]
    row[A_MAXQ] = acc[3]
    row[A_PEAKF] = rhs_force(acc[3], n, model)
    mean = acc[4] / acc[6]
    row[A_MEANF] = mean
    row[A_RMSF] = sqrt(acc[5] / acc[6])
    # Eq. 7 integrated over whole periods: the forcing's mean is 0
    exact = 1.0 - ((v1 - acc[8]) + 2.0 * zeta * (q1 - acc[7])) / tau
    row[A_QUAD_ERR] = abs(mean - exact)


@kernel("void(float64, int64, float64[::1])")
def _sample_times(T, count, t_eval):
    for j in range(count):
        t_eval[j] = (j + 1) * T / count
    t_eval[count - 1] = T


# ---- the attractor from one initial state -------------------------------------------------

@kernel("boolean(float64, float64, float64, int64, float64, float64, float64, int64, float64, int64, boolean, float64[::1], float64, float64[::1])", inline="ir")
def _confirm(omega, sigma, zeta, m, q, v, n, model, shoot_rtol, max_steps, harmonics, orbit,
             near, row):
    """Shoot period m from (q, v): True when it converged to a stable orbit of minimal period m
    within ``near`` of (q, v) (orbit row filled either way; one more refinement in row)."""
    row[A_REFINE] += 1.0
    row[A_ORBIT_PERIOD] = m
    shoot_into(omega, sigma, zeta, m, q, v, n, model, shoot_rtol, shoot_rtol, 40, 1.0,
               max_steps, harmonics, orbit)
    if orbit[I_STATUS] != st.CONVERGED:
        return False
    if orbit[I_MINPER] != m or orbit[I_STABLE] != 1.0:
        return False
    return hypot(orbit[I_Q0] - q, orbit[I_V0] - v) <= near


@kernel("boolean(float64[::1])")
def _flip_unstable(orbit):
    """A converged orbit that lost stability through a flip (a real multiplier below -1)."""
    return (orbit[I_STATUS] == st.CONVERGED and orbit[I_M1I] == 0.0
            and (orbit[I_M1R] < -1.0 or orbit[I_M2R] < -1.0))


@kernel("void(float64, float64, float64, float64, float64, float64, int64, int64, int64, boolean, int64, int64, float64, int64, float64, float64, float64, int64, boolean, float64[:, ::1], int64[::1], int64[::1], float64[::1], float64[:, ::1], int64[::1], int64, float64[::1], float64[::1], float64[:, ::1])", inline="ir")
def attractor_into(omega, sigma, zeta, q0, v0, n, model, transient_periods, record_periods,
                   lyapunov, lyapunov_discard, force_samples, cycle_tol, cycle_repeats, rtol,
                   atol, shoot_rtol, max_steps, harmonics, known, known_label, cell_start,
                   grid, cert, cert_label, own_label, row, orbit, strobe):
    """The long-time response of paper Eq. 7 from (q0, v0) at tau = 0 (module docstring).

    Inputs (dimensionless): omega > 0, sigma >= 0, zeta >= 0, n > 0, model (kernels.model);
    the budget transient_periods >= 0 + record_periods >= 1 forcing periods (the record window:
    strobe points, measures and, with ``lyapunov``, Benettin's exponent after
    ``lyapunov_discard`` periods); force_samples per period (0: spacing FORCE_DT in tau, at
    least 32); cycle_tol, cycle_repeats: the detection test; rtol/atol: the transient's
    integrator tolerances; shoot_rtol: the refinement's; max_steps per period; harmonics: the
    refined orbit's contact-force harmonics (kernels.shooting).

    Recognition (known, known_label, cell_start, grid: the known attractors' stroboscopic
    points, see known_near; none when known has no rows): the transient stops as soon as its
    stroboscopic points have stayed within tolerance of the points of one known attractor
    (label) other than ``own_label`` for that point's K_VISITS consecutive periods; the row's
    status is then RECOGNISED and its recognised_as the label (no measures: the attractor's
    own transient has them). Certified stable orbits (cert, cert_label: rows of C_* columns,
    none when cert has no rows): the transient is on one once its stroboscopic point lies in
    the orbit's certified neighbourhood V(x) <= c (the sublevel set where the orbit's m-period
    map was shown to contract V by kappa: study.solve.certificate) and, m periods later, lies
    there again with V decreased by at least kappa: the contraction its multipliers predict,
    seen on the transient itself.

    Outputs: row (ATTRACTOR_FIELDS), orbit (kernels.shooting.FIELDS: the refined orbit, NaN if
    none was tried), strobe (cap, 2): the last min(strobe_count, cap) stroboscopic points in
    order (the whole budget's points when they fit).
    """
    for i in range(row.shape[0]):
        row[i] = np.nan
    for i in range(orbit.shape[0]):
        orbit[i] = np.nan
    row[A_PERIOD] = 0.0
    row[A_RUN] = 0.0
    row[A_REFINE] = 0.0
    row[A_ORBIT_PERIOD] = 0.0
    row[A_STROBE_COUNT] = 0.0
    if not (omega > 0.0 and np.isfinite(omega) and sigma >= 0.0 and np.isfinite(sigma)
            and zeta >= 0.0 and np.isfinite(zeta) and n > 0.0 and np.isfinite(q0)
            and np.isfinite(v0) and transient_periods >= 0 and record_periods >= 1
            and cycle_repeats >= 1 and cycle_repeats <= MAX_REPEATS and cycle_tol > 0.0):
        row[A_STATUS] = st.DIVERGED
        return
    T = 2.0 * pi / omega
    y, f, y_new, f_new, K, P, stats, harm = integrator_scratch(2)
    y6, f6, y6_new, f6_new = state_arrays(6)
    no_eval = np.empty(0)
    out_none = np.empty((3, 0))
    ns = force_samples if force_samples > 0 else max(32, int(np.ceil(T / FORCE_DT)))
    t_samp = np.empty(ns)
    _sample_times(T, ns, t_samp)
    out_samp = np.empty((3, ns))
    ring = np.empty((max(RING, strobe.shape[0]), 2))
    cap = ring.shape[0]
    acc = np.zeros(10)
    w = np.array([1.0, 1.0]) / sqrt(2.0)
    blocks = np.zeros(N_BLOCKS)
    lyap_periods = record_periods - lyapunov_discard
    per_block = max(1, lyap_periods // N_BLOCKS)
    lyap_total = 0.0
    lyap_area = 0.0
    lyap_done = 0
    liou_worst = 0.0

    y[0] = q0
    y[1] = v0
    ring[0, 0] = q0
    ring[0, 1] = v0
    count = 1
    h = min(0.1, T / 16.0)
    budget = transient_periods + record_periods
    next_check = 0
    fails = 0
    code = st.CONVERGED
    settled = False
    last_m = 0
    last_res = np.inf
    recognising = known.shape[0] > 0
    recognised = False
    streak = 0
    streak_label = NO_LABEL
    n_cert = cert.shape[0]
    # per certified orbit: the period the transient last entered its neighbourhood (-1: not
    # inside) and V there
    entered = np.full(max(n_cert, 1), -1, np.int64)
    entered_v = np.zeros(max(n_cert, 1))
    k = 0
    while k < budget:
        recording = k >= transient_periods
        if recording and k == transient_periods:
            _window_start(acc)
            acc[7] = y[0]
            acc[8] = y[1]
        if recording and lyapunov:
            _start_tangent(y6, y[0], y[1])
            code, h = _period(y6, T, omega, sigma, zeta, n, model, rtol, atol, h, max_steps,
                              True, t_samp, out_samp, stats, harm, f6, y6_new, f6_new, K, P)
            y[0] = y6[0]
            y[1] = y6[1]
        elif recording:
            code, h = _period(y, T, omega, sigma, zeta, n, model, rtol, atol, h, max_steps,
                              True, t_samp, out_samp, stats, harm, f, y_new, f_new, K, P)
        else:
            code, h = _period(y, T, omega, sigma, zeta, n, model, rtol, atol, h, max_steps,
                              False, no_eval, out_none, stats, harm, f, y_new, f_new, K, P)
        k += 1
        if code != st.CONVERGED:
            break
        if recording:
            _window_add(acc, stats, out_samp, T)
            if lyapunov:
                g, e, log_area = _tangent_step(y6, w, zeta, T)
                if not np.isfinite(g):
                    code = st.DIVERGED
                    break
                j = k - 1 - transient_periods - lyapunov_discard
                if j >= 0:
                    lyap_total += g
                    lyap_area += log_area
                    lyap_done += 1
                    b = j // per_block
                    if b < N_BLOCKS:
                        blocks[b] += g
                    if e > liou_worst:
                        liou_worst = e
        ring[count % cap, 0] = y[0]
        ring[count % cap, 1] = y[1]
        count += 1
        if n_cert > 0:
            for e in range(n_cert):
                if cert_label[e] == own_label:
                    continue
                m_e = int(cert[e, C_PERIOD])
                dq = y[0] - cert[e, C_Q]
                dv = y[1] - cert[e, C_V]
                value = (cert[e, C_P11] * dq * dq + 2.0 * cert[e, C_P12] * dq * dv
                         + cert[e, C_P22] * dv * dv)
                if value <= cert[e, C_LEVEL]:
                    if entered[e] >= 0 and k - entered[e] == m_e \
                            and value <= cert[e, C_KAPPA] * entered_v[e]:
                        recognised = True
                        streak_label = cert_label[e]
                        break
                    if entered[e] < 0 or k - entered[e] >= m_e:
                        entered[e] = k
                        entered_v[e] = value
                elif entered[e] >= 0 and k - entered[e] >= m_e:
                    entered[e] = -1
            if recognised:
                break
        if recognising:
            near = known_near(known, known_label, cell_start, grid, own_label, y[0], y[1])
            if near < 0:
                streak = 0
                streak_label = NO_LABEL
            else:
                if known_label[near] == streak_label:
                    streak += 1
                else:
                    streak = 1
                    streak_label = known_label[near]
                if streak >= known[near, K_VISITS]:
                    recognised = True
                    break
        if k < next_check or fails >= MAX_REFINEMENTS:
            continue
        m, res = detect_period(ring, count, M_MAX, cycle_tol, cycle_repeats)
        if m == 0:
            continue
        last_m = m
        last_res = res
        scale = 1.0 + hypot(y[0], y[1])
        near = max(1e3 * cycle_tol, 1e-3) * scale
        ok = _confirm(omega, sigma, zeta, m, y[0], y[1], n, model, shoot_rtol, max_steps,
                      harmonics, orbit, near, row)
        if not ok and _flip_unstable(orbit) and 2 * m <= M_MAX:
            # points that repeat with period m to tol can be a period-2m orbit just past a flip
            # of the m-orbit (its two halves closer than tol)
            ok = _confirm(omega, sigma, zeta, 2 * m, y[0], y[1], n, model, shoot_rtol,
                          max_steps, harmonics, orbit, near, row)
            if ok:
                last_m = 2 * m
        if ok:
            settled = True
            break
        fails += 1
        next_check = k + 16 * (1 << fails)

    if code == st.CONVERGED and not settled and not recognised:
        # the budget is spent: one last look at the points (a cycle that appeared while the
        # checks were backed off is still refined)
        m, res = detect_period(ring, count, M_MAX, cycle_tol, cycle_repeats)
        last_m = m
        last_res = res
        if m > 0:
            near = max(1e3 * cycle_tol, 1e-3) * (1.0 + hypot(y[0], y[1]))
            settled = _confirm(omega, sigma, zeta, m, y[0], y[1], n, model, shoot_rtol,
                               max_steps, harmonics, orbit, near, row)

    # ---- results --------------------------------------------------------------------------
    row[A_RUN] = k
    row[A_QEND] = y[0]
    row[A_VEND] = y[1]
    row[A_STEPS] = stats[S_ACCEPTED] + stats[S_REJECTED] + stats[S_PARTIAL]
    row[A_REJ] = stats[S_REJECTED]
    row[A_EVENTS] = stats[S_EVENTS]
    kept = min(count, strobe.shape[0])
    for j in range(kept):
        src = (count - kept + j) % cap
        strobe[j, 0] = ring[src, 0]
        strobe[j, 1] = ring[src, 1]
    row[A_STROBE_COUNT] = kept
    if code != st.CONVERGED:
        row[A_STATUS] = code
        return
    if recognised:
        row[A_STATUS] = st.RECOGNISED
        row[A_RECOGNISED] = streak_label
        return
    if settled:
        m = last_m
        row[A_PERIOD] = m
        row[A_SETTLED] = k
        row[A_CYCLE_RES] = last_res
        # the orbit's exponent from its multipliers: exact where Benettin only converges
        rho = max(hypot(orbit[I_M1R], orbit[I_M1I]), hypot(orbit[I_M2R], orbit[I_M2I]))
        row[A_LYAP] = log(rho) / (m * T)
        row[A_LYAP_PERIODS] = 0.0
        # both exponents from the multipliers: their sum log|mu1 mu2| / (m T) is -2 zeta
        mu_product = hypot(orbit[I_M1R], orbit[I_M1I]) * hypot(orbit[I_M2R], orbit[I_M2I])
        row[A_LYAP_SUM] = abs(log(mu_product) / (m * T) + 2.0 * zeta)
        # measures over one period of the orbit, by the same integration as a record window
        y[0] = orbit[I_Q0]
        y[1] = orbit[I_V0]
        _window_start(acc)
        acc[7] = y[0]
        acc[8] = y[1]
        hm = min(0.1, T / 16.0)
        mstats = np.zeros(N_STATS)
        for _ in range(m):
            code, hm = _period(y, T, omega, sigma, zeta, n, model, shoot_rtol, shoot_rtol, hm,
                               max_steps, True, t_samp, out_samp, mstats, harm, f, y_new, f_new,
                               K, P)
            if code != st.CONVERGED:
                break
            _window_add(acc, mstats, out_samp, T)
        if code != st.CONVERGED:
            row[A_STATUS] = code
            return
        _window_finish(acc, y[0], y[1], zeta, n, model, row)
        row[A_WINDOW] = m
        row[A_STATUS] = st.CONVERGED
        return
    # the budget is spent: the record window describes the response
    window = k - transient_periods
    if window > 0:
        _window_finish(acc, y[0], y[1], zeta, n, model, row)
        row[A_WINDOW] = window
    if lyapunov and lyap_done > 0:
        tmp = np.empty(3)
        full = lyap_done >= N_BLOCKS * per_block and lyap_periods >= N_BLOCKS
        _block_statistics(blocks, N_BLOCKS if full else 0, per_block * T, lyap_total,
                          lyap_done * T, tmp)
        row[A_LYAP] = tmp[0]
        row[A_LYAP_ERR] = tmp[1]
        row[A_LYAP_HALVES] = tmp[2]
        row[A_LYAP_PERIODS] = lyap_done
        row[A_LIOU] = liou_worst
        row[A_LYAP_SUM] = abs(lyap_area / (lyap_done * T) + 2.0 * zeta)
    if last_m > 0:
        row[A_PERIOD] = last_m
        row[A_CYCLE_RES] = last_res
        row[A_STATUS] = st.UNCONFIRMED
    else:
        row[A_STATUS] = st.UNSETTLED


#: The most cells along each axis of the grid over known points (larger sides beyond it)
KNOWN_GRID_CELLS = 128


def known_attractors(points, labels, tol, visits, certified=(), certified_labels=()):
    """The arrays attractor_into recognises known attractors by (known, known_label,
    cell_start, grid; see known_near; then cert, cert_label) from stroboscopic points (n, 2),
    each with its attractor's label, tolerance (distance in the (q, q') plane) and consecutive
    visits, and from ``certified`` stable orbits (rows of the C_* columns) with their labels.
    No points and no certified orbits: nothing is recognised."""
    cert = np.ascontiguousarray(np.asarray(certified, float).reshape(-1, N_CERT_FIELDS))
    cert_label = np.ascontiguousarray(np.asarray(certified_labels, np.int64).reshape(-1))
    return _known_points(points, labels, tol, visits) + (cert, cert_label)


def _known_points(points, labels, tol, visits):
    points = np.asarray(points, float).reshape(-1, 2)
    n = points.shape[0]
    labels = np.broadcast_to(np.asarray(labels, np.int64), (n,))
    tol = np.broadcast_to(np.asarray(tol, float), (n,))
    visits = np.broadcast_to(np.asarray(visits, float), (n,))
    if n == 0:
        return (np.empty((0, N_KNOWN_FIELDS)), np.empty(0, np.int64), np.zeros(2, np.int64),
                np.array([0.0, 0.0, 1.0, 1.0]))
    lo = points.min(axis=0) - tol.max()
    span = points.max(axis=0) + tol.max() - lo
    side = max(float(tol.max()), float(span.max()) / KNOWN_GRID_CELLS, 1e-300)
    nq, nv = (np.floor(span / side).astype(np.int64) + 1)
    cells = (np.floor((points[:, 0] - lo[0]) / side).astype(np.int64) * nv
             + np.floor((points[:, 1] - lo[1]) / side).astype(np.int64))
    order = np.argsort(cells, kind="stable")
    known = np.empty((n, N_KNOWN_FIELDS))
    known[:, K_Q], known[:, K_V] = points[order, 0], points[order, 1]
    known[:, K_TOL], known[:, K_VISITS] = tol[order], visits[order]
    cell_start = np.zeros(nq * nv + 1, np.int64)
    np.cumsum(np.bincount(cells, minlength=nq * nv), out=cell_start[1:])
    return (known, np.ascontiguousarray(labels[order]), cell_start,
            np.array([lo[0], lo[1], side, float(nq)]))


@kernel("void(float64, float64, float64, float64[::1], float64[::1], float64, int64, int64, int64, "
        "boolean, int64, int64, float64, int64, float64, float64, float64, int64, boolean, "
        "float64[:, ::1], int64[::1], int64[::1], float64[::1], float64[:, ::1], int64[::1], "
        "int64, float64[:, ::1], float64[:, ::1], float64[:, :, ::1])")
def attractor_batch_into(omega, sigma, zeta, q0, v0, n, model, transient_periods,
                         record_periods, lyapunov, lyapunov_discard, force_samples, cycle_tol,
                         cycle_repeats, rtol, atol, shoot_rtol, max_steps, harmonics, known,
                         known_label, cell_start, grid, cert, cert_label, own_label, rows,
                         orbits, strobes):
    """attractor_into for each initial state (q0[i], v0[i]) at one parameter point, with the
    same known attractors to recognise: rows (k, N_ATTRACTOR_FIELDS), orbits (k, N_FIELDS),
    strobes (k, cap, 2).

    The census's one compiled entry point (attractor_into is copied into it);
    kernels.attractor calls it with k = 1. Every compiled entry point carries its own
    optimised copy of the integrator and of the shooting code (kernels._jit)."""
    for i in range(q0.shape[0]):
        attractor_into(omega, sigma, zeta, q0[i], v0[i], n, model, transient_periods,
                       record_periods, lyapunov, lyapunov_discard, force_samples, cycle_tol,
                       cycle_repeats, rtol, atol, shoot_rtol, max_steps, harmonics, known,
                       known_label, cell_start, grid, cert, cert_label, own_label, rows[i],
                       orbits[i], strobes[i])

