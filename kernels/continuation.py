"""Pseudo-arclength continuation of periodic orbits, bifurcation test functions, branch switching
at flips and two-parameter continuation of fold and flip curves (paper section 3.2, Fig. 6-10).

Pure: numpy over the numba shooting kernels (no I/O, no Dask, no xarray). Every loop is bounded
(points, Newton iterations, secant iterations); failures come back as status codes.

Unknowns and equations
----------------------
A period-m orbit (m = 1: 1T, m = 2: 2T) is a fixed point x = (q, q') of the stroboscopic map
Phi_{mT}(x; omega, sigma), T = 2 pi / omega. One-parameter continuation (in omega or sigma) solves

    F(u) = Phi(x; p) - x = 0,    u = (q, q', p)

by pseudo-arclength: a secant/tangent predictor u_k + ds t_k and a Newton corrector on the
hyperplane t_k . (u - u_pred) = 0. The Jacobian is [M - I | dPhi/dp] with M the exact monodromy
(variational equations, kernels.shooting) and dPhi/dp by central differences (step 1e-5): the
corrector converges linearly at a rate ~1e-5, to |du| <= 1e-9 (1 + |u|). Continuation goes
through folds (the arclength handles turning points) and through loss of contact (the map and
its monodromy are exact across the switches: the vector field is continuous at q = -n).

Test functions, evaluated from M at every point of a branch (2x2 monodromy):

    fold     1 - tr M + det M = (1 - mu1)(1 - mu2)     (a multiplier +1)
    flip     1 + tr M + det M = (1 + mu1)(1 + mu2)     (a multiplier -1)
    grazing  min q + n   (Hertz; min q - q_c for the Taylor model, q_c = kernels.model.TAYLOR_CONTACT_LOSS, Eq. 12)

A sign change between consecutive points of a branch is refined by the Illinois variant of
regula falsi on the chord between them, each trial point corrected onto the branch on the
hyperplane normal to the chord. The accuracy reported with each located point is the final
bracket width in omega (or sigma) and the residual of the test function.

Branch switching at a flip: the 2T branch leaves the 1T orbit x* along the eigenvector e of the
multiplier -1, at constant parameter to first order: the first 2T point solves Phi_{2T}(x) = x on
the hyperplane e . (x - x*) = d. A 2T branch ends where it meets the 1T orbit again (another
flip: the 2T orbit and its T-shift merge, |Phi_T(x0) - x0| -> 0): status BRANCH_POINT.

Two-parameter continuation of a fold (of period-m orbits) or flip (of 1T orbits) curve in
(omega, sigma) at fixed zeta: u = (q, q', omega, sigma), equations Phi(x) - x = 0 and
g(M) = 0 (g the fold or flip test function), pseudo-arclength with a finite-difference Jacobian
for the g row and the parameter columns (central, step 1e-5).

Curves in any two of (omega, sigma, zeta) (``trace_curve``, the study's "curves" output): fold,
flip (of the period-m monodromy: m = 2 gives the 2T -> 4T flips) and grazing (min q + n = 0)
curves, with a compiled extended system and chord corrector (exact M, forward differences for
the rest: ~9-16 period maps a vertex), traced both ways to the window's edge, through turning
points and contact loss; on the way the sign changes of the other two test functions
(codimension-2 points, with the values on both sides), the cusps of fold curves and the extrema
of each parameter are located and inserted as vertices; a 2T curve that reaches the 1T orbit
ends there, extrapolated onto it (where the isola's fold curve meets the 1T flip curve).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from math import pi

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels._jit import kernel
from hertzmap.kernels.integrate import S_MAX_Q, S_MIN_Q, integrator_scratch
from hertzmap.kernels.model import check_exponent, contact_loss_level, model_code
from hertzmap.kernels.orbit import DEFAULT_MAX_STEPS, DEFAULT_RTOL, shoot
from hertzmap.kernels.shooting import _map, _measure_pass

# ---- branch status codes ------------------------------------------------------------------
BOUNDARY = 0        # left the parameter window
CLOSED = 1          # came back to its start (an isola, or a closed curve)
BRANCH_POINT = 2    # a 2T branch met the 1T orbit (flip of the 1T orbit)
MAX_POINTS = 3      # point budget spent
STEP_FAIL = 4       # corrector failed down to the smallest step
START_FAIL = 5      # the start point did not converge
BRANCH_STATUS = {BOUNDARY: "boundary", CLOSED: "closed", BRANCH_POINT: "branch_point",
                 MAX_POINTS: "max_points", STEP_FAIL: "step_fail", START_FAIL: "start_fail"}

FD_STEP = 1e-5
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
    exponent: float = 1.5
    model: str = "hertz"
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


TEST_FUNCTIONS = {"fold": fold_function, "flip": flip_function}


def _params(u, param, omega, sigma):
    if param == "omega":
        return u[2], sigma
    if param == "sigma":
        return omega, u[2]
    return u[2], u[3]          # "both": (omega, sigma)


def _residual_1p(system, m, param, omega, sigma):
    """u = (q, v, p) -> (F, J, M, ok) for the fixed-point problem in one parameter."""
    def fun(u):
        w, s = _params(u, param, omega, sigma)
        phi, M, code = system.map(u[:2], w, s, m)
        if code != st.CONVERGED or not np.all(np.isfinite(M)):
            return None, None, None, False
        p = u[2]
        h = FD_STEP * (1.0 + abs(p))
        up, um = u.copy(), u.copy()
        up[2] += h
        um[2] -= h
        phi_p, _, c1 = system.map(u[:2], *_params(up, param, omega, sigma), m)
        phi_m, _, c2 = system.map(u[:2], *_params(um, param, omega, sigma), m)
        if c1 != st.CONVERGED or c2 != st.CONVERGED:
            return None, None, None, False
        J = np.empty((2, 3))
        J[:, :2] = M - np.eye(2)
        J[:, 2] = (phi_p - phi_m) / (2.0 * h)
        return phi - u[:2], J, M, True
    return fun


def _residual_2p(system, m, kind):
    """u = (q, v, omega, sigma) -> (F, J, M, ok) for a fold/flip curve: Phi(x) = x, g(M) = 0."""
    g = TEST_FUNCTIONS[kind]

    def fun(u):
        phi, M, code = system.map(u[:2], u[2], u[3], m)
        if code != st.CONVERGED or not np.all(np.isfinite(M)):
            return None, None, None, False
        J = np.empty((3, 4))
        J[:2, :2] = M - np.eye(2)
        for j in range(4):
            h = FD_STEP * (1.0 + abs(u[j]))
            up, um = u.copy(), u.copy()
            up[j] += h
            um[j] -= h
            pp, Mp, c1 = system.map(up[:2], up[2], up[3], m)
            pm, Mm, c2 = system.map(um[:2], um[2], um[3], m)
            if c1 != st.CONVERGED or c2 != st.CONVERGED:
                return None, None, None, False
            J[2, j] = (g(Mp) - g(Mm)) / (2.0 * h)
            if j >= 2:
                J[:2, j] = (pp - pm) / (2.0 * h)
        F = np.empty(3)
        F[:2] = phi - u[:2]
        F[2] = g(M)
        return F, J, M, True
    return fun


def _correct(fun, u_pred, normal, max_iter=MAX_NEWTON, xtol=XTOL):
    """Newton on F(u) = 0, normal . (u - u_pred) = 0. Returns (u, J, M, iterations) or None."""
    u = np.array(u_pred, float)
    for it in range(1, max_iter + 1):
        F, J, M, ok = fun(u)
        if not ok:
            return None
        A = np.vstack([J, normal])
        b = -np.concatenate([F, [normal @ (u - u_pred)]])
        try:
            du = np.linalg.solve(A, b)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(du)):
            return None
        u = u + du
        if np.linalg.norm(du) <= xtol * (1.0 + np.linalg.norm(u)):
            return u, J, M, it
        if np.linalg.norm(du) > 1.0 + np.linalg.norm(u):     # runaway
            return None
    return None


def _tangent(J, t_prev):
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


def _adapt_step(h, iterations, ds_min, ds_max):
    """Next arclength step from the corrector's effort: grow after an easy step, shrink after a
    hard one."""
    if iterations <= 2:
        return min(ds_max, 1.5 * h)
    if iterations >= 5:
        return max(ds_min, 0.6 * h)
    return h


def _predict_correct(fun, u_prev, t_prev, h, ds_min):
    """One pseudo-arclength step of size h along t_prev, halved until the Newton corrector lands
    near the prediction with a consistent tangent. Returns ((u, M, iterations, tangent), h), or
    (None, h) once h < ds_min."""
    while h >= ds_min:
        u_pred = u_prev + h * t_prev
        r = _correct(fun, u_pred, t_prev)
        if r is not None:
            un, Jn, Mn, it = r
            tn = _tangent(Jn, t_prev)
            if (tn is not None and tn @ t_prev > 0.9
                    and np.linalg.norm(un - u_pred) <= 0.5 * h + 1e-12):
                return (un, Mn, it, tn), h
        h *= 0.5
    return None, h


def _null_vector(J):
    """Unit null vector of a k x (k+1) matrix (SVD)."""
    _, _, vt = np.linalg.svd(J)
    return vt[-1] / np.linalg.norm(vt[-1])


# ---- records -------------------------------------------------------------------------------

POINT_FIELDS = ("omega", "sigma", "q0", "v0", "trace", "det", "mu1_re", "mu1_im", "mu2_re",
                "mu2_im", "stable", "min_q", "max_q", "ptp", "loses_contact", "flight_fraction",
                "fold", "flip", "grazing", "asym", "minimal_period", "arclength")


@dataclass
class SpecialPoint:
    """A located fold, flip, grazing or branch point on a branch."""

    kind: str                # "fold", "flip", "grazing", "branch_point"
    period: int
    omega: float
    sigma: float
    x0: np.ndarray
    multipliers: np.ndarray
    value: float             # test function at the located point
    accuracy: float          # final bracket width in the continuation parameter
    evaluations: int
    index: int               # the branch point index after which it lies

    def as_dict(self):
        return {"kind": self.kind, "period": self.period, "omega": self.omega,
                "sigma": self.sigma, "q0": float(self.x0[0]), "v0": float(self.x0[1]),
                "multipliers": [complex(z) for z in self.multipliers], "value": self.value,
                "accuracy": self.accuracy, "evaluations": self.evaluations}


@dataclass
class Branch:
    period: int
    param: str                        # "omega", "sigma" or "both" (a two-parameter curve)
    status: int = START_FAIL
    points: dict = field(default_factory=dict)       # POINT_FIELDS -> 1-D arrays
    special: list = field(default_factory=list)      # SpecialPoint
    kind: str = ""                                   # for curves: "fold" or "flip"

    @property
    def status_name(self):
        return BRANCH_STATUS[self.status]

    def __len__(self):
        return len(self.points.get("omega", ()))

    def u(self, i):
        p = self.points
        if self.param == "both":
            return np.array([p["q0"][i], p["v0"][i], p["omega"][i], p["sigma"][i]])
        return np.array([p["q0"][i], p["v0"][i], p[self.param][i]])


def _multipliers(M):
    return np.linalg.eigvals(M).astype(complex)


def _point_record(system, m, u, M, param, omega, sigma, polish=True):
    """Measures at a corrected point. The monodromy is the corrector's (|du| <= 1e-9 away);
    min q and the contact measures come from a shoot measure pass when ``polish``."""
    w, s = _params(u, param, omega, sigma)
    mu = _multipliers(M)
    mu = mu[np.argsort(-np.abs(mu))]
    rec = dict(omega=float(w), sigma=float(s), q0=float(u[0]), v0=float(u[1]),
               trace=float(M[0, 0] + M[1, 1]), det=float(np.linalg.det(M)),
               mu1_re=mu[0].real, mu1_im=mu[0].imag, mu2_re=mu[1].real, mu2_im=mu[1].imag,
               stable=float(np.max(np.abs(mu)) < 1.0), fold=float(fold_function(M)),
               flip=float(flip_function(M)), min_q=np.nan, max_q=np.nan, ptp=np.nan,
               loses_contact=np.nan, flight_fraction=np.nan, grazing=np.nan, asym=np.nan,
               minimal_period=float(m), arclength=np.nan)
    if polish:
        o = system.shoot(w, s, m, (u[0], u[1]), max_iter=2)
        if o.converged and np.hypot(*(o.x0 - u[:2])) <= 1e-6 * (1.0 + np.hypot(*u[:2])):
            rec.update(min_q=o.min_q, max_q=o.max_q, ptp=o.ptp,
                       loses_contact=float(o.loses_contact), flight_fraction=o.flight_fraction,
                       grazing=o.min_q - system.contact_level(),
                       minimal_period=float(o.minimal_period))
    if m == 2:
        phi_half, _, code = system.map(u[:2], w, s, 1)
        if code == st.CONVERGED:
            rec["asym"] = float(np.hypot(*(phi_half - u[:2])))
    return rec


def _append(points, rec):
    for k in POINT_FIELDS:
        points.setdefault(k, []).append(rec[k])


# ---- locating zeros of test functions ------------------------------------------------------

def _locate(fun, ua, ub, ga, gb, gfun, pidx, max_iter=40, tol=1e-12):
    """Illinois regula falsi on the chord ua -> ub for a zero of gfun(u, M) along the branch.
    Returns (u, M, g, bracket width in u[pidx], evaluations) or None."""
    c = ub - ua
    nc = np.linalg.norm(c)
    if nc == 0.0:
        return None
    normal = c / nc
    slope = (gb - ga) / c[pidx] if c[pidx] != 0.0 else np.inf
    ta, tb = 0.0, 1.0
    best = None
    side = 0
    for it in range(1, max_iter + 1):
        th = ta - ga * (tb - ta) / (gb - ga) if gb != ga else 0.5 * (ta + tb)
        if not (ta < th < tb):
            th = 0.5 * (ta + tb)
        up = ua + th * c
        r = _correct(fun, up, normal)
        if r is None:
            return best
        u, J, M, _ = r
        g = gfun(u, M)
        if not np.isfinite(g):
            return best
        width = abs(c[pidx]) * (tb - ta)
        best = (u, M, g, width, it)
        if g == 0.0:
            return (u, M, g, 0.0, it)
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
        width = min(abs(c[pidx]) * (tb - ta), abs(g / slope))
        best = (u, M, g, width, it)
        if (tb - ta) * nc <= tol * (1.0 + np.linalg.norm(u)) or abs(g) <= 1e-14:
            return best
    return best


# ---- one-parameter continuation -------------------------------------------------------------

def continue_orbit(zeta, x0, *, omega, sigma, period=1, param="omega", direction=1.0,
                   p_min=None, p_max=None, ds=0.01, ds_min=1e-6, ds_max=0.5, max_points=2000,
                   tangent=None, exponent=1.5, model="hertz", rtol=DEFAULT_RTOL,
                   max_steps=DEFAULT_MAX_STEPS, locate=("fold", "flip", "grazing"),
                   stop_at_branch_point=True, polish=True, dp_max=None) -> Branch:
    """Pseudo-arclength continuation of the period-``period`` orbit through (x0, omega, sigma)
    in ``param`` ("omega" or "sigma"), starting in ``direction`` (+1: increasing parameter, or
    along ``tangent`` if given), inside [p_min, p_max]. Locates the test-function zeros named in
    ``locate`` between consecutive points; ``dp_max`` caps the parameter change per step (two
    zeros of a test function closer than one step are not seen). Returns a Branch; never
    raises for a failed solve.
    """
    system = System(float(zeta), float(exponent), model, float(rtol), int(max_steps))
    m = int(period)
    if param not in ("omega", "sigma"):
        raise ValueError(f"param must be 'omega' or 'sigma', got {param!r}")
    p0 = float(omega if param == "omega" else sigma)
    p_min = -np.inf if p_min is None else float(p_min)
    p_max = np.inf if p_max is None else float(p_max)
    if param == "omega":
        p_min = max(p_min, 1e-3)
    else:
        p_min = max(p_min, 0.0)
    fun = _residual_1p(system, m, param, float(omega), float(sigma))
    branch = Branch(period=m, param=param)
    # the start point: Newton at fixed parameter
    u0 = np.array([x0[0], x0[1], p0], float)
    r = _correct(fun, u0, np.array([0.0, 0.0, 1.0]), max_iter=20)
    if r is None:
        return branch
    u, J, M, _ = r
    if tangent is None:
        t = _null_vector(J)
        if t[2] * direction < 0:
            t = -t
    else:
        t = np.asarray(tangent, float) / np.linalg.norm(tangent)
        tt = _tangent(J, t)
        t = t if tt is None else tt
    pts = {}
    rec = _point_record(system, m, u, M, param, omega, sigma, polish)
    rec["arclength"] = 0.0
    _append(pts, rec)
    recs = [rec]
    us = [u]
    u_start, x_start_shift = u.copy(), None
    if m == 2:
        phi_half, _, code = system.map(u[:2], *_params(u, param, omega, sigma), 1)
        if code == st.CONVERGED:
            x_start_shift = phi_half
    s_total = 0.0
    status = MAX_POINTS
    h = float(ds)
    gfuns = _gfuns(system, m, param, omega, sigma)
    while len(us) < max_points:
        u_prev, t_prev = us[-1], t
        if dp_max is not None and abs(t_prev[2]) * h > dp_max:
            h = max(ds_min, dp_max / abs(t_prev[2]))
        r, h = _predict_correct(fun, u_prev, t_prev, h, ds_min)
        if r is None:
            status = STEP_FAIL
            break
        un, Mn, it, t = r
        rec = _point_record(system, m, un, Mn, param, omega, sigma, polish)
        s_total += np.linalg.norm(un - u_prev)
        rec["arclength"] = s_total
        # a 2T branch that met the 1T orbit (checked first: the 2T fold function vanishes there)
        if m == 2 and stop_at_branch_point and (rec["minimal_period"] == 1 or (
                np.isfinite(rec["asym"]) and rec["asym"] <= 1e-6 * (1.0 + np.hypot(*un[:2])))
                or _crossed_1t(system, m, param, omega, sigma, u_prev, un)):
            w, s = _params(un, param, omega, sigma)
            branch.special.append(SpecialPoint("branch_point", m, float(w), float(s),
                                               un[:2].copy(), _multipliers(Mn), rec["fold"],
                                               float(abs(un[2] - u_prev[2])), 0, len(us) - 1))
            _append(pts, rec)
            us.append(un)
            status = BRANCH_POINT
            break
        # locate sign changes of the test functions between the last two points
        for kind in locate:
            ga, gb = recs[-1][kind], rec[kind]
            if np.isfinite(ga) and np.isfinite(gb) and ga * gb < 0.0:
                loc = _locate(fun, u_prev, un, ga, gb, gfuns[kind], 2)
                if loc is not None:
                    ul, Ml, gl, width, nev = loc
                    w, s = _params(ul, param, omega, sigma)
                    branch.special.append(SpecialPoint(kind, m, float(w), float(s), ul[:2].copy(),
                                                       _multipliers(Ml), float(gl), float(width),
                                                       nev, len(us) - 1))
        _append(pts, rec)
        recs.append(rec)
        us.append(un)
        if not (p_min <= un[2] <= p_max):
            status = BOUNDARY
            break
        # back at the start (or at its T-shift): a closed branch
        if s_total > 3.0 * h and len(us) > 3:
            for target in (u_start[:2], x_start_shift):
                if target is None:
                    continue
                d = np.hypot(*(un[:2] - target)) + abs(un[2] - u_start[2])
                if d <= 0.75 * h and s_total > 4.0 * d:
                    status = CLOSED
                    break
            if status == CLOSED:
                break
        h = _adapt_step(h, it, ds_min, ds_max)
    branch.status = status
    branch.points = {k: np.asarray(v, float) for k, v in pts.items()}
    return branch


def _crossed_1t(system, m, param, omega, sigma, ua, ub):
    """True when the 2T points ua, ub lie on either side of the 1T orbit (the vector
    x0 - Phi_T(x0) flips): the branch passed through a flip of the 1T orbit."""
    wa = system.map(ua[:2], *_params(ua, param, omega, sigma), 1)
    wb = system.map(ub[:2], *_params(ub, param, omega, sigma), 1)
    if wa[2] != st.CONVERGED or wb[2] != st.CONVERGED:
        return False
    da = wa[0] - ua[:2]
    db = wb[0] - ub[:2]
    na, nb = np.linalg.norm(da), np.linalg.norm(db)
    if na == 0.0 or nb == 0.0:
        return True
    return (da @ db) / (na * nb) < -0.5


def _gfuns(system, m, param, omega, sigma):
    def graze(u, M):
        w, s = _params(u, param, omega, sigma)
        o = system.shoot(w, s, m, (u[0], u[1]), max_iter=2)
        return o.min_q - system.contact_level() if o.converged else np.nan
    return {"fold": lambda u, M: fold_function(M), "flip": lambda u, M: flip_function(M),
            "grazing": graze}


def flip_eigenvector(M):
    """Unit eigenvector of the real multiplier closest to -1."""
    w, V = np.linalg.eig(M)
    k = int(np.argmin(np.abs(w + 1.0)))
    e = np.real(V[:, k])
    return e / np.linalg.norm(e)


def switch_at_flip(zeta, flip: SpecialPoint, *, d=0.02, exponent=1.5, model="hertz",
                   rtol=DEFAULT_RTOL, max_steps=DEFAULT_MAX_STEPS, param="omega", M=None):
    """First point of the 2T branch born at a flip of the 1T orbit: solve Phi_{2T}(x) = x on the
    hyperplane e . (x - x*) = d (e the eigenvector of the multiplier -1), with the parameter free.
    Returns (x0, omega, sigma, tangent) or None. The tangent points away from the 1T orbit."""
    system = System(float(zeta), float(exponent), model, float(rtol), int(max_steps))
    if M is None:
        _, M, code = system.map(flip.x0, flip.omega, flip.sigma, 1)
        if code != st.CONVERGED:
            return None
    e = flip_eigenvector(M)
    fun = _residual_1p(system, 2, param, flip.omega, flip.sigma)
    p = flip.omega if param == "omega" else flip.sigma
    for dd in (d, d / 4, d / 16):
        u_star = np.array([flip.x0[0], flip.x0[1], p])
        normal = np.array([e[0], e[1], 0.0])
        u_pred = u_star + dd * normal
        r = _correct(fun, u_pred, normal, max_iter=20)
        if r is None:
            continue
        u, J, _, _ = r
        w, s = _params(u, param, flip.omega, flip.sigma)
        half, _, code = system.map(u[:2], w, s, 1)
        if code != st.CONVERGED or np.hypot(*(half - u[:2])) <= 1e-6:
            continue        # landed on the 1T orbit
        t = _tangent(J, normal)
        return u[:2].copy(), float(w), float(s), t
    return None


# ---- two-parameter continuation -------------------------------------------------------------

def continue_curve(zeta, x0, omega, sigma, *, kind="fold", period=2, direction=1.0,
                   omega_bounds=(0.05, 10.0), sigma_bounds=(0.0, 10.0), ds=0.01, ds_min=1e-6,
                   ds_max=0.05, max_points=1000, exponent=1.5, model="hertz",
                   rtol=DEFAULT_RTOL, max_steps=DEFAULT_MAX_STEPS,
                   stop_at_branch_point=True) -> Branch:
    """Continue a fold (``kind="fold"``, period-``period`` orbits) or flip (``kind="flip"``,
    1T orbits) curve in (omega, sigma) at fixed zeta from a point near it (x0, omega, sigma),
    starting towards increasing sigma for direction=+1. Returns a Branch with param="both";
    points hold omega, sigma, q0, v0, trace, det, multipliers, asym (2T). A 2T fold curve that
    reaches the 1T orbit (where it meets the flip curve) stops there with status BRANCH_POINT
    and a special point "flip_meets_fold"."""
    system = System(float(zeta), float(exponent), model, float(rtol), int(max_steps))
    m = int(period)
    fun = _residual_2p(system, m, kind)
    branch = Branch(period=m, param="both", kind=kind)
    u0 = np.array([x0[0], x0[1], omega, sigma], float)
    r = _correct(fun, u0, np.array([0.0, 0.0, 0.0, 1.0]), max_iter=20)
    if r is None:
        return branch
    u, J, M, _ = r
    t = _null_vector(J)
    if t[3] * direction < 0:
        t = -t
    pts = {}
    s_total = 0.0

    def record(u, M):
        rec = _point_record(system, m, u, M, "both", None, None, polish=False)
        return rec

    rec = record(u, M)
    rec["arclength"] = 0.0
    _append(pts, rec)
    us = [u]
    u_start = u.copy()
    x_shift = None
    if m == 2:
        x_shift = system.map(u[:2], u[2], u[3], 1)[0]
    status = MAX_POINTS
    h = float(ds)
    scale = 1.0 + np.hypot(*u[:2])
    while len(us) < max_points:
        u_prev, t_prev = us[-1], t
        r, h = _predict_correct(fun, u_prev, t_prev, h, ds_min)
        if r is None:
            status = STEP_FAIL
            asym = pts.get("asym", [])
            if m == 2 and len(asym) > 2 and asym[-1] <= 1e-2 * max(asym):
                # stuck next to the 1T orbit: the codimension-2 point where the fold curve
                # meets the flip curve makes the system singular there
                ul = us[-1]
                branch.special.append(SpecialPoint("flip_meets_fold", m, float(ul[2]),
                                                   float(ul[3]), ul[:2].copy(),
                                                   np.array([np.nan, np.nan], complex),
                                                   float(pts["fold"][-1]), float(asym[-1]), 0,
                                                   len(us) - 1))
                status = BRANCH_POINT
            break
        un, Mn, it, t = r
        rec = record(un, Mn)
        s_total += np.linalg.norm(un - u_prev)
        rec["arclength"] = s_total
        _append(pts, rec)
        us.append(un)
        if m == 2 and stop_at_branch_point and (
                rec["asym"] <= 1e-5 * scale
                or _crossed_1t(system, m, "both", None, None, u_prev, un)):
            branch.special.append(SpecialPoint("flip_meets_fold", m, float(un[2]), float(un[3]),
                                               un[:2].copy(), _multipliers(Mn), rec["fold"],
                                               float(np.hypot(*(un[2:] - u_prev[2:]))), 0,
                                               len(us) - 1))
            status = BRANCH_POINT
            break
        if not (omega_bounds[0] <= un[2] <= omega_bounds[1]
                and sigma_bounds[0] <= un[3] <= sigma_bounds[1]):
            status = BOUNDARY
            break
        if s_total > 3.0 * h and len(us) > 3:
            for target in (u_start[:2], x_shift):
                if target is None:
                    continue
                d = np.hypot(*(un[:2] - target)) + np.hypot(*(un[2:] - u_start[2:]))
                if d <= 0.75 * h and s_total > 4.0 * d:
                    status = CLOSED
            if status == CLOSED:
                break
        h = _adapt_step(h, it, ds_min, ds_max)
    branch.status = status
    branch.points = {k: np.asarray(v, float) for k, v in pts.items()}
    return branch


def curve_extremum(branch: Branch, coord="sigma", kind="min"):
    """Extremum of ``coord`` along a curve: a parabola through the three points around the
    discrete extremum, in arclength. Returns (value, other coordinate, spacing) or None."""
    p = branch.points
    if len(branch) < 3:
        return None
    y = p[coord] if kind == "min" else -p[coord]
    i = int(np.argmin(y))
    if i == 0 or i == len(y) - 1:
        return None
    s = p["arclength"][i - 1:i + 2]
    other = "omega" if coord == "sigma" else "sigma"
    c = np.polyfit(s - s[1], y[i - 1:i + 2], 2)
    if c[0] <= 0:
        return None
    s_min = -c[1] / (2 * c[0])
    val = np.polyval(c, s_min)
    co = np.polyfit(s - s[1], p[other][i - 1:i + 2], 2)
    oth = np.polyval(co, s_min)
    return (val if kind == "min" else -val), float(oth), float(max(np.diff(s)))


# =============================================================================================
# Curves in any two of (omega, sigma, zeta): fold, flip and grazing curves
# =============================================================================================
#
# Unknowns u = (q, q', a, b), (a, b) two of (omega, sigma, zeta), the third fixed; equations
#
#     Phi_{mT}(x; p) - x = 0,    g(x, p) = 0,
#
# g the fold function 1 - tr M + det M, the flip function 1 + tr M + det M (of the period-m
# monodromy: m = 2 gives the 2T -> 4T flips) or the grazing function min q + n (min over the
# orbit's period; an interior minimum, so a smooth function of (x, p) where one local minimum is
# the lowest). The Jacobian's Phi rows take the exact monodromy M for the x columns and forward
# differences for the parameter columns; the g row is a forward difference in all four
# (integrator noise ~rtol / h dominates the truncation error at h ~ 1e-5, so central
# differences would buy nothing for twice the maps). The corrector is a chord method: the
# Jacobian is built once at the predicted point (5 period maps) and kept while the corrections
# contract (one map per iteration), rebuilt once if they stop contracting. A vertex costs about
# 8 period maps where a full Newton with central differences costs 9 per iteration.

CURVE_PARAMS = ("omega", "sigma", "zeta")
CURVE_KINDS = ("fold", "flip", "grazing")      # codes 0, 1, 2 in the compiled evaluator
_KIND_FOLD, _KIND_FLIP, _KIND_GRAZING = 0, 1, 2

#: vertex flags (bit mask): why a vertex is where it is
VERTEX_SEED = 1          # the corrected start point of the trace
VERTEX_EXTREMUM = 2      # a turning point of a parameter along the curve (refined: dp/ds = 0)
VERTEX_EDGE = 4          # on the window's edge (the curve leaves there)
VERTEX_END = 8           # the extrapolated end where a 2T curve meets the 1T orbit
VERTEX_CODIM2 = 16       # a located codimension-2 point (also in Curve.codim2)
VERTEX_FLAGS = ((VERTEX_SEED, "seed"), (VERTEX_EXTREMUM, "parameter_extremum"),
                (VERTEX_EDGE, "window_edge"), (VERTEX_END, "meets_1T_orbit"),
                (VERTEX_CODIM2, "codim2_point"))

#: codimension-2 points along a curve
CODIM2_KINDS = ("cusp", "fold_flip", "fold_grazing", "flip_grazing")

CURVE_FD_STEP = 1e-5
CURVE_XTOL = 1e-11       # |du| <= CURVE_XTOL (1 + |u|): the corrections contract by >= 1e3
CURVE_MAX_ITER = 12      # corrector iterations per vertex (the Jacobian rebuilt at most once)
CURVE_FTOL = 1e-8        # a converged vertex solves the equations to this (1 + |u|) (~1e-11)
# A 2T curve this close to the 1T orbit (|Phi_T(x) - x| / (1 + |x|)) ends there: the extended
# system's smallest singular value falls like |Phi_T(x) - x|^2 towards the 1T orbit (1.5e-4 at
# 0.05 on the isola's fold curve, zeta 0.01), and the end point is extrapolated from the
# vertices further out (Tracer.meets_1t)
MEET_1T_ASYM = 3e-2


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


VERTEX_FIELDS = ("omega", "sigma", "zeta", "q0", "v0", "m11", "m12", "m21", "m22", "min_q",
                 "max_q", "fold", "flip", "grazing", "asym", "step", "residual", "iterations",
                 "arclength", "flag")


@dataclass
class Codim2Point:
    """A codimension-2 point on a traced curve, with its evidence: ``value`` is the other test
    function (or, for a cusp, the curve tangent's component along the parameter direction it
    had before) at the point, ``left``/``right`` its values at the two vertices that bracket it
    (opposite signs). ``accuracy``: the bracket's final width in the curve's parameters (for
    "fold_flip", the spread of the extrapolation)."""

    kind: str                # CODIM2_KINDS
    period: int
    omega: float
    sigma: float
    zeta: float
    x0: np.ndarray
    multipliers: np.ndarray
    value: float
    left: float
    right: float
    accuracy: float
    vertex: int = -1         # index of its vertex in Curve.vertices

    def as_dict(self):
        return {"kind": self.kind, "period": self.period, "omega": self.omega,
                "sigma": self.sigma, "zeta": self.zeta, "q0": float(self.x0[0]),
                "v0": float(self.x0[1]), "multipliers": [complex(z) for z in self.multipliers],
                "value": self.value, "left": self.left, "right": self.right,
                "accuracy": self.accuracy, "vertex": self.vertex}


@dataclass
class Curve:
    """A traced fold / flip / grazing curve in the (pair[0], pair[1]) plane, the third parameter
    at ``fixed``. ``vertices``: VERTEX_FIELDS -> 1-D arrays in order along the curve (the
    backward half reversed, then the forward half); ``status``: (backward, forward) end codes
    (BRANCH_STATUS; CLOSED on both for a closed curve); ``maps``: period maps integrated."""

    kind: str
    period: int
    pair: tuple
    fixed: float
    status: tuple = (START_FAIL, START_FAIL)
    vertices: dict = field(default_factory=dict)
    codim2: list = field(default_factory=list)
    maps: int = 0
    seconds: float = 0.0

    def __len__(self):
        return len(self.vertices.get("omega", ()))

    @property
    def status_names(self):
        return tuple(BRANCH_STATUS[s] for s in self.status)


class _CurveSystem:
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
                                 CURVE_FD_STEP, F, J, aux)
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
    """Corrector on F(u) = 0, normal . (u - u_pred) = 0 (see :func:`_chord`), compiled: u, F,
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


