"""The extended system of a fold, flip or grazing curve, compiled, and its chord corrector
(kernels.continuation.curve traces the curves with it).

Unknowns u = (q, q', a, b), (a, b) two of (omega, sigma, zeta), the third fixed; equations

    Phi_{mT}(x; p) - x = 0,    g(x, p) = 0,

g the fold function 1 - tr M + det M, the flip function 1 + tr M + det M (of the period-m
monodromy: m = 2 gives the 2T -> 4T flips) or the grazing function min q + n (min over the
orbit's period; an interior minimum, so a smooth function of (x, p) where one local minimum is
the lowest). The Jacobian's Phi rows take the exact monodromy M for the x columns and forward
differences for the parameter columns; the g row is a forward difference in all four
(kernels.continuation.core.CURVE_DIFFERENCE). The corrector is a chord method: the Jacobian is
built once at the predicted point (5 period maps) and kept while the corrections contract (one
map per iteration), rebuilt once if they stop contracting. A vertex costs about 8 period maps
where a full Newton with central differences costs 9 per iteration. Dimensionless (paper Eq. 7
/ 11).
"""
from __future__ import annotations

from math import pi
from typing import NamedTuple

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels._jit import kernel
from hertzmap.kernels.continuation.core import CURVE_DIFFERENCE, period_map_into
from hertzmap.kernels.integrate import S_MAX_Q, S_MIN_Q, integrator_scratch
from hertzmap.kernels.model import check_exponent, contact_loss_level, model_code
from hertzmap.kernels.shooting import _measure_pass

CURVE_PARAMS = ("omega", "sigma", "zeta")
CURVE_KINDS = ("fold", "flip", "grazing")      # codes 0, 1, 2 in the compiled evaluator
_KIND_FOLD, _KIND_FLIP, _KIND_GRAZING = 0, 1, 2

CURVE_XTOL = 1e-11       # |du| <= CURVE_XTOL (1 + |u|): the corrections contract by >= 1e3
CURVE_MAX_ITER = 12      # corrector iterations per vertex (the Jacobian rebuilt at most once)
CURVE_FTOL = 1e-8        # a converged vertex solves the equations to this (1 + |u|) (~1e-11)


@kernel("int64(float64, float64, float64, float64, float64, int64, int64, float64, int64, float64, float64, int64, boolean, float64, float64[::1])", inline="ir")
def _phi_g(q, v, omega, sigma, zeta, m, kind, n, model, rtol, atol, max_steps, measure, level,
           out):
    """One period map with the orbit's test function: out[0:2] = Phi_{mT}(q, v), out[2:6] = M
    (m11, m12, m21, m22), out[6] = g (fold, flip or grazing), out[7] = min q, out[8] = max q
    (NaN unless ``measure``; the grazing kind always measures). Returns the integrator
    status. Without the measures, the map is period_map_into's."""
    for i in range(9):
        out[i] = np.nan
    if not (omega > 0.0 and sigma >= 0.0 and zeta >= 0.0 and np.isfinite(q) and np.isfinite(v)
            and np.isfinite(omega) and np.isfinite(sigma) and np.isfinite(zeta)):
        return st.DIVERGED
    if measure or kind == _KIND_GRAZING:
        y, f, y_new, f_new, K, W, stats, harm = integrator_scratch(6)
        P = m * 2.0 * pi / omega
        h = min(0.1, P / 16.0)
        code = _measure_pass(q, v, P, omega, sigma, zeta, n, model, rtol, atol, h, max_steps, y,
                             stats, False, harm, np.empty(0), np.empty((3, 0)), f, y_new, f_new,
                             K, W)
        for i in range(6):
            out[i] = y[i]
        out[7] = stats[S_MIN_Q]
        out[8] = stats[S_MAX_Q]
    else:
        code = period_map_into(q, v, omega, sigma, zeta, m, n, model, rtol, atol, max_steps, out)
    tr = out[2] + out[5]
    det = out[2] * out[5] - out[3] * out[4]
    if kind == _KIND_FOLD:
        out[6] = 1.0 - tr + det
    elif kind == _KIND_FLIP:
        out[6] = 1.0 + tr + det
    else:
        out[6] = out[7] - level
    return code


