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
"""
from __future__ import annotations

from dataclasses import dataclass, field
from math import pi

import numpy as np

from kernels import status as st
from kernels._jit import kernel
from kernels.api import DEFAULT_MAX_STEPS, DEFAULT_RTOL, _check_exponent, _model_code, shoot
from kernels.integrate import N_HARMONICS, N_STATS
from kernels.model import contact_loss_level
from kernels.shooting import _map

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
    y = np.empty(6)
    f = np.empty(6)
    y_new = np.empty(6)
    f_new = np.empty(6)
    K = np.empty((16, 2))
    W = np.empty((7, 2))
    stats = np.zeros(N_STATS)
    harm = np.zeros((2, N_HARMONICS + 1))
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
                               float(self.zeta), int(m), _check_exponent(self.exponent),
                               _model_code(self.model), float(self.rtol), float(self.rtol),
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
