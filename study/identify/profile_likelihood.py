"""Profile likelihood: each parameter's profile and its 95 % interval.

The profile of a parameter p is P(x) = the log-likelihood maximised over every other parameter
(and the noise model) with p held at x; the 95 % interval is {x : P(x) >= L_max - 1.92}, 1.92
= chi-square(1)'s 0.95 quantile / 2 (Wilks). It is read from the signed root deviance r(x) =
sign(x - x_hat) sqrt(2 (L_max - P(x))), linear in x where the likelihood is quadratic, at
r = -1.96 and +1.96 (linear interpolation between the profile's points). Where P stays above
the threshold up to a parameter's bound, the interval is open there (it runs to the bound);
open at both bounds, the data do not determine the parameter: the fit says "not identified"
instead of printing a number (a measurement that never leaves the 1T response cannot
separate sigma from zeta). Where the profile drops by a cliff (a model jump passing a measured
point moves it onto another branch: the jump's frequency is known only to the measured
steps around it), the interval's end is the cliff's, its bracket halved until it is a
CLIFF_BISECTIONS-th power of 2 of the points' spacing.

A profile point (:func:`profile_point`, one task each) maximises over the other parameters by
Gauss-Newton iterations with the Jacobian of the fit's optimum (a chord method: each iteration
one forward model, the f0 column of the Jacobian evaluated afresh at every iterate for free,
each step at most a standard error per coordinate and halved back from the best point when
it does not gain), the noise model re-estimated at every iterate, and f0, when free,
maximised exactly at each (it only stretches the frequency axis: no forward model). It starts
from the optimum moved along the covariance (the quadratic model's conditional optimum) in
the directions the data determine. Every iterate's log-likelihood is a
lower bound of the profile, and the profile is the best of them.

Pure numpy; the forward models are the tasks' own (study.identify.forward_model).
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from hertzmap.study.identify.likelihood import (Readings, loglik, model_amplitudes,
                                                pseudo_residuals, pseudo_residuals_dm)
from hertzmap.study.identify.forward_model import forward_model
from hertzmap.study.identify.problem import FitProblem

__all__ = ["THRESHOLD", "R_CRITICAL", "PROFILE_ITERATIONS", "Coordinates", "residuals",
           "column", "best_local_f0", "profile_point", "interval", "crossings", "signed_root",
           "CLIFF", "CLIFF_BISECTIONS"]

#: chi-square(1) 0.95 quantile / 2: a profile within this of the maximum is inside the interval
THRESHOLD = 1.920729410347062
#: the signed root deviance at the 95 % interval's ends (standard normal 0.975 quantile)
R_CRITICAL = 1.959963984540054
#: Gauss-Newton iterations (forward models) of one profile point at most
PROFILE_ITERATIONS = 6
#: an interval's end whose bracket's signed roots differ by more than CLIFF (where a quadratic
#: profile's differ by about a standard error's worth, ~1) lies on a cliff of the profile (a
#: model jump passing a measured point): the bracket is halved, at most CLIFF_BISECTIONS times
CLIFF, CLIFF_BISECTIONS = 1.5, 3


class Coordinates:
    """The fit's internal coordinates u of the parameters (problem.free, f0 first): log f0,
    sigma, log zeta, n: each parameter where the likelihood is nearest to quadratic and its
    bounds a box."""

    def __init__(self, problem: FitProblem):
        self.names = problem.free
        self.log = np.array([n in ("f0", "zeta") for n in self.names])
        lo = np.array([problem.bounds[n][0] for n in self.names])
        hi = np.array([problem.bounds[n][1] for n in self.names])
        self.lower, self.upper = self.to_u(lo), self.to_u(hi)

    def to_u(self, values) -> np.ndarray:
        v = np.asarray(values, float)
        return np.where(self.log, np.log(np.maximum(v, 1e-300)), v)

    def to_values(self, u) -> np.ndarray:
        u = np.asarray(u, float)
        return np.where(self.log, np.exp(u), u)

    def clip(self, u) -> np.ndarray:
        return np.clip(u, self.lower, self.upper)

    def theta(self, u, problem: FitProblem) -> tuple[float, float, float]:
        """(sigma, zeta, exponent) of u: what one forward model is computed at."""
        v = dict(zip(self.names, self.to_values(u)))
        return (float(v["sigma"]), float(v["zeta"]),
                float(v.get("exponent", problem.exponent)))


def residuals(problem: FitProblem, fm, f0: float, a: float, b: float,
              readings: Readings) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R, segment, dR/dlog f0): the pseudo-residuals (study.identify.likelihood.
    pseudo_residuals, 2 r) of the readings at f0 under the noise model (a, b), the branch
    segment each reading is on (r,), and the derivative of R in log f0 along those branches
    (f0 only stretches the frequency axis: no forward model)."""
    m, _, segment, dm = model_amplitudes(problem, fm, f0)
    m = m.ravel()[readings.index]
    dm = dm.ravel()[readings.index]
    seg = segment[readings.index // 3]
    R = pseudo_residuals(readings.y, m, a, b)
    dR = pseudo_residuals_dm(readings.y, m, a, b) * np.tile(dm, 2)
    return R, seg, dR


def column(R0: np.ndarray, seg0: np.ndarray, R1: np.ndarray, seg1: np.ndarray,
           h: float) -> np.ndarray:
    """A Jacobian column by finite differences (R1 - R0) / h, zero for the readings the
    step moved onto another branch (a jump passed them: their difference is the jump's, not
    a derivative along the branch)."""
    col = (R1 - R0) / h
    moved = np.tile(seg0 != seg1, 2)
    return np.where(moved, 0.0, col)


def best_local_f0(problem: FitProblem, fm, f0: float, width: float,
                  readings: Readings) -> tuple[float, Any]:
    """f0 maximising the exact log-likelihood of ``fm`` within f0 exp(+-width) (Brent's
    bounded search), and its NoiseFit; f0 itself when nothing better is found."""
    lo, hi = problem.bounds["f0"]
    a, b = max(lo, f0 * math.exp(-width)), min(hi, f0 * math.exp(width))
    here = loglik(problem, fm, f0, readings)
    if not a < b:
        return f0, here
    # to 1e-7 of f0 (its standard error is ~1e-4 of it on 400 steps)
    res = minimize_scalar(lambda x: -loglik(problem, fm, x, readings).loglik, bounds=(a, b),
                          method="bounded", options={"xatol": 1e-7 * f0})
    fit = loglik(problem, fm, float(res.x), readings)
    return (float(res.x), fit) if fit.loglik > here.loglik else (f0, here)


def profile_point(spec: dict[str, Any]) -> dict[str, Any]:
    """One point of a profile (module docstring). spec: problem, u_hat (the optimum), l_max
    (its log-likelihood), J (the Jacobian d residuals / du at it, f0 column first), cov (the
    covariance of u there), index (the parameter held), value (its value, in u), se (u's
    standard errors). A point that stays 5 thresholds below l_max even with twice the gain
    its next step promises stops there (it is outside the interval whatever the rest).
    Returns the profile's log-likelihood at the point, where the other parameters went, the
    noise model, the forward models computed and the seconds."""
    t0, c0 = time.perf_counter(), time.process_time()
    problem: FitProblem = spec["problem"]
    coords = Coordinates(problem)
    r = Readings.of(problem)
    u_hat = np.asarray(spec["u_hat"], float)
    J = np.asarray(spec["J"], float)
    cov = np.asarray(spec["cov"], float)
    se = np.asarray(spec["se"], float)
    j = int(spec["index"])
    value = float(spec["value"])
    free = [k for k in range(u_hat.size) if k != j]
    width = coords.upper - coords.lower
    determined = se < width                 # the directions the data determine at all
    # the start: the conditional optimum of the quadratic model, in the determined directions
    u = u_hat.copy()
    if cov[j, j] > 0.0 and np.all(np.isfinite(cov[:, j])):
        shift = cov[:, j] / cov[j, j] * (value - u_hat[j])
        u = u_hat + np.where(determined, shift, 0.0)
    u[j] = value
    u = coords.clip(u)
    l_max = float(spec.get("l_max", math.inf))
    best: dict[str, Any] | None = None
    step = np.zeros(len(free))
    models = 0
    halvings = 0
    for _ in range(PROFILE_ITERATIONS):
        sigma, zeta, n = coords.theta(u, problem)
        fm = forward_model(sigma, zeta, problem.omega, exponent=n,
                           directions=problem.directions)
        models += 1
        f0 = math.exp(u[0])
        fit = loglik(problem, fm, f0, r)
        if j != 0:      # f0 free: maximised exactly (no forward model)
            f0, fit = best_local_f0(problem, fm, f0, 5.0 * max(se[0], 1e-6), r)
            u[0] = math.log(f0)
        if not np.isfinite(fit.loglik):
            if best is None:
                best = {"loglik": fit.loglik, "u": u.copy(), "a": fit.a, "b": fit.b}
            break
        if best is not None and fit.loglik <= best["loglik"]:
            # no better: back from the best point by half the step, twice at most (a cliff
            # of the profile next to the best point: a model jump passing a measured point)
            step = 0.5 * step
            halvings += 1
            if halvings > 2 or np.all(np.abs(step) <= 1e-3 * se[free]):
                break
            u = best["u"].copy()
            u[free] += step
            u = coords.clip(u)
            continue
        gain = math.inf if best is None else fit.loglik - best["loglik"]
        best = {"loglik": fit.loglik, "u": u.copy(), "a": fit.a, "b": fit.b}
        halvings = 0
        if gain < 1e-2:
            break
        # a Gauss-Newton step in the free coordinates with the optimum's Jacobian (its f0
        # column afresh) and the noise model here, its columns scaled, at most a standard
        # error per coordinate (a chord method's trust region)
        eps, _, d_f0 = residuals(problem, fm, f0, fit.a, fit.b, r)
        Jf = J[:, free].copy()
        if j != 0:
            Jf[:, 0] = d_f0
        norms = np.linalg.norm(Jf, axis=0)
        norms = np.where(norms > 0.0, norms, 1.0)
        scaled, *_ = np.linalg.lstsq(Jf / norms, -eps, rcond=1e-8)
        step = scaled / norms
        if not np.all(np.isfinite(step)):
            break
        step = np.clip(step, -se[free], se[free])
        if np.all(np.abs(step) <= 1e-3 * se[free]):
            break
        # far outside the interval, even with twice the gain the step promises (the sum of
        # squares is -2 log L): the profile there is below the threshold whatever the rest
        predicted = 0.5 * (float(eps @ eps) - float(np.sum((eps + Jf @ step) ** 2)))
        if fit.loglik + 2.0 * max(predicted, 0.0) < l_max - 5.0 * THRESHOLD:
            break
        u = u.copy()
        u[free] += step
        u = coords.clip(u)
    return {"index": j, "value": value, "loglik": best["loglik"], "u": best["u"],
            "a": best["a"], "b": best["b"], "models": models,
            "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0}


def signed_root(x, values, x_hat: float, l_max: float) -> np.ndarray:
    """r(x) = sign(x - x_hat) sqrt(2 (l_max - P(x))) of a profile P (values) at x."""
    x = np.asarray(x, float)
    d = 2.0 * np.maximum(l_max - np.asarray(values, float), 0.0)
    return np.sign(x - x_hat) * np.sqrt(d)


def crossings(x, values, x_hat: float, l_max: float) -> list[tuple[float, float, float, float]]:
    """The brackets (x_in, x_out, r_in, r_out) of a profile's points where its signed root
    first crosses -R_CRITICAL below x_hat and +R_CRITICAL above (one per side found)."""
    x = np.asarray(x, float)
    order = np.argsort(x)
    x, p = x[order], np.asarray(values, float)[order]
    xs = np.r_[x[x < x_hat], x_hat, x[x > x_hat]]
    ps = np.r_[p[x < x_hat], l_max, p[x > x_hat]]
    rs = signed_root(xs, ps, x_hat, l_max)
    k = int(np.flatnonzero(xs == x_hat)[0])
    out = []
    for i in range(k, 0, -1):
        if rs[i - 1] <= -R_CRITICAL:
            out.append((xs[i], xs[i - 1], rs[i], rs[i - 1]))
            break
    for i in range(k, xs.size - 1):
        if rs[i + 1] >= R_CRITICAL:
            out.append((xs[i], xs[i + 1], rs[i], rs[i + 1]))
            break
    return out


def interval(x, values, x_hat: float, l_max: float, lower: float,
             upper: float) -> tuple[float, float, bool, bool]:
    """(low, high, low_closed, high_closed): the 95 % interval of a profile (x increasing,
    its values P), read where the signed root crosses -+R_CRITICAL (linear interpolation
    between the profile's points around the optimum x_hat, l_max). A side whose profile does
    not cross before the parameter's bound is open: its end is the bound."""
    x = np.asarray(x, float)
    order = np.argsort(x)
    x, p = x[order], np.asarray(values, float)[order]
    xs = np.r_[x[x < x_hat], x_hat, x[x > x_hat]]
    ps = np.r_[p[x < x_hat], l_max, p[x > x_hat]]
    rs = signed_root(xs, ps, x_hat, l_max)
    k = int(np.flatnonzero(xs == x_hat)[0])
    low, low_closed = lower, False
    for i in range(k, 0, -1):           # from the optimum down
        if rs[i - 1] <= -R_CRITICAL:
            low = _cross(xs[i - 1], xs[i], rs[i - 1], rs[i], -R_CRITICAL)
            low_closed = True
            break
    high, high_closed = upper, False
    for i in range(k, xs.size - 1):
        if rs[i + 1] >= R_CRITICAL:
            high = _cross(xs[i], xs[i + 1], rs[i], rs[i + 1], R_CRITICAL)
            high_closed = True
            break
    return float(low), float(high), low_closed, high_closed


def _cross(x0: float, x1: float, r0: float, r1: float, level: float) -> float:
    if r1 == r0:
        return 0.5 * (x0 + x1)
    return x0 + (level - r0) * (x1 - x0) / (r1 - r0)