def _chord(system, u_pred, normal, J=None, max_iter=CURVE_MAX_ITER, xtol=CURVE_XTOL):
    """Corrector on F(u) = 0, normal . (u - u_pred) = 0 with a Jacobian ``J`` built once (at
    u_pred when None, else the one given) and then updated, not rebuilt: the Phi rows' x
    columns are the exact M - I of every map, the rest Broyden's rank-1 secant update. It is
    rebuilt by differences (once) where the corrections stop contracting by 3 or more.
    Converged at |du| <= xtol (1 + |u|), or at the integrator's noise floor (|du| <= 1e-8
    (1 + |u|) and no longer contracting: an ill-conditioned system, e.g. a 2T curve near the
    1T orbit). Returns (u, F, aux, J, iterations), F and aux at u, or None."""
    u = np.empty(4)
    F = np.empty(3)
    aux = np.empty(7)
    Jw = np.empty((3, 4)) if J is None else np.array(J, float)
    maps = np.zeros(1)
    it = _chord_into(np.ascontiguousarray(u_pred, dtype=np.float64),
                     np.ascontiguousarray(normal, dtype=np.float64), Jw, J is not None,
                     system.pa, system.pb, system.fixed, system.kind_code, system.m, system.n,
                     system.model_code, system.rtol, system.rtol, system.max_steps,
                     system.level, CURVE_FD_STEP, int(max_iter), float(xtol), True, u, F, aux,
                     maps)
    system.maps += int(maps[0])
    if it < 0:
        return None
    return u, F, aux, Jw, it


