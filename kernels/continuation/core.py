"""The continuation problem and its one predictor-corrector (paper section 3.2): the period map
with its exact monodromy, the bifurcation test functions, the parameter derivatives, the Newton
corrector on the pseudo-arclength hyperplane, the tangent, the step.

Unknowns and equations
----------------------
A period-m orbit (m = 1: 1T, m = 2: 2T) is a fixed point x = (q, q') of the stroboscopic map
Phi_{mT}(x; omega, sigma), T = 2 pi / omega. One-parameter continuation (in omega or sigma) solves

    F(u) = Phi(x; p) - x = 0,    u = (q, q', p)

by pseudo-arclength: a tangent predictor u_k + h t_k and a Newton corrector on the hyperplane
t_k . (u - u_pred) = 0. The Jacobian is [M - I | dPhi/dp] with M the exact monodromy
(variational equations, kernels.shooting) and dPhi/dp by finite differences (the conventions
below). Continuation goes through folds (the arclength handles turning points) and through
loss of contact (the map and its monodromy are exact across the switches: the vector field is
continuous at q = -n).

Test functions, from the 2x2 monodromy M:

    fold     1 - tr M + det M = (1 - mu1)(1 - mu2)     (a multiplier +1)
    flip     1 + tr M + det M = (1 + mu1)(1 + mu2)     (a multiplier -1)
    grazing  min q + n   (Hertz; min q - q_c for the Taylor model, q_c = kernels.model.TAYLOR_CONTACT_LOSS, Eq. 12)

Steps: the pseudo-arclength step (predict_correct) with its length adapted to the corrector's
effort (adapt_step); and the natural-parameter predictor (natural_prediction: secant, then
quadratic, through the last vertices) for continuation in a parameter held by the corrector.

Users: kernels.continuation.branch (continue_orbit, switch_at_flip), .path (arc_path), .curve
(trace_curve, whose compiled extended system is kernels.continuation.extended_system) and
.extremum (continue_extremum: natural-parameter steps adapted to the predictor's miss).
Dimensionless throughout (paper Eq. 5-8). Pure: numpy over the numba shooting kernels.
"""
from __future__ import annotations

from dataclasses import dataclass
from math import pi
from typing import NamedTuple

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels._jit import kernel
from hertzmap.kernels.integrate import integrator_scratch
from hertzmap.kernels.model import (DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL, check_exponent,
                                    contact_loss_level, model_code)
from hertzmap.kernels.periodic_orbit import DEFAULT_MAX_STEPS, shoot
from hertzmap.kernels.shooting import _map

# ---- how a branch or a curve ends --------------------------------------------------------------
BOUNDARY = 0        # left the parameter window
CLOSED = 1          # came back to its start (an isola, or a closed curve)
BRANCH_POINT = 2    # a 2T branch met the 1T orbit (flip of the 1T orbit)
MAX_POINTS = 3      # point budget spent
STEP_FAIL = 4       # corrector failed down to the smallest step
START_FAIL = 5      # the start point did not converge
#: how a branch or a traced curve ends, by code (the stored curve_status_* flags of the traced
#: curves read it)
BRANCH_STATUS = {BOUNDARY: "boundary", CLOSED: "closed", BRANCH_POINT: "meets_1T_orbit",
                 MAX_POINTS: "max_points", STEP_FAIL: "step_fail", START_FAIL: "start_fail"}

#: the corrector's defaults (a branch's points): |du| <= XTOL (1 + |u|) in MAX_NEWTON iterations
XTOL = 1e-9
MAX_NEWTON = 8


