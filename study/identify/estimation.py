"""The fit: the parameters of the model that best explain a measurement, and their 95 %
profile-likelihood intervals (docs/identify.md).

The objective is not smooth: a model jump that passes a measured point moves that point onto
another branch, a step in the log-likelihood. It is designed for it in three stages, each a
batch of independent tasks handed to a ``mapper`` (scheduler.stages.fit_tasks ships them to a Dask
cluster; :func:`in_process` runs them here):

1. **global** (:func:`cell_task`, one task per cell): a grid over (sigma, zeta[, n]) within the
   bounds (GLOBAL_SIGMA points in sigma, zeta geometric at most a factor GLOBAL_ZETA_RATIO
   apart, GLOBAL_EXPONENT in n), at each cell one pair of model sweeps (at twice the forward
   model's step: it only ranks the cells) and the log-likelihood maximised over f0 (a scan
   that lets no model jump pass two measured points at once, refined by Brent: f0 only
   stretches the frequency axis, no forward model) and over the noise model;
2. **local** from the best cell: Gauss-Newton with a trust region (scipy's least_squares,
   "trf") on the standardised residuals in the coordinates (log f0, sigma, log zeta[, n]), the
   noise model re-estimated between rounds (iteratively reweighted), the Jacobian by finite
   differences: its f0 column free, the others one forward model each, in one batch;
3. **profiles** (study.identify.profile_likelihood, one task per point): each parameter held
   at its estimate +- PROFILE_STEPS standard errors (of the Gauss-Newton covariance), the
   others re-optimised, and outwards (PROFILE_EXTEND) until the profile falls below the 95 %
   threshold or meets the parameter's bound. A profile point better than the optimum restarts
   the local stage from it (at most MAX_RESTARTS times).

Pure: numpy, scipy and the kernels through study.identify.forward_model. No Dask, no files.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from scipy.optimize import least_squares

from hertzmap.study.identify.forward_model import ForwardModel, forward_model
from hertzmap.study.identify.likelihood import Readings, best_f0
from hertzmap.study.identify.problem import FitProblem
from hertzmap.study.identify.profile_likelihood import (CLIFF, CLIFF_BISECTIONS, Coordinates,
                                                        best_local_f0, column, crossings,
                                                        interval, profile_point, residuals)

__all__ = ["GLOBAL_SIGMA", "GLOBAL_ZETA_RATIO", "GLOBAL_EXPONENT", "GLOBAL_STEP_FACTOR",
           "PROFILE_STEPS", "PROFILE_EXTEND", "MAX_RESTARTS", "FD_STEP", "Mapper", "FitResult",
           "cell_task", "forward_task", "profile_task", "run_task", "in_process",
           "global_grid", "fit"]

#: the global stage's grid: sigma values over its bounds, zeta values at most this factor
#: apart (geometric) over its bounds, n values over its bounds when fitted
GLOBAL_SIGMA, GLOBAL_ZETA_RATIO, GLOBAL_EXPONENT = 7, 2.0, 4
#: the global stage's forward models step this many times the forward model's step
GLOBAL_STEP_FACTOR = 2
#: profile points at the estimate +- these standard errors, then outwards at these
PROFILE_STEPS = (1.0, 2.0, 3.0)
PROFILE_EXTEND = (5.0, 8.0, 13.0, 21.0, 34.0)
#: local stages restarted from a better profile point at most
MAX_RESTARTS = 2
#: the finite-difference steps of the Jacobian in the coordinates (log f0, sigma, log zeta, n)
FD_STEP = {"f0": 1e-6, "sigma": 1e-4, "zeta": 1e-4, "exponent": 1e-4}
#: least-squares rounds of the local stage (the noise model re-estimated between), each of at
#: most LOCAL_EVALUATIONS residual evaluations, stopped when a step gains less than LOCAL_GAIN
#: in log L
LOCAL_ROUNDS, LOCAL_EVALUATIONS, LOCAL_GAIN = 4, 25, 0.05
#: least_squares' verbosity in the local stage (2: each iteration)
VERBOSE = 0

#: (label, task specs) -> their results in order: how a stage's batch of tasks runs
Mapper = Callable[[str, list], list]


# ---- the tasks (one spec in, one dict out: what a worker runs) ---------------------------------

def cell_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One cell of the global stage: the forward model at spec["theta"] = (sigma, zeta, n) over
    spec["problem"].omega, its log-likelihood maximised over f0 and the noise model."""
    t0, c0 = time.perf_counter(), time.process_time()
    problem: FitProblem = spec["problem"]
    sigma, zeta, n = spec["theta"]
    fm = forward_model(sigma, zeta, problem.omega, exponent=n, directions=problem.directions)
    f0, fit, _, _ = best_f0(problem, fm)
    return {"theta": (sigma, zeta, n), "f0": f0, "loglik": fit.loglik, "a": fit.a,
            "b": fit.b, "steps": fm.steps, "seconds": time.perf_counter() - t0,
            "cpu_seconds": time.process_time() - c0}