@kernel("void(float64[::1], int64, int64, float64, float64[::1])", inline="ir")
def _curve_params(u, pa, pb, fixed, p):
    for i in range(3):
        p[i] = fixed
    p[pa] = u[2]
    p[pb] = u[3]


@kernel("int64(float64[::1], int64, int64, float64, int64, int64, float64, int64, float64, float64, int64, float64, boolean, float64, float64[::1], float64[:, ::1], float64[::1])")
def curve_system_into(u, pa, pb, fixed, kind, m, n, model, rtol, atol, max_steps, level, jac,
                      fd_step, F, J, aux):
    """The extended system of a fold / flip / grazing curve at u = (q, q', p[pa], p[pb]), the
    third parameter (p = (omega, sigma, zeta)) at ``fixed``: F (3,) = (Phi(x) - x, g); with
    ``jac`` the Jacobian J (3, 4) (exact M in the x columns of the Phi rows, forward differences
    elsewhere); aux (7,) = (m11, m12, m21, m22, min q, maps used, max q). Returns the integrator status
    of the first failing map (0 when all converged)."""
    p = np.empty(3)
    out = np.empty(9)
    out2 = np.empty(9)
    _curve_params(u, pa, pb, fixed, p)
    code = _phi_g(u[0], u[1], p[0], p[1], p[2], m, kind, n, model, rtol, atol, max_steps, True,
                  level, out)
    aux[5] = 1.0
    if code != st.CONVERGED:
        return code
    F[0] = out[0] - u[0]
    F[1] = out[1] - u[1]
    F[2] = out[6]
    for i in range(4):
        aux[i] = out[2 + i]
    aux[4] = out[7]
    aux[6] = out[8]
    if not jac:
        return code
    J[0, 0] = out[2] - 1.0
    J[0, 1] = out[3]
    J[1, 0] = out[4]
    J[1, 1] = out[5] - 1.0
    up = np.empty(4)
    for j in range(4):
        for i in range(4):
            up[i] = u[i]
        hj = fd_step * (1.0 + abs(u[j]))
        up[j] += hj
        _curve_params(up, pa, pb, fixed, p)
        c2 = _phi_g(up[0], up[1], p[0], p[1], p[2], m, kind, n, model, rtol, atol, max_steps,
                    False, level, out2)
        aux[5] += 1.0
        if c2 != st.CONVERGED:
            return c2
        if j >= 2:
            J[0, j] = (out2[0] - out[0]) / hj
            J[1, j] = (out2[1] - out[1]) / hj
        J[2, j] = (out2[6] - out[6]) / hj
    return code


class CurveSystem:
    """The compiled extended system with its fixed arguments, counting the maps it costs."""

    def __init__(self, kind, m, pair, fixed, exponent, model, rtol, max_steps):
        self.kind_code = CURVE_KINDS.index(kind)
        self.m = int(m)
        self.pa, self.pb = (CURVE_PARAMS.index(pair[0]), CURVE_PARAMS.index(pair[1]))
        self.fixed = float(fixed)
        self.n = check_exponent(exponent)
        self.model_code = model_code(model)
        self.model = model
        self.rtol = float(rtol)
        self.max_steps = int(max_steps)
        self.level = float(contact_loss_level(model, self.n))
        self.maps = 0

    def params(self, u):
        p = np.full(3, self.fixed)
        p[self.pa] = u[2]
        p[self.pb] = u[3]
        return p

    def __call__(self, u, jac):
        """(F, J or None, aux) at u, or None when a map fails."""
        F = np.empty(3)
        J = np.empty((3, 4))
        aux = np.empty(7)
        code = curve_system_into(np.ascontiguousarray(u, dtype=np.float64), self.pa, self.pb,
                                 self.fixed, self.kind_code, self.m, self.n, self.model_code,
                                 self.rtol, self.rtol, self.max_steps, self.level, bool(jac),
                                 CURVE_DIFFERENCE.relative_step, F, J, aux)
        self.maps += int(aux[5])
        if code != st.CONVERGED or not np.all(np.isfinite(F)) or (
                jac and not np.all(np.isfinite(J))):
            return None
        return F, (J if jac else None), aux

    def shift(self, u, m=1):
        """Phi_{mT}(x) at u's parameters (the T-shift of a 2T start point), or None."""
        out = np.empty(6)
        w, s, z = self.params(u)
        code = period_map_into(float(u[0]), float(u[1]), w, s, z, int(m), self.n,
                               self.model_code, self.rtol, self.rtol, self.max_steps, out)
        self.maps += 1
        return out[:2].copy() if code == st.CONVERGED else None