class _Tracer:
    """Traces one curve from a start point both ways (see :func:`trace_curve`)."""

    def __init__(self, system, bounds, ds, ds_min, ds_max, dp_frac, max_points):
        self.sys = system
        self.lo = np.array([bounds[0][0], bounds[1][0]], float)
        self.hi = np.array([bounds[0][1], bounds[1][1]], float)
        self.dp_max = dp_frac * np.maximum(self.hi - self.lo, 1e-9)
        self.ds, self.ds_min, self.ds_max = float(ds), float(ds_min), float(ds_max)
        self.max_points = int(max_points)
        self.m = system.m
        self.kind = CURVE_KINDS[system.kind_code]
        self.others = [k for k in ("fold", "flip", "grazing") if k != self.kind]

    # -- one vertex ----------------------------------------------------------------------------
    def record(self, u, F, aux, step, iterations, flag):
        tr = aux[0] + aux[3]
        det = aux[0] * aux[3] - aux[1] * aux[2]
        w, s, z = self.sys.params(u)
        rec = dict(omega=w, sigma=s, zeta=z, q0=u[0], v0=u[1], m11=aux[0], m12=aux[1],
                   m21=aux[2], m22=aux[3], min_q=aux[4], max_q=aux[6], fold=1.0 - tr + det,
                   flip=1.0 + tr + det, grazing=aux[4] - self.sys.level, asym=np.nan,
                   step=step, residual=float(np.max(np.abs(F))), iterations=iterations,
                   arclength=np.nan, flag=flag)
        if self.m == 2:
            half = self.sys.shift(u)
            if half is not None:
                rec["asym"] = float(np.hypot(*(half - u[:2])))
                rec["_shift"] = half - u[:2]
        return rec

    def multipliers(self, rec):
        M = np.array([[rec["m11"], rec["m12"]], [rec["m21"], rec["m22"]]])
        mu = _multipliers(M)
        return mu[np.argsort(-np.abs(mu))]

    # -- refining along a chord ------------------------------------------------------------------
    def refine(self, ua, ub, ga, gb, gfun, J=None, max_iter=30):
        """Zero of gfun(u, F, aux, J) between two vertices: Illinois regula falsi on the chord,
        each trial point corrected onto the curve on the hyperplane normal to the chord (with
        ``J`` kept, or a Jacobian built at each trial when gfun needs it fresh). Returns
        (u, F, aux, J, g, width in the parameters) or None."""
        c = ub - ua
        nc = float(np.linalg.norm(c))
        if nc == 0.0 or not (np.isfinite(ga) and np.isfinite(gb)) or ga * gb > 0.0:
            return None
        normal = c / nc
        ta, tb = 0.0, 1.0
        side = 0
        best = None
        wp = float(np.linalg.norm(c[2:]))
        for _ in range(max_iter):
            th = ta - ga * (tb - ta) / (gb - ga) if gb != ga else 0.5 * (ta + tb)
            if not (ta < th < tb):
                th = 0.5 * (ta + tb)
            r = _chord(self.sys, ua + th * c, normal, J=J)
            if r is None:
                return best
            u, F, aux, Jt, _ = r
            g = gfun(u, F, aux, Jt)
            if not np.isfinite(g):
                return best
            if g == 0.0:
                return (u, F, aux, Jt, g, 0.0)
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
            # the bracket's width, or the secant's estimate |g / g'| where smaller
            slope = abs(gb - ga) / (wp * (tb - ta)) if tb > ta and wp > 0.0 else 0.0
            width = wp * (tb - ta)
            if slope > 0.0:
                width = min(width, abs(g) / slope)
            best = (u, F, aux, Jt, g, width)
            if (tb - ta) * nc <= 1e-13 * (1.0 + np.linalg.norm(u)):
                break
        return best

    def to_edge(self, u_prev, u_new, J):
        """The point where the curve leaves the window between two vertices: corrected onto
        the edge it crosses first (the edge's parameter held at the bound). None on failure."""
        c = u_new - u_prev
        best = None
        for j in range(2):
            for bound in (self.lo[j], self.hi[j]):
                a, b = u_prev[2 + j] - bound, u_new[2 + j] - bound
                if a * b < 0.0 or (b == 0.0 and a != 0.0):
                    th = a / (a - b)
                    if best is None or th < best[0]:
                        best = (th, j, bound)
        if best is None:
            return None
        th, j, bound = best
        guess = u_prev + th * c
        guess[2 + j] = bound
        normal = np.zeros(4)
        normal[2 + j] = 1.0
        r = _chord(self.sys, guess, normal, J=J)
        if r is None:
            r = _chord(self.sys, guess, normal)
        return r

    def inside(self, u):
        return bool(np.all(u[2:] >= self.lo) and np.all(u[2:] <= self.hi))

    # -- the end of a 2T curve on the 1T orbit ---------------------------------------------------
    def meets_1t(self, recs, us):
        """Extrapolate a 2T curve to where it meets the 1T orbit: the parameters are even
        functions of the 2T orbit's distance a from the 1T orbit, and |Phi_T(x) - x| = 2|a| +
        O(a^3), so p = p0 + c1 A + c2 A^2 with A = |Phi_T(x) - x|^2 (least squares over the
        vertices closest to the 1T orbit). Returns (u_end, accuracy) or None."""
        asym = np.array([r["asym"] for r in recs])
        ok = np.isfinite(asym)
        if ok.sum() < 3:
            return None
        idx = np.nonzero(ok)[0]
        idx = idx[np.argsort(asym[idx])][:8]
        if len(idx) < 3:
            return None
        A = asym[idx] ** 2
        U = np.array([us[i] for i in idx])
        end = np.empty(4)
        spread = 0.0
        deg = 3 if len(idx) >= 7 else (2 if len(idx) >= 4 else 1)
        for j in range(4):
            y = U[:, j]
            if j < 2:      # the 1T orbit's start point: the mean of x and its T-shift
                y = np.array([us[i][j] + 0.5 * recs[i]["_shift"][j] for i in idx])
            c_hi = np.polyfit(A, y, deg)
            # the spread: the same fit one degree lower, over the closest points
            c_lo = np.polyfit(A[:-1], y[:-1], deg - 1) if deg > 1 else c_hi
            end[j] = c_hi[-1]
            if j >= 2:
                spread = max(spread, abs(c_hi[-1] - c_lo[-1]))
        return end, spread

    # -- one direction -------------------------------------------------------------------------
    def side(self, u0, t0, J0, rec0):
        """Vertices (records) from the start point (excluded) along t0, the codimension-2 points
        met, and the end status."""
        recs, us, ts, Js, special = [], [], [], [], []
        u, t, J, prev = u0, t0, J0, rec0
        h = self.ds
        s_total = 0.0
        status = MAX_POINTS
        start_targets = [u0[:2]]
        if self.m == 2 and "_shift" in rec0:
            start_targets.append(u0[:2] + rec0["_shift"])
        while len(recs) < self.max_points:
            tp = np.abs(t[2:])
            cap = np.min(np.where(tp > 0, self.dp_max / np.maximum(tp, 1e-300), np.inf))
            if self.m == 2 and np.isfinite(prev.get("asym", np.nan)):
                # steps no longer than a fifth of the distance to the 1T orbit: a 2T curve
                # that ends there leaves ~10 vertices at asym 0.03..0.3 for the extrapolation
                cap = min(cap, 0.2 * prev["asym"])
            h = max(self.ds_min, min(h, cap, self.ds_max))
            step = None
            while h >= self.ds_min and step is None:
                u_pred = u + h * t
                # (the last vertex's Jacobian, Broyden-updated, instead of one built here saved
                # 4 maps a vertex but took 6-12 corrections each and lost the isola's fold
                # curve: built here)
                r = _chord(self.sys, u_pred, t)
                if r is not None:
                    un, Fn, auxn, Jn, it = r
                    tn = _tangent(Jn, t)
                    if (tn is not None and tn @ t > 0.9
                            and np.linalg.norm(un - u_pred) <= 0.5 * h + 1e-12):
                        step = (un, Fn, auxn, Jn, it, tn)
                if step is None:
                    h *= 0.5
            if step is None:
                status = STEP_FAIL
                if self.m == 2 and len(recs) >= 3:
                    asym = [r["asym"] for r in [rec0] + recs]
                    if np.isfinite(asym[-1]) and asym[-1] <= 0.05 * np.nanmax(asym):
                        status = BRANCH_POINT      # stuck next to the 1T orbit
                break
            un, Fn, auxn, Jn, it, tn = step
            dist = float(np.linalg.norm(un - u))
            rec = self.record(un, Fn, auxn, dist, it, 0)
            # a 2T curve that reaches the 1T orbit (or crosses it: x - Phi_T(x) turns over)
            if self.m == 2 and "_shift" in rec and "_shift" in prev:
                a, b = prev["_shift"], rec["_shift"]
                crossed = (a @ b) < -0.5 * np.linalg.norm(a) * np.linalg.norm(b)
                scale = 1.0 + np.hypot(*un[:2])
                if crossed or rec["asym"] <= MEET_1T_ASYM * scale:
                    if not crossed:
                        recs.append(rec)
                        us.append(un)
                        s_total += dist
                    status = BRANCH_POINT
                    break
            edge = None
            if not self.inside(un):
                edge = self.to_edge(u, un, Jn)
                if edge is None:
                    status = BOUNDARY
                    break
                un, Fn, auxn, Jn, it = edge
                dist = float(np.linalg.norm(un - u))
                rec = self.record(un, Fn, auxn, dist, it, VERTEX_EDGE)
            inserts = self.specials(u, un, prev, rec, Jn, special)
            for th, r_ins, u_ins in sorted(inserts, key=lambda z: z[0]):
                r_ins["step"] = float(np.linalg.norm(u_ins - (us[-1] if us else u)))
                recs.append(r_ins)
                us.append(u_ins)
            s_total += dist
            recs.append(rec)
            us.append(un)
            if edge is not None:
                status = BOUNDARY
                break
            # back at the start (or its T-shift): a closed curve
            if s_total > 3.0 * h and len(recs) > 3:
                closed = False
                for target in start_targets:
                    d = np.hypot(*(un[:2] - target)) + np.hypot(*(un[2:] - u0[2:]))
                    if d <= 0.75 * h and s_total > 4.0 * d:
                        closed = True
                if closed:
                    status = CLOSED
                    break
            u, t, J, prev = un, tn, Jn, rec
            # the chord corrector takes 3-4 iterations on an easy step (its Jacobian is the
            # predicted point's): grow then, shrink when it needs many more
            if it <= 4:
                h = min(self.ds_max, 1.5 * h)
            elif it >= 7:
                h = max(self.ds_min, 0.6 * h)
        return recs, us, special, status

    def specials(self, ua, ub, ra, rb, Jb, special):
        """Codimension-2 points between two consecutive vertices (sign changes of the other two
        test functions): located, recorded in ``special`` and returned as vertices to insert
        (fraction along the chord, record, u)."""
        out = []
        chord = ub - ua
        # the other test functions: a sign change is a codimension-2 point
        for other in self.others:
            ga, gb = ra[other], rb[other]
            if not (np.isfinite(ga) and np.isfinite(gb)) or ga * gb > 0.0:
                continue
            names = sorted((self.kind, other), key=("fold", "flip", "grazing").index)
            name = "_".join(names)
            idx = {"fold": 0, "flip": 1, "grazing": 2}[other]

            def g_other(u, F, aux, J, idx=idx):
                tr = aux[0] + aux[3]
                det = aux[0] * aux[3] - aux[1] * aux[2]
                return (1.0 - tr + det, 1.0 + tr + det, aux[4] - self.sys.level)[idx]
            loc = self.refine(ua, ub, ga, gb, g_other, J=Jb)
            if loc is None:
                continue
            u, F, aux, _, g, width = loc
            rec = self.record(u, F, aux, np.nan, 0, VERTEX_CODIM2)
            th = float((u - ua) @ chord / (chord @ chord))
            rec["_codim2"] = Codim2Point(name, self.m, rec["omega"], rec["sigma"], rec["zeta"],
                                         u[:2].copy(), self.multipliers(rec), float(g),
                                         float(ga), float(gb), float(width))
            special.append(rec["_codim2"])
            out.append((th, rec, u))
        return out

    def extremum(self, ua, ub, J, d, maximum):
        """The point of the curve between ua and ub (vertices two apart, bracketing it) where
        d . (a, b) is extremal: the curve's points on the hyperplanes normal to the chord
        through ua + th (ub - ua), th in [0, 1], with Brent's bounded search over th (to 1e-9
        in th: the extremal value is then exact to ~1e-18 times the curvature). Returns
        (u, F, aux) or None."""
        from scipy.optimize import minimize_scalar

        c = ub - ua
        normal = c / np.linalg.norm(c)
        sign = -1.0 if maximum else 1.0
        found = {}

        def phi(th):
            r = _chord(self.sys, ua + th * c, normal, J=J)
            if r is None:
                return np.inf
            found[th] = r
            return sign * float(r[0][2:] @ d)
        # a trial that does not converge is +inf: no arithmetic warning from the search
        with np.errstate(invalid="ignore", over="ignore"):
            res = minimize_scalar(phi, bounds=(0.0, 1.0), method="bounded",
                                  options={"xatol": 1e-9, "maxiter": 80})
        th = float(res.x)
        if th not in found or not np.isfinite(res.fun):
            return None
        u, F, aux, _, _ = found[th]
        return u, F, aux

    def turning_points(self, recs, us):
        """The curve's parameter extrema and (fold curves) cusps, refined and inserted as
        vertices: a post-pass over the assembled curve. An extremum of a parameter lies where
        its values at three consecutive vertices k-1, k, k+1 turn (p_k above or below both):
        it is located as the extremum of that parameter over the curve between k-1 and k+1,
        not as a zero of the tangent (the tangent comes from a difference Jacobian ~1e-4 off:
        that moved sigma** by 1e-6, and the tangent's sign change by two vertices, where the
        extremal value itself is exact to the integrator's accuracy). On a fold curve, a cusp
        is where the parameter increments reverse ((p_k - p_k-1) . (p_k+1 - p_k) < 0) and
        the curve's tangent has no parameter component left at the extremum of p . d (d the
        direction before it). Returns the new (recs, us)."""
        inserts = []            # (k, after k?, record, u)
        n = len(recs)
        P = np.array([[r[CURVE_PARAMS[self.sys.pa]], r[CURVE_PARAMS[self.sys.pb]]] for r in recs])
        for k in range(1, n - 1):
            if any(recs[i]["flag"] & (VERTEX_EDGE | VERTEX_END) for i in (k - 1, k, k + 1)):
                continue
            d1, d2 = P[k] - P[k - 1], P[k + 1] - P[k]
            ua, uk, ub = us[k - 1], us[k], us[k + 1]
            cusp = self.kind == "fold" and d1 @ d2 < 0.0
            todo = []
            if cusp:
                todo.append(("cusp", d1 / np.linalg.norm(d1), True))
            else:
                for j in range(2):
                    if d1[j] * d2[j] < 0.0:
                        e = np.zeros(2)
                        e[j] = 1.0
                        todo.append(("extremum", e, d1[j] > 0.0))
            if not todo:
                continue
            r = self.sys(uk, True)
            if r is None:
                continue
            J = r[1]
            for what, d, maximum in todo:
                loc = self.extremum(ua, ub, J, d, maximum)
                if loc is None:
                    continue
                u, F, aux = loc
                after = bool((u - uk) @ (ub - ua) > 0.0)
                if what == "extremum":
                    inserts.append((k, after, self.record(u, F, aux, np.nan, 0, VERTEX_EXTREMUM),
                                    u))
                    continue
                rj = self.sys(u, True)
                t = _tangent(rj[1], (ub - ua) / np.linalg.norm(ub - ua)) if rj is not None \
                    else None
                if t is None or np.linalg.norm(t[2:]) > 1e-2:
                    continue                    # a sharp smooth turn, not a cusp
                rec = self.record(u, F, aux, np.nan, 0, VERTEX_CODIM2 | VERTEX_EXTREMUM)
                rec["_codim2"] = Codim2Point("cusp", self.m, rec["omega"], rec["sigma"],
                                             rec["zeta"], u[:2].copy(), self.multipliers(rec),
                                             float(t[2:] @ d), float(d1 @ d), float(d2 @ d),
                                             1e-9 * float(np.linalg.norm(P[k + 1] - P[k - 1])))
                inserts.append((k, after, rec, u))
        if not inserts:
            return recs, us
        out_r, out_u = [], []
        by_k = {}
        for k, after, rec, u in inserts:
            by_k.setdefault(k, []).append((after, rec, u))
        for k in range(n):
            before = [(r_, u_) for a, r_, u_ in by_k.get(k, []) if not a]
            later = [(r_, u_) for a, r_, u_ in by_k.get(k, []) if a]
            for r_, u_ in before:
                out_r.append(r_)
                out_u.append(u_)
            out_r.append(recs[k])
            out_u.append(us[k])
            for r_, u_ in later:
                out_r.append(r_)
                out_u.append(u_)
        return out_r, out_u