def forward_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One forward model (study.identify.forward_model) at spec["theta"] = (sigma, zeta, n)."""
    t0, c0 = time.perf_counter(), time.process_time()
    problem: FitProblem = spec["problem"]
    sigma, zeta, n = spec["theta"]
    fm = forward_model(sigma, zeta, problem.omega, exponent=n, directions=problem.directions)
    return {"model": fm, "seconds": time.perf_counter() - t0,
            "cpu_seconds": time.process_time() - c0}


def profile_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One profile point (study.identify.profile_likelihood.profile_point)."""
    return profile_point(spec)


_TASKS = {"cell": cell_task, "forward": forward_task, "profile": profile_task}


def run_task(spec: dict[str, Any]) -> dict[str, Any]:
    """The task of ``spec`` by its "kind" (cell, forward, profile)."""
    return _TASKS[spec["kind"]](spec)


def in_process(label: str, specs: list) -> list:
    """A mapper that runs each task here, in order."""
    return [run_task(s) for s in specs]


# ---- the result -------------------------------------------------------------------------------

@dataclass
class FitResult:
    """What a fit found (docs/identify.md; study.identify.fit_dataset makes it a Dataset).

    names: the parameters fitted (f0 first); estimate: their values; loglik: the maximum
    log-likelihood; a, b: the noise model there; se: the Gauss-Newton standard errors (in the
    coordinates u: log f0, sigma, log zeta, n); cov: their covariance. intervals: name -> (low,
    high, low_closed, high_closed). profiles: name -> (values, profile log-likelihoods, the
    other parameters at each: (k, names)). cells: the global stage's (theta (k, 3), f0 (k,),
    log-likelihood (k,)). model: the forward model at the estimate. stages: name -> (wall
    seconds, the tasks' seconds, their CPU seconds, tasks). restarts: local stages started
    again from a better profile point. forward_models: computed in all.
    """

    problem: FitProblem
    names: tuple[str, ...]
    estimate: dict[str, float]
    loglik: float
    a: float
    b: float
    se: np.ndarray
    cov: np.ndarray
    intervals: dict[str, tuple[float, float, bool, bool]]
    profiles: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
    cells: tuple[np.ndarray, np.ndarray, np.ndarray]
    model: ForwardModel
    stages: dict[str, tuple[float, float, float, int]] = field(default_factory=dict)
    restarts: int = 0
    forward_models: int = 0

    def identified(self, name: str) -> bool:
        """The profile leaves the 95 % threshold on both sides within the bounds."""
        _, _, lo, hi = self.intervals[name]
        return lo and hi


# ---- the stages -------------------------------------------------------------------------------

def global_grid(problem: FitProblem) -> list[tuple[float, float, float]]:
    """The global stage's cells (sigma, zeta, n) (module docstring)."""
    s_lo, s_hi = problem.bounds["sigma"]
    z_lo, z_hi = problem.bounds["zeta"]
    sigmas = np.linspace(s_lo, s_hi, GLOBAL_SIGMA)
    count = max(3, int(math.ceil(math.log(z_hi / z_lo) / math.log(GLOBAL_ZETA_RATIO))) + 1)
    zetas = np.geomspace(z_lo, z_hi, count)
    if "exponent" in problem.free:
        exponents = np.linspace(*problem.bounds["exponent"], GLOBAL_EXPONENT)
    else:
        exponents = np.array([problem.exponent])
    return [(float(s), float(z), float(n)) for s in sigmas for z in zetas for n in exponents]