@kernel("int64(float64, float64, float64, float64, float64, int64, float64, int64, float64, float64, int64, float64[::1])")
def period_map_into(q, v, omega, sigma, zeta, m, n, model, rtol, atol, max_steps, out):
    """Phi_{mT}(q, v) and its Jacobian M: out[0:2] = Phi, out[2:6] = (m11, m12, m21, m22).
    Returns the integrator status (kernels.status)."""
    for i in range(6):
        out[i] = np.nan
    if not (omega > 0.0 and sigma >= 0.0 and zeta >= 0.0 and m >= 1 and np.isfinite(q)
            and np.isfinite(v) and np.isfinite(omega) and np.isfinite(sigma)):
        return st.DIVERGED
    y, f, y_new, f_new, K, W, stats, harm = integrator_scratch(6)
    P = m * 2.0 * pi / omega
    h = min(0.1, P / 16.0)
    code = _map(q, v, P, omega, sigma, zeta, n, model, rtol, atol, h, max_steps, y, stats, harm,
                np.empty(0), np.empty((3, 0)), f, y_new, f_new, K, W)
    for i in range(6):
        out[i] = y[i]
    return code


# ---- the problem -----------------------------------------------------------------------------

@dataclass(frozen=True)
class System:
    """Paper Eq. 7 (or Eq. 11) at fixed zeta: maps, monodromies and test functions."""

    zeta: float
    exponent: float = DEFAULT_EXPONENT
    model: str = DEFAULT_LAW
    rtol: float = DEFAULT_RTOL
    max_steps: int = DEFAULT_MAX_STEPS

    def map(self, x, omega, sigma, m):
        """(Phi_{mT}(x), M, status)."""
        out = np.empty(6)
        code = period_map_into(float(x[0]), float(x[1]), float(omega), float(sigma),
                               float(self.zeta), int(m), check_exponent(self.exponent),
                               model_code(self.model), float(self.rtol), float(self.rtol),
                               int(self.max_steps), out)
        return out[:2].copy(), out[2:].reshape(2, 2).copy(), int(code)

    def contact_level(self):
        return contact_loss_level(self.model, self.exponent)

    def shoot(self, omega, sigma, m, guess, max_iter=3):
        return shoot(omega, sigma, self.zeta, m, guess, exponent=self.exponent, model=self.model,
                     rtol=self.rtol, max_iter=max_iter, max_steps=self.max_steps)


def fold_function(M):
    """1 - tr M + det M: zero where a multiplier is +1."""
    return 1.0 - (M[0, 0] + M[1, 1]) + (M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0])


def flip_function(M):
    """1 + tr M + det M: zero where a multiplier is -1."""
    return 1.0 + (M[0, 0] + M[1, 1]) + (M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0])


def floquet_multipliers(M):
    """The eigenvalues of the monodromy M (complex)."""
    return np.linalg.eigvals(M).astype(complex)


def branch_params(u, param, omega, sigma):
    """(omega, sigma) at u = (q, q', p) of a branch in ``param``, the other at its given value."""
    if param == "omega":
        return u[2], sigma
    return omega, u[2]


# ---- parameter derivatives -------------------------------------------------------------------

@dataclass(frozen=True)
class ParameterDifference:
    """A finite difference for d/dp: step h = relative_step (1 + |p|); central,
    (f(p + h) - f(p - h)) / 2h, or forward, (f(p + h) - f(p)) / h."""

    relative_step: float
    central: bool


#: continue_orbit, switch_at_flip: central, step 1e-5. A branch's points carry its records
#: (multipliers, test functions) and the bifurcations located between them are corrected onto
#: it: to |du| <= 1e-9 (1 + |u|), which the corrector reaches with a central difference at a
#: linear rate ~1e-5
BRANCH_DIFFERENCE = ParameterDifference(1e-5, central=True)
#: arc_path: forward, step 1e-6. Its points only seed Newton at fixed omega (a loose corrector):
#: one map more per corrector iteration instead of two
PATH_DIFFERENCE = ParameterDifference(1e-6, central=False)
#: arc_path once its corrector stalls: central, step 1e-6. The forward difference's error grows
#: with the map's curvature in omega, which grows with the period: on a 16T orbit it left the
#: corrector converging only linearly and the path spent its point budget (arc_path)
PATH_STALL_DIFFERENCE = ParameterDifference(1e-6, central=True)
#: trace_curve (compiled: extended_system.curve_system_into, forward only): forward, step 1e-5,
#: in the g row and the parameter columns. The integrator's noise ~rtol / h dominates the
#: truncation error at h ~ 1e-5, so central differences would buy nothing for twice the maps
CURVE_DIFFERENCE = ParameterDifference(1e-5, central=False)