def trace_curve(x0, omega, sigma, zeta, *, kind, period=1, pair=("omega", "sigma"),
                bounds=None, exponent=1.5, model="hertz", rtol=DEFAULT_RTOL,
                max_steps=DEFAULT_MAX_STEPS, ds=0.01, ds_min=1e-7, ds_max=0.2,
                dp_frac=0.01, max_points=1500, both_ways=True, direction=1.0,
                hold=None) -> Curve:
    """Trace the ``kind`` curve ("fold", "flip" or "grazing") of period-``period`` orbits in the
    plane of ``pair`` (two of "omega", "sigma", "zeta"; the third held at its given value) from
    a point near it: the orbit through x0 = (q, q') at (omega, sigma, zeta).

    The start is corrected onto the curve with ``hold`` held (default pair[1]; then, failing
    that, the other parameter of the pair: a start between two grid points of a line of
    ``hold``'s value is corrected along that line); the
    curve is followed both ways (``both_ways``; else along increasing pair[1] for direction
    +1) until it leaves ``bounds`` ({param: (lo, hi)} for the pair; the last vertex is put on
    the edge), closes, ends on the 1T orbit (a 2T curve: its end is extrapolated), or fails.
    Vertices are at most ``dp_frac`` of the window apart in each parameter. Along the way the
    sign changes of the other two test functions (codimension-2 points), the cusps of fold
    curves and the extrema of each parameter are located and inserted as vertices.
    Every loop is bounded; a failure is a status, never an exception. Dimensionless (paper
    Eq. 7 / 11); returns a :class:`Curve`.
    """
    t_start = time.perf_counter()
    pair = tuple(pair)
    if len(pair) != 2 or pair[0] == pair[1] or any(p not in CURVE_PARAMS for p in pair):
        raise ValueError(f"pair must be two distinct names of {CURVE_PARAMS}, got {pair!r}")
    if kind not in CURVE_KINDS:
        raise ValueError(f"kind must be one of {CURVE_KINDS}, got {kind!r}")
    p0 = {"omega": float(omega), "sigma": float(sigma), "zeta": float(zeta)}
    fixed_name = [p for p in CURVE_PARAMS if p not in pair][0]
    default = {"omega": (1e-3, 10.0), "sigma": (0.0, 10.0), "zeta": (0.0, 10.0)}
    bounds = dict(bounds or {})
    bnd = (tuple(bounds.get(pair[0], default[pair[0]])), tuple(bounds.get(pair[1], default[pair[1]])))
    system = _CurveSystem(kind, period, pair, p0[fixed_name], exponent, model, rtol, max_steps)
    curve = Curve(kind=kind, period=int(period), pair=pair, fixed=p0[fixed_name])
    tracer = _Tracer(system, bnd, ds, ds_min, ds_max, dp_frac, max_points)
    u0 = np.array([x0[0], x0[1], p0[pair[0]], p0[pair[1]]], float)
    start = None
    if hold is not None and hold not in pair:
        raise ValueError(f"hold must be one of {pair!r}, got {hold!r}")
    for held in ((2, 3) if hold == pair[0] else (3, 2)):
        normal = np.zeros(4)
        normal[held] = 1.0
        start = _chord(system, u0, normal, max_iter=30)
        if start is not None:
            break
    if start is None:
        curve.maps = system.maps
        curve.seconds = time.perf_counter() - t_start
        return curve
    u, F, aux, J, it = start
    r = system(u, True)
    if r is not None:
        J = r[1]
    t = _null_vector(J)
    if (t[3] if abs(t[3]) > 1e-12 else t[2]) * direction < 0:
        t = -t
    rec0 = tracer.record(u, F, aux, 0.0, it, VERTEX_SEED)
    fwd, fus, fsp, fst = tracer.side(u, t, J, rec0)
    if fst == CLOSED or not both_ways:
        bwd, bus, bsp, bst = [], [], [], fst if fst == CLOSED else START_FAIL
    else:
        bwd, bus, bsp, bst = tracer.side(u, -t, J, rec0)
    recs, us = tracer.turning_points(bwd[::-1] + [rec0] + fwd, bus[::-1] + [u] + fus)
    ends = []
    for side_recs, side_us, side_status, at_start in ((bwd, bus, bst, True),
                                                      (fwd, fus, fst, False)):
        if side_status != BRANCH_POINT or period != 2:
            continue
        ex = tracer.meets_1t([rec0] + side_recs, [u] + side_us)
        if ex is None:
            continue
        ue, spread = ex
        ends.append((at_start, ue, spread))
    for at_start, ue, spread in ends:
        w, s_, z = system.params(ue)
        o = shoot(w, s_, z, 1, (ue[0], ue[1]), exponent=system.n, model=model, rtol=rtol,
                  max_iter=20, max_steps=max_steps)
        last = recs[0] if at_start else recs[-1]
        o_last = shoot(last["omega"], last["sigma"], last["zeta"], 1, (ue[0], ue[1]),
                       exponent=system.n, model=model, rtol=rtol, max_iter=20,
                       max_steps=max_steps)
        system.maps += o.newton_iterations + o_last.newton_iterations + 2
        g_end = flip_function(o.monodromy) if o.converged else np.nan
        g_last = flip_function(o_last.monodromy) if o_last.converged else np.nan
        # the 2T fold curve ends on the 1T flip curve where the flip is degenerate (the 2T
        # branch born there turns back at once); a 2T grazing curve ends where the 1T flip
        # curve meets the 1T grazing curve
        other = {"fold": "fold_flip", "grazing": "flip_grazing"}.get(kind, "fold_flip")
        x_end = o.x0 if o.converged else ue[:2]
        M = o.monodromy if o.converged else np.full((2, 2), np.nan)
        M2 = M @ M          # the end vertex is the 1T orbit: its monodromy over 2T is M^2
        tr2, det2 = np.trace(M2), np.linalg.det(M2)
        pt = Codim2Point(other, int(period), w, s_, z, np.array(x_end, float),
                         o.multipliers if o.converged else np.full(2, np.nan, complex),
                         float(g_end), float(g_last), np.nan, float(spread))
        rec = dict(omega=w, sigma=s_, zeta=z, q0=x_end[0], v0=x_end[1], m11=M2[0, 0],
                   m12=M2[0, 1], m21=M2[1, 0], m22=M2[1, 1],
                   min_q=o.min_q if o.converged else np.nan,
                   max_q=o.max_q if o.converged else np.nan, fold=1.0 - tr2 + det2,
                   flip=1.0 + tr2 + det2,
                   grazing=(o.min_q - system.level) if o.converged else np.nan, asym=0.0,
                   step=np.nan, residual=o.residual, iterations=o.newton_iterations,
                   arclength=np.nan, flag=VERTEX_END | VERTEX_CODIM2, _codim2=pt)
        recs = [rec] + recs if at_start else recs + [rec]
    vert = {k: np.asarray([r[k] for r in recs], float) for k in VERTEX_FIELDS}
    codim2 = []
    for i, r in enumerate(recs):
        if "_codim2" in r:
            r["_codim2"].vertex = i
            codim2.append(r["_codim2"])
    # step and arclength along the final vertex list, in (q, q', a, b)
    pts = np.column_stack([vert["q0"], vert["v0"], vert[pair[0]], vert[pair[1]]])
    d = np.r_[0.0, np.linalg.norm(np.diff(pts, axis=0), axis=1)]
    vert["step"] = d
    vert["arclength"] = np.cumsum(d)
    curve.vertices = vert
    curve.codim2 = codim2
    curve.status = (bst, fst)
    curve.maps = system.maps
    curve.seconds = time.perf_counter() - t_start
    return curve