class _Fit:
    """One fit's state: the problem, the mapper, the forward models computed (by theta)."""

    def __init__(self, problem: FitProblem, mapper: Mapper, report: Callable[[str], None]):
        self.problem = problem
        self.mapper = mapper
        self.report = report
        self.coords = Coordinates(problem)
        self.readings = Readings.of(problem)
        self.models: dict[tuple[float, float, float], ForwardModel] = {}
        self.stages: dict[str, list[float]] = {}
        self.computed = 0

    def run(self, label: str, stage: str, specs: list) -> list:
        t0 = time.perf_counter()
        out = self.mapper(label, specs) if specs else []
        cost = self.stages.setdefault(stage, [0.0, 0.0, 0.0, 0])
        cost[0] += time.perf_counter() - t0
        cost[1] += sum(float(r.get("seconds", 0.0)) for r in out)
        cost[2] += sum(float(r.get("cpu_seconds", 0.0)) for r in out)
        cost[3] += len(out)
        return out

    def theta(self, u) -> tuple[float, float, float]:
        return self.coords.theta(u, self.problem)

    def forward(self, us: list[np.ndarray], stage: str) -> list[ForwardModel]:
        """The forward models at each u (computed in one batch where not known)."""
        keys = [tuple(round(x, 13) for x in self.theta(u)) for u in us]
        todo = list(dict.fromkeys(k for k in keys if k not in self.models))
        specs = [{"kind": "forward", "problem": self.problem, "theta": k} for k in todo]
        for k, res in zip(todo, self.run("forward models", stage, specs)):
            self.models[k] = res["model"]
            self.computed += 1
        return [self.models[k] for k in keys]

    # -- global --
    def global_stage(self) -> tuple[np.ndarray, tuple]:
        coarse = dataclasses.replace(self.problem,
                                     omega=self.problem.omega[::GLOBAL_STEP_FACTOR])
        cells = global_grid(self.problem)
        specs = [{"kind": "cell", "problem": coarse, "theta": c} for c in cells]
        res = self.run("global grid", "global", specs)
        self.computed += len(res)
        thetas = np.array([r["theta"] for r in res])
        f0s = np.array([r["f0"] for r in res])
        lls = np.array([r["loglik"] for r in res])
        k = int(np.nanargmax(np.where(np.isfinite(lls), lls, -np.inf)))
        start = {"f0": f0s[k], "sigma": thetas[k, 0], "zeta": thetas[k, 1],
                 "exponent": thetas[k, 2]}
        self.report(f"global: {len(cells)} cells; best sigma {thetas[k, 0]:.4g}, zeta "
                    f"{thetas[k, 1]:.4g}" + (f", n {thetas[k, 2]:.4g}" if "exponent" in
                                              self.problem.free else "")
                    + f", f0 {f0s[k]:.6g} Hz (log-likelihood {lls[k]:.1f})")
        u0 = self.coords.to_u([start[n] for n in self.problem.free])
        return u0, (thetas, f0s, lls)

    # -- local --
    def jacobian(self, u: np.ndarray, a: float, b: float, stage: str) -> np.ndarray:
        """d pseudo-residuals / du at u for the noise model (a, b): the f0 column along each
        reading's branch (no forward model), each other column by a forward difference, one
        forward model at u + h each (one batch), a reading the step moves onto another branch
        left out of it (profile_likelihood.column)."""
        names = self.problem.free
        shifted, steps = [], []
        for k in range(1, len(names)):
            h = FD_STEP[names[k]]
            h = h if u[k] + h <= self.coords.upper[k] else -h
            v = u.copy()
            v[k] += h
            shifted.append(v)
            steps.append(h)
        fm, *others = self.forward([u] + shifted, stage)
        f0 = math.exp(u[0])
        R0, seg0, d_f0 = residuals(self.problem, fm, f0, a, b, self.readings)
        cols = [d_f0]
        for m, h in zip(others, steps):
            R1, seg1, _ = residuals(self.problem, m, f0, a, b, self.readings)
            cols.append(column(R0, seg0, R1, seg1, h))
        return np.column_stack(cols)

    def exact(self, u: np.ndarray, stage: str) -> tuple[np.ndarray, Any]:
        """u with f0 maximised exactly (its window 1e-3) and the NoiseFit there."""
        (fm,) = self.forward([u], stage)
        f0, fit = best_local_f0(self.problem, fm, math.exp(u[0]), 1e-3, self.readings)
        v = u.copy()
        v[0] = math.log(f0)
        return v, fit

    def local_stage(self, u0: np.ndarray) -> tuple[np.ndarray, Any]:
        u, fit = self.exact(self.coords.clip(u0), "local")
        for _ in range(LOCAL_ROUNDS):
            a, b = fit.a, fit.b

            def fun(x):
                (fm,) = self.forward([x], "local")
                return residuals(self.problem, fm, math.exp(x[0]), a, b, self.readings)[0]

            def jac(x, *_):
                return self.jacobian(x, a, b, "local")

            lower = self.coords.lower
            upper = self.coords.upper
            x0 = np.clip(u, lower + 1e-12 * np.abs(lower), upper - 1e-12 * np.abs(upper))
            # ftol: stop once a step gains less than LOCAL_GAIN in log L (least_squares' cost
            # is half the sum of squares, -log L + const); xtol: 1e-4 of a coordinate's
            # scale. The profiles find a better point left (a restart from it)
            cost = 0.5 * float(np.sum(fun(x0) ** 2))
            res = least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf",
                                x_scale="jac", max_nfev=LOCAL_EVALUATIONS,
                                ftol=LOCAL_GAIN / max(1.0, cost), xtol=1e-4, gtol=1e-8,
                                verbose=VERBOSE)
            self.report(f"  round: {res.nfev} evaluations, {res.njev} Jacobians, "
                        f"{res.message}")
            v, new = self.exact(res.x, "local")
            if not new.loglik > fit.loglik:
                break
            gain = new.loglik - fit.loglik
            moved = max(abs(new.a / fit.a - 1.0), abs(new.b / fit.b - 1.0))
            u, fit = v, new
            # another round with the noise model re-estimated, unless it hardly changed
            if gain < LOCAL_GAIN or moved < 0.05:
                break
        return u, fit

    # -- profiles --
    def profile_stage(self, u_hat: np.ndarray, fit, J: np.ndarray, cov: np.ndarray,
                      se: np.ndarray) -> tuple[dict, dict, dict | None]:
        """Each parameter's profile points until its interval is found (module docstring).
        Returns (intervals in u, profiles in u, a better point or None)."""
        names = self.problem.free
        points: dict[int, dict[float, dict]] = {j: {} for j in range(len(names))}
        base = {"kind": "profile", "problem": self.problem, "u_hat": u_hat, "J": J,
                "cov": cov, "se": se, "l_max": fit.loglik}

        def wanted(j: int, multiples) -> list[float]:
            out = []
            for k in multiples:
                for sign in (-1.0, 1.0):
                    x = float(np.clip(u_hat[j] + sign * k * se[j], self.coords.lower[j],
                                      self.coords.upper[j]))
                    if x != u_hat[j] and x not in points[j] and x not in out:
                        out.append(x)
            return out

        # first the nearest points (a better point there restarts the local stage cheaply)
        todo = {j: wanted(j, PROFILE_STEPS[:1]) for j in points}
        later = list(PROFILE_STEPS[1:])
        extend = list(PROFILE_EXTEND)
        bisected: dict[int, dict[bool, int]] = {j: {} for j in points}
        better = None
        while any(todo.values()):
            specs = [dict(base, index=j, value=x) for j, xs in todo.items() for x in xs]
            for r in self.run("profiles", "profiles", specs):
                points[r["index"]][r["value"]] = r
                self.computed += r["models"]
                if r["loglik"] > fit.loglik + 0.05 and (better is None or
                                                        r["loglik"] > better["loglik"]):
                    better = r
            if better is not None:
                return {}, points, better
            if later:
                todo = {j: wanted(j, later) for j in points}
                later = []
                continue
            todo = {}
            step = extend.pop(0) if extend else None
            for j in points:
                xs = sorted(points[j])
                vals = [points[j][x]["loglik"] for x in xs]
                lo, hi, lo_c, hi_c = interval(xs, vals, u_hat[j], fit.loglik,
                                              self.coords.lower[j], self.coords.upper[j])
                need = []
                if not lo_c and xs[0] > self.coords.lower[j] and step is not None:
                    need.append(max(self.coords.lower[j], u_hat[j] - step * se[j]))
                    if need[-1] >= xs[0]:      # the standard error is far too small: double
                        need[-1] = max(self.coords.lower[j],
                                       u_hat[j] - 2.0 * (u_hat[j] - xs[0]))
                if not hi_c and xs[-1] < self.coords.upper[j] and step is not None:
                    need.append(min(self.coords.upper[j], u_hat[j] + step * se[j]))
                    if need[-1] <= xs[-1]:
                        need[-1] = min(self.coords.upper[j],
                                       u_hat[j] + 2.0 * (xs[-1] - u_hat[j]))
                # an end on a cliff of the profile: its bracket halved
                for x_in, x_out, r_in, r_out in crossings(xs, vals, u_hat[j], fit.loglik):
                    halved = bisected[j].get(x_out < u_hat[j], 0)
                    if abs(r_out - r_in) > CLIFF and halved < CLIFF_BISECTIONS:
                        bisected[j][x_out < u_hat[j]] = halved + 1
                        need.append(0.5 * (x_in + x_out))
                need = [x for x in need if x not in points[j]]
                if need:
                    todo[j] = need
        intervals = {}
        for j, name in enumerate(names):
            xs = sorted(points[j])
            vals = [points[j][x]["loglik"] for x in xs]
            intervals[name] = interval(xs, vals, u_hat[j], fit.loglik, self.coords.lower[j],
                                       self.coords.upper[j])
        return intervals, points, None