def fixed_point_residual(system, m, param, omega, sigma, difference):
    """u = (q, q', p) -> (F, J, M) for Phi_{mT}(x; p) - x = 0 in ``param`` ("omega" or
    "sigma"; the other at its given value), or None where a map fails: F = Phi(x) - x,
    J = [M - I | dPhi/dp] (2 x 3; dPhi/dp by ``difference``), M the exact monodromy."""
    def residual(u):
        w, s = branch_params(u, param, omega, sigma)
        phi, M, code = system.map(u[:2], w, s, m)
        if code != st.CONVERGED or not np.all(np.isfinite(M)):
            return None
        h = difference.relative_step * (1.0 + abs(u[2]))
        up = u.copy()
        up[2] += h
        phi_p, _, code = system.map(u[:2], *branch_params(up, param, omega, sigma), m)
        if code != st.CONVERGED:
            return None
        J = np.empty((2, 3))
        J[:, :2] = M - np.eye(2)
        if difference.central:
            um = u.copy()
            um[2] -= h
            phi_m, _, code = system.map(u[:2], *branch_params(um, param, omega, sigma), m)
            if code != st.CONVERGED:
                return None
            J[:, 2] = (phi_p - phi_m) / (2.0 * h)
        else:
            J[:, 2] = (phi_p - phi) / h
        return phi - u[:2], J, M
    return residual


# ---- a zero of a test function between two points -------------------------------------------

def illinois_trial(ta, tb, ga, gb):
    """The next trial in the bracket [ta, tb] (values ga, gb of opposite signs) of the Illinois
    variant of regula falsi: the secant's zero, or the midpoint where it falls outside."""
    th = ta - ga * (tb - ta) / (gb - ga) if gb != ga else 0.5 * (ta + tb)
    if not (ta < th < tb):
        th = 0.5 * (ta + tb)
    return th


def illinois_bracket(th, g, ta, tb, ga, gb, side):
    """The bracket after the trial th (value g): th replaces the end of g's sign, and an end
    kept twice in a row has its value halved (Illinois: the secant then moves it). ``side``:
    which end moved last (-1: ta, +1: tb, 0: none yet). Returns (ta, tb, ga, gb, side)."""
    if np.sign(g) == np.sign(ga):
        ta, ga = th, g
        if side == -1:
            gb *= 0.5
        side = -1
    else:
        tb, gb = th, g
        if side == 1:
            ga *= 0.5
        side = 1
    return ta, tb, ga, gb, side


# ---- the corrector, the tangent, the step ----------------------------------------------------

class Correction(NamedTuple):
    """A converged correction: the point, the Jacobian and monodromy of its last iteration
    (at the point before the last update, |du| <= xtol (1 + |u|) away)."""

    u: np.ndarray
    J: np.ndarray
    M: np.ndarray
    iterations: int


def correct(residual, u_pred, normal, *, max_iter=MAX_NEWTON, xtol=XTOL, runaway=True,
            on_stall=None):
    """Newton on F(u) = 0, normal . (u - u_pred) = 0 from u_pred (``residual``: u -> (F, J, M)
    or None, e.g. fixed_point_residual). Converged at |du| <= xtol (1 + |u|). Fails (None)
    where a map fails, the bordered system is singular or its solution not finite, after
    ``max_iter`` iterations, and, with ``runaway``, at a step longer than 1 + |u|.

    ``on_stall``: called when the iterations run out while the corrections still shrink (a
    stalled, linearly converging corrector); the residual it returns (or None) is corrected
    again from u_pred, once. Returns a Correction or None."""
    u = np.array(u_pred, float)
    step_prev = None
    shrinking = False
    for it in range(1, max_iter + 1):
        r = residual(u)
        if r is None:
            return None
        F, J, M = r
        A = np.vstack([J, normal])
        b = -np.concatenate([F, [normal @ (u - u_pred)]])
        try:
            du = np.linalg.solve(A, b)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(du)):
            return None
        u = u + du
        step = np.linalg.norm(du)
        if step <= xtol * (1.0 + np.linalg.norm(u)):
            return Correction(u, J, M, it)
        if runaway and step > 1.0 + np.linalg.norm(u):
            return None
        shrinking = step_prev is not None and step < step_prev
        step_prev = step
    if shrinking and on_stall is not None:
        again = on_stall()
        if again is not None:
            return correct(again, u_pred, normal, max_iter=max_iter, xtol=xtol,
                           runaway=runaway)
    return None