@kernel("boolean(float64[:, ::1], float64[::1], float64[::1])", inline="ir")
def _solve4(A, b, x):
    """x = A^-1 b for a 4x4 system by Gaussian elimination with partial pivoting (A and b are
    overwritten). False when a pivot vanishes or the result is not finite."""
    for k in range(4):
        p = k
        for i in range(k + 1, 4):
            if abs(A[i, k]) > abs(A[p, k]):
                p = i
        if A[p, k] == 0.0 or not np.isfinite(A[p, k]):
            return False
        if p != k:
            for j in range(4):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            b[k], b[p] = b[p], b[k]
        for i in range(k + 1, 4):
            f = A[i, k] / A[k, k]
            for j in range(k, 4):
                A[i, j] -= f * A[k, j]
            b[i] -= f * b[k]
    for k in range(3, -1, -1):
        acc = b[k]
        for j in range(k + 1, 4):
            acc -= A[k, j] * x[j]
        x[k] = acc / A[k, k]
        if not np.isfinite(x[k]):
            return False
    return True


@kernel("int64(float64[::1], float64[::1], float64[:, ::1], boolean, int64, int64, float64, int64, int64, float64, int64, float64, float64, int64, float64, float64, int64, float64, boolean, float64[::1], float64[::1], float64[::1], float64[::1])")
def _chord_into(u_pred, normal, J, have_J, pa, pb, fixed, kind, m, n, model, rtol, atol,
                max_steps, level, fd_step, max_iter, xtol, broyden, u, F, aux, maps):
    """Corrector on F(u) = 0, normal . (u - u_pred) = 0 (see :func:`chord_correct`), compiled: u, F,
    aux and J are updated in place, maps[0] counts the period maps. Returns the iterations
    (>= 1) on convergence, -1 on failure."""
    A = np.empty((4, 4))
    b = np.empty(4)
    du = np.empty(4)
    Jn = np.empty((3, 4))
    F_old = np.empty(3)
    for i in range(4):
        u[i] = u_pred[i]
    code = curve_system_into(u, pa, pb, fixed, kind, m, n, model, rtol, atol, max_steps, level,
                             not have_J, fd_step, F, Jn, aux)
    maps[0] += aux[5]
    if code != st.CONVERGED:
        return -1
    if not have_J:
        for i in range(3):
            for j in range(4):
                J[i, j] = Jn[i, j]
    J[0, 0], J[0, 1], J[1, 0], J[1, 1] = aux[0] - 1.0, aux[1], aux[2], aux[3] - 1.0
    rebuilds = 0
    prev = np.inf
    for it in range(1, max_iter + 1):
        r_norm = 0.0
        for j in range(4):
            r_norm += normal[j] * (u[j] - u_pred[j])
        for i in range(3):
            for j in range(4):
                A[i, j] = J[i, j]
            b[i] = -F[i]
        for j in range(4):
            A[3, j] = normal[j]
        b[3] = -r_norm
        if not _solve4(A, b, du):
            return -1
        nd = 0.0
        nu = 0.0
        for j in range(4):
            u[j] += du[j]
            nd += du[j] * du[j]
            nu += u[j] * u[j]
        nd = np.sqrt(nd)
        nu = np.sqrt(nu)
        if nd > 1.0 + nu:                       # runaway
            return -1
        slow = nd > prev / 3.0
        rebuild = slow and rebuilds == 0
        for i in range(3):
            F_old[i] = F[i]
        code = curve_system_into(u, pa, pb, fixed, kind, m, n, model, rtol, atol, max_steps,
                                 level, rebuild, fd_step, F, Jn, aux)
        maps[0] += aux[5]
        if code != st.CONVERGED:
            return -1
        ok = True
        for i in range(3):
            if not np.isfinite(F[i]):
                ok = False
        if not ok:
            return -1
        if nd <= xtol * (1.0 + nu) or (slow and nd <= 1e-8 * (1.0 + nu)):
            # converged in u: the point must also solve the equations. At an exact tangency
            # with the surface (on a grazing curve) the integrated map can jump (0.37 once in
            # ~200 vertices of the fig03 scene's 2T grazing curve), and a tiny step then lands
            # on a point that is not an orbit: refused, the step is retried shorter
            fmax = 0.0
            for i in range(3):
                fmax = max(fmax, abs(F[i]))
            if fmax > CURVE_FTOL * (1.0 + nu):
                return -1
            return it
        if rebuild:
            for i in range(3):
                for j in range(4):
                    J[i, j] = Jn[i, j]
            rebuilds = 1
        else:
            if slow and nd > prev:
                return -1                       # diverging even with a fresh Jacobian
            if broyden:
                dd = nd * nd
                for i in range(3):
                    r = F[i] - F_old[i]
                    for j in range(4):
                        r -= J[i, j] * du[j]
                    for j in range(4):
                        J[i, j] += r * du[j] / dd
            J[0, 0], J[0, 1], J[1, 0], J[1, 1] = aux[0] - 1.0, aux[1], aux[2], aux[3] - 1.0
        prev = nd
    return -1