def _covariance(J: np.ndarray, width: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cov, se) of the coordinates from the Jacobian of the pseudo-residuals: Gauss-Newton's
    (J^T J)^-1 with the bounds as a weak prior, (J^T J + diag(1 / width^2))^-1: a parameter
    the data hardly determine (a small column of J) then has a standard error of about its
    bounds' width instead of an unbounded one, and does not inflate those of the parameters
    it is correlated with beyond what its bounds allow (the columns scaled to unit norm for
    the inversion). A standard error above the width is the width."""
    prior = 1.0 / np.maximum(width, 1e-300) ** 2
    A = J.T @ J + np.diag(prior)
    scale = np.sqrt(np.diag(A))
    cov = np.linalg.inv(A / np.outer(scale, scale)) / np.outer(scale, scale)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    se = np.where(np.isfinite(se) & (se > 0.0) & (se < width), se, width)
    return cov, se


def fit(problem: FitProblem, mapper: Mapper = in_process,
        report: Callable[[str], None] = lambda s: None) -> FitResult:
    """Fit the problem's parameters (module docstring). ``mapper`` runs each stage's batch of
    tasks (default: here, in order); ``report`` receives one line per stage."""
    state = _Fit(problem, mapper, report)
    names = problem.free
    t0 = time.perf_counter()
    u0, cells = state.global_stage()
    restarts = 0
    while True:
        u_hat, best = state.local_stage(u0)
        J = state.jacobian(u_hat, best.a, best.b, "local")
        width = state.coords.upper - state.coords.lower
        cov, se = _covariance(J, width)
        values = state.coords.to_values(u_hat)
        report("local: " + ", ".join(f"{n} {v:.6g}" for n, v in zip(names, values))
               + f" (log-likelihood {best.loglik:.2f}, noise a {best.a:.3g}, b {best.b:.3g} N)")
        _, points, better = state.profile_stage(u_hat, best, J, cov, se)
        if better is None or restarts >= MAX_RESTARTS:
            if better is not None:
                report("profiles: a better point than the optimum again; kept the last")
            break
        restarts += 1
        report(f"profiles: a point {better['loglik'] - best.loglik:.2f} above the optimum: "
               "the local stage again from it")
        u0 = np.asarray(better["u"], float)
    to = state.coords.to_values
    intervals, profiles = {}, {}
    for j, name in enumerate(names):
        xs = sorted(points[j])
        lls = [points[j][x]["loglik"] for x in xs]
        # a better profile point left after the last restart: the interval about it
        top = max([best.loglik] + lls)
        lo, hi, lo_c, hi_c = interval(xs, lls, u_hat[j], top, state.coords.lower[j],
                                      state.coords.upper[j])

        def value(x: float, j=j) -> float:
            w = u_hat.copy()
            w[j] = x
            return float(to(w)[j])

        intervals[name] = (value(lo), value(hi), lo_c, hi_c)
        rows = np.array([points[j][x]["u"] for x in xs] + [u_hat])
        ll = np.array(lls + [best.loglik])
        order = np.argsort(rows[:, j], kind="stable")
        profiles[name] = (to(rows)[order, j], ll[order], to(rows)[order])
    (model,) = state.forward([u_hat], "local")
    values = state.coords.to_values(u_hat)
    stages = {k: (v[0], v[1], v[2], int(v[3])) for k, v in state.stages.items()}
    stages["total"] = (time.perf_counter() - t0, sum(v[1] for v in state.stages.values()),
                       sum(v[2] for v in state.stages.values()),
                       sum(int(v[3]) for v in state.stages.values()))
    return FitResult(problem=problem, names=names,
                     estimate={n: float(v) for n, v in zip(names, values)},
                     loglik=best.loglik, a=best.a, b=best.b, se=se, cov=cov,
                     intervals=intervals, profiles=profiles, cells=cells, model=model,
                     stages=stages, restarts=restarts, forward_models=state.computed)