def tangent(J, t_prev):
    """The unit tangent of the curve J u = 0 (J: k x (k+1)) on t_prev's side: the bordered
    solve [J; t_prev] t = e_(k+1), normalised. None where singular."""
    k = J.shape[0]
    A = np.vstack([J, t_prev])
    rhs = np.zeros(k + 1)
    rhs[-1] = 1.0
    try:
        t = np.linalg.solve(A, rhs)
    except np.linalg.LinAlgError:
        return None
    nt = np.linalg.norm(t)
    if not np.isfinite(nt) or nt == 0.0:
        return None
    t /= nt
    return t if t @ t_prev >= 0.0 else -t


def null_vector(J, *, unit=True):
    """The null vector of a k x (k+1) matrix: the right singular vector of its smallest singular
    value, renormalised when ``unit`` (else unit to rounding, as the SVD gives it)."""
    v = np.linalg.svd(J)[2][-1]
    return v / np.linalg.norm(v) if unit else v


def null_tangent(J, t_prev):
    """The null vector of J as the SVD gives it, on t_prev's side: a tangent without the
    bordered solve."""
    t = null_vector(J, unit=False)
    return t * (np.sign(t @ t_prev) or 1.0)


def adapt_step(h, effort, h_max, *, h_min=0.0, easy=2, hard=5):
    """The next step from the last step's effort: grown by 1.5 (to h_max) at an effort of at
    most ``easy``, shrunk by 0.6 (to h_min) at ``hard`` or more (never when None), else kept.

    ``effort`` is any measure of how hard the step was that grows with the step, in the units
    of ``easy`` and ``hard``: the corrector's iterations on an arclength step (branch, path,
    curve), or the predictor's relative miss in natural-parameter continuation
    (kernels.continuation.extremum); a failed step is an infinite effort."""
    if effort <= easy:
        return min(h_max, 1.5 * h)
    if hard is not None and effort >= hard:
        return max(h_min, 0.6 * h)
    return h


def natural_prediction(params, points, p, *, order=2):
    """The natural-parameter predictor: the point at parameter ``p`` extrapolated, component by
    component, by the polynomial through the last k = min(len(points), order + 1) vertices
    (params[i], points[i]): the last vertex itself (k = 1), the secant (k = 2), then the
    quadratic (k = 3). Units those of ``points``."""
    k = min(len(points), order + 1)
    if k == 1:
        return np.array(points[-1], float)
    ps = np.array(params[-k:], float)
    U = np.array(points[-k:], float)
    return np.array([np.polyval(np.polyfit(ps, U[:, j], k - 1), p) for j in range(U.shape[1])])


def predict_correct(correct_at, u, t, h, h_min, *, tangent_at=tangent, slack=1e-12):
    """One pseudo-arclength step of size h along t: the prediction u + h t corrected on the
    hyperplane normal to t through it (``correct_at(u_pred, t)``: a result with ``u``, ``J``
    and ``iterations``, or None), accepted where it lands within h / 2 (+ ``slack``) of the
    prediction with a consistent tangent (``tangent_at(J, t)`` . t > 0.9); else h is halved,
    while h >= h_min. Returns (result, its tangent, h), or (None, None, h)."""
    while h >= h_min:
        u_pred = u + h * t
        r = correct_at(u_pred, t)
        if r is not None:
            tn = tangent_at(r.J, t)
            if (tn is not None and tn @ t > 0.9
                    and np.linalg.norm(r.u - u_pred) <= 0.5 * h + slack):
                return r, tn, h
        h *= 0.5
    return None, None, h
