"""One-parameter continuation of periodic orbits (paper section 3.2, Fig. 6-10): a branch in
omega or sigma with its points' records, the fold, flip and grazing points located on it, and the
switch onto the 2T branch at a flip of the 1T orbit.

``continue_orbit`` follows F(u) = Phi_{mT}(x; p) - x = 0, u = (q, q', p), by the core's
pseudo-arclength predictor-corrector (kernels.continuation.core: dPhi/dp by BRANCH_DIFFERENCE,
central with step 1e-5; the corrector converges linearly at a rate ~1e-5, to |du| <= 1e-9
(1 + |u|)). Every loop is bounded (points, Newton iterations, secant iterations); failures come
back as status codes.

A sign change of a test function (fold, flip, grazing: kernels.continuation.core) between
consecutive points of a branch is refined by the Illinois variant of regula falsi on the chord
between them, each trial point corrected onto the branch on the hyperplane normal to the chord.
The accuracy reported with each located point is the final bracket width in omega (or sigma)
and the residual of the test function.

Branch switching at a flip: the 2T branch leaves the 1T orbit x* along the eigenvector e of the
multiplier -1, at constant parameter to first order: the first 2T point solves Phi_{2T}(x) = x on
the hyperplane e . (x - x*) = d. A 2T branch ends where it meets the 1T orbit again (another
flip: the 2T orbit and its T-shift merge, |Phi_T(x0) - x0| -> 0): status BRANCH_POINT.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.continuation import core
from hertzmap.kernels.continuation.core import (BOUNDARY, BRANCH_DIFFERENCE, BRANCH_POINT,
                                                BRANCH_STATUS, CLOSED, MAX_POINTS, START_FAIL,
                                                STEP_FAIL, System, adapt_step, branch_params,
                                                correct, fixed_point_residual, flip_function,
                                                floquet_multipliers, fold_function,
                                                illinois_bracket, illinois_trial, null_vector,
                                                predict_correct)
from hertzmap.kernels.model import DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL
from hertzmap.kernels.periodic_orbit import DEFAULT_MAX_STEPS

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
    param: str                        # "omega" or "sigma"
    status: int = START_FAIL
    points: dict = field(default_factory=dict)       # POINT_FIELDS -> 1-D arrays
    special: list = field(default_factory=list)      # SpecialPoint

    @property
    def status_name(self):
        return BRANCH_STATUS[self.status]

    def __len__(self):
        return len(self.points.get("omega", ()))

    def u(self, i):
        p = self.points
        return np.array([p["q0"][i], p["v0"][i], p[self.param][i]])


def _point_record(system, m, u, M, param, omega, sigma, polish=True):
    """Measures at a corrected point. The monodromy is the corrector's (|du| <= 1e-9 away);
    min q and the contact measures come from a shoot measure pass when ``polish``."""
    w, s = branch_params(u, param, omega, sigma)
    mu = floquet_multipliers(M)
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
        th = illinois_trial(ta, tb, ga, gb)
        up = ua + th * c
        r = correct(fun, up, normal)
        if r is None:
            return best
        u, M = r.u, r.M
        g = gfun(u, M)
        if not np.isfinite(g):
            return best
        width = abs(c[pidx]) * (tb - ta)
        best = (u, M, g, width, it)
        if g == 0.0:
            return (u, M, g, 0.0, it)
        ta, tb, ga, gb, side = illinois_bracket(th, g, ta, tb, ga, gb, side)
        width = min(abs(c[pidx]) * (tb - ta), abs(g / slope))
        best = (u, M, g, width, it)
        if (tb - ta) * nc <= tol * (1.0 + np.linalg.norm(u)) or abs(g) <= 1e-14:
            return best
    return best


# ---- one-parameter continuation -------------------------------------------------------------

def continue_orbit(zeta, x0, *, omega, sigma, period=1, param="omega", direction=1.0,
                   p_min=None, p_max=None, ds=0.01, ds_min=1e-6, ds_max=0.5, max_points=2000,
                   tangent=None, exponent=DEFAULT_EXPONENT, model=DEFAULT_LAW, rtol=DEFAULT_RTOL,
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
    fun = fixed_point_residual(system, m, param, float(omega), float(sigma), BRANCH_DIFFERENCE)
    branch = Branch(period=m, param=param)
    # the start point: Newton at fixed parameter
    u0 = np.array([x0[0], x0[1], p0], float)
    r = correct(fun, u0, np.array([0.0, 0.0, 1.0]), max_iter=20)
    if r is None:
        return branch
    u, J, M = r.u, r.J, r.M
    if tangent is None:
        t = null_vector(J)
        if t[2] * direction < 0:
            t = -t
    else:
        t = np.asarray(tangent, float) / np.linalg.norm(tangent)
        tt = core.tangent(J, t)
        t = t if tt is None else tt
    pts = {}
    rec = _point_record(system, m, u, M, param, omega, sigma, polish)
    rec["arclength"] = 0.0
    _append(pts, rec)
    recs = [rec]
    us = [u]
    u_start, x_start_shift = u.copy(), None
    if m == 2:
        phi_half, _, code = system.map(u[:2], *branch_params(u, param, omega, sigma), 1)
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
        r, t, h = predict_correct(lambda u_pred, normal: correct(fun, u_pred, normal), u_prev,
                                  t_prev, h, ds_min)
        if r is None:
            status = STEP_FAIL
            break
        un, Mn, it = r.u, r.M, r.iterations
        rec = _point_record(system, m, un, Mn, param, omega, sigma, polish)
        s_total += np.linalg.norm(un - u_prev)
        rec["arclength"] = s_total
        # a 2T branch that met the 1T orbit (checked first: the 2T fold function vanishes there)
        if m == 2 and stop_at_branch_point and (rec["minimal_period"] == 1 or (
                np.isfinite(rec["asym"]) and rec["asym"] <= 1e-6 * (1.0 + np.hypot(*un[:2])))
                or _crossed_1t(system, m, param, omega, sigma, u_prev, un)):
            w, s = branch_params(un, param, omega, sigma)
            branch.special.append(SpecialPoint("branch_point", m, float(w), float(s),
                                               un[:2].copy(), floquet_multipliers(Mn),
                                               rec["fold"], float(abs(un[2] - u_prev[2])), 0,
                                               len(us) - 1))
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
                    w, s = branch_params(ul, param, omega, sigma)
                    branch.special.append(SpecialPoint(kind, m, float(w), float(s),
                                                       ul[:2].copy(), floquet_multipliers(Ml),
                                                       float(gl), float(width), nev,
                                                       len(us) - 1))
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
        h = adapt_step(h, it, ds_max, h_min=ds_min)
    branch.status = status
    branch.points = {k: np.asarray(v, float) for k, v in pts.items()}
    return branch


def _crossed_1t(system, m, param, omega, sigma, ua, ub):
    """True when the 2T points ua, ub lie on either side of the 1T orbit (the vector
    x0 - Phi_T(x0) flips): the branch passed through a flip of the 1T orbit."""
    wa = system.map(ua[:2], *branch_params(ua, param, omega, sigma), 1)
    wb = system.map(ub[:2], *branch_params(ub, param, omega, sigma), 1)
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
        w, s = branch_params(u, param, omega, sigma)
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


def switch_at_flip(zeta, flip: SpecialPoint, *, d=0.02, exponent=DEFAULT_EXPONENT, model=DEFAULT_LAW,
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
    fun = fixed_point_residual(system, 2, param, flip.omega, flip.sigma, BRANCH_DIFFERENCE)
    p = flip.omega if param == "omega" else flip.sigma
    for dd in (d, d / 4, d / 16):
        u_star = np.array([flip.x0[0], flip.x0[1], p])
        normal = np.array([e[0], e[1], 0.0])
        u_pred = u_star + dd * normal
        r = correct(fun, u_pred, normal, max_iter=20)
        if r is None:
            continue
        u, J = r.u, r.J
        w, s = branch_params(u, param, flip.omega, flip.sigma)
        half, _, code = system.map(u[:2], w, s, 1)
        if code != st.CONVERGED or np.hypot(*(half - u[:2])) <= 1e-6:
            continue        # landed on the 1T orbit
        t = core.tangent(J, normal)
        return u[:2].copy(), float(w), float(s), t
    return None