class ChordCorrection(NamedTuple):
    """A converged chord correction: the point, F and aux (curve_system_into's) at it, the
    Jacobian as last updated and the iterations."""

    u: np.ndarray
    F: np.ndarray
    aux: np.ndarray
    J: np.ndarray
    iterations: int


def chord_correct(system, u_pred, normal, J=None, max_iter=CURVE_MAX_ITER, xtol=CURVE_XTOL):
    """Corrector on F(u) = 0, normal . (u - u_pred) = 0 with a Jacobian ``J`` built once (at
    u_pred when None, else the one given) and then updated, not rebuilt: the Phi rows' x
    columns are the exact M - I of every map, the rest Broyden's rank-1 secant update. It is
    rebuilt by differences (once) where the corrections stop contracting by 3 or more.
    Converged at |du| <= xtol (1 + |u|), or at the integrator's noise floor (|du| <= 1e-8
    (1 + |u|) and no longer contracting: an ill-conditioned system, e.g. a 2T curve near the
    1T orbit). Returns a ChordCorrection or None."""
    u = np.empty(4)
    F = np.empty(3)
    aux = np.empty(7)
    Jw = np.empty((3, 4)) if J is None else np.array(J, float)
    maps = np.zeros(1)
    it = _chord_into(np.ascontiguousarray(u_pred, dtype=np.float64),
                     np.ascontiguousarray(normal, dtype=np.float64), Jw, J is not None,
                     system.pa, system.pb, system.fixed, system.kind_code, system.m, system.n,
                     system.model_code, system.rtol, system.rtol, system.max_steps,
                     system.level, CURVE_DIFFERENCE.relative_step, int(max_iter), float(xtol),
                     True, u, F, aux, maps)
    system.maps += int(maps[0])
    if it < 0:
        return None
    return ChordCorrection(u, F, aux, Jw, it)
