"""Discovery along a grid line: every periodic response, isolas included, and the bifurcation
points between them (paper Fig. 6-10).

A line is a set of omega values at fixed (sigma, zeta). Discovery runs in three stages:

1. **Seeds.** The block solver's sweep (study.solve.point: linear 1T response, MMS 2T seeds, flip
   eigenvectors, neighbours swept both ways), plus **transients** started from several initial
   states (a deterministic Halton set over q in [-6, 4], q' in [-5, 5], plus the static point) at
   a subset of the line's points: the state after an even number of forcing periods seeds a 2T
   solve (a 2T solve landing on the 1T orbit is the 1T orbit). Transients reach every stable
   orbit whose basin they enter, isolas included (paper Fig. 8), without hand-given seeds.
2. **Continuation** (kernels.continuation): each solution not yet on a traced branch is
   continued in omega both ways across the line (pseudo-arclength: through folds and loss of
   contact), which also yields the unstable halves of isolas and hysteresis loops. At every flip
   of a 1T branch the 2T branch is switched onto and traced. Every branch is intersected with
   the grid values of omega (Newton at fixed omega from the interpolated branch point).
3. **Bifurcation points.** Sign changes of the fold, flip and grazing test functions between
   consecutive points of a branch are refined on the branch (kernels.continuation.branch);
   2T branches ending on the 1T orbit give "branch_point" entries (the flip seen from 2T).

Distinct solutions are kept once (the identity rule of study.orbit_rules: invariants min q, max q,
trace M, which do not change under the T-shift of a 2T orbit). Each is classified as in paper
Fig. 6 (study.orbit_rules classes). ``benchmarks/archive/discover_line.py`` prints what a line holds.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from hertzmap.kernels import simulate
from hertzmap.kernels import continuation as cont
from hertzmap.kernels import status as st
from hertzmap.kernels.model import DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL
from hertzmap.study.orbit_rules import ORBIT_CLASSES, class_code
from hertzmap.study.solve.line import grid_crossings
from hertzmap.study.solve.point import is_known, merge_new_orbits, shoot_seeds_minimal, solve_point
from hertzmap.study.solve.seeds import initial_states, mms_seeds

def transient_periods(omega, zeta, min_periods=40, max_periods=400):
    """An even number of forcing periods lasting about 3 / zeta (transients decay like
    exp(-zeta t)), within [min_periods, max_periods]."""
    T = 2.0 * np.pi / omega
    n = int(np.ceil(3.0 / max(zeta, 1e-12) / T))
    n = min(max(n, min_periods), max_periods)
    return n + (n % 2)


def transient_seeds(omega, sigma, zeta, count=16, *, exponent=DEFAULT_EXPONENT,
                    model=DEFAULT_LAW, rtol=DEFAULT_RTOL):
    """End states of transients from ``initial_states(count)`` (at tau = 0 mod 2T)."""
    n = transient_periods(omega, zeta)
    seeds = []
    for x0 in initial_states(count):
        h = simulate(omega, sigma, zeta, x0, periods=n, samples_per_period=1, exponent=exponent,
                     model=model, rtol=max(rtol, 1e-8), max_steps=200_000)
        f = h["final"]
        if h["status"] == st.CONVERGED and np.all(np.isfinite(f)) and np.all(np.abs(f) < 1e3):
            seeds.append((float(f[0]), float(f[1])))
    return seeds


@dataclass
class LineResult:
    omega: np.ndarray
    sigma: float
    zeta: float
    solutions: list                       # per grid point: list of solution dicts (study.block)
    branches: list = field(default_factory=list)
    special: list = field(default_factory=list)    # dicts (kernels.continuation.SpecialPoint)
    seconds: dict = field(default_factory=dict)

    def classes(self):
        """(len(omega), 8) counts of solutions per orbit class (study.orbit_rules codes 1..8 in
        columns 0..7)."""
        out = np.zeros((len(self.omega), len(ORBIT_CLASSES) - 1), int)
        for i, sols in enumerate(self.solutions):
            for s in sols:
                out[i, class_code(s) - 1] += 1
        return out


def _near(sol, guesses, tol=1e-3):
    """sol's start point (or, for 2T, its T-shift is not checked) is within tol of a traced
    branch's interpolated point at the same grid omega."""
    x = sol["x0"]
    return any(p == sol["period"] and np.hypot(*(x - g)) <= tol * (1.0 + np.hypot(*x))
               for p, g in guesses)


def _covered(sol, sols):
    return is_known(sol, sols)


def _same_special(a, b):
    return (a["kind"] == b["kind"] and a["period"] == b["period"]
            and abs(a["omega"] - b["omega"]) <= 1e-6 * (1.0 + abs(a["omega"]))
            and abs(a["sigma"] - b["sigma"]) <= 1e-9)


def discover_line(omega, sigma, zeta, *, periods=(1, 2), exponent=DEFAULT_EXPONENT,
                  model=DEFAULT_LAW, rtol=DEFAULT_RTOL, transients=16, transient_points=12, continuation=True,
                  max_branches=16, max_points=1500, sweep=True, initial=None,
                  debug=False) -> LineResult:
    """Every periodic response found along the line ``omega`` at (sigma, zeta).

    transients: initial states per transient point (0: none); transient_points: how many of
    the line's points (evenly spread) get transients. continuation: trace branches (else the
    grid solutions come from the seeds only). Returns a LineResult (solutions per grid point,
    branches, located fold/flip/grazing/branch points, timings). ``initial``: solutions per
    grid point already found (lists of study.solve.point solution dicts); then no sweep is run.
    """
    omega = np.asarray(omega, float)
    periods = tuple(int(p) for p in periods)
    options = dict(exponent=float(exponent), model=model, rtol=float(rtol))
    sols = [[] for _ in omega] if initial is None else [list(x) for x in initial]
    sweep = sweep and initial is None
    t0 = time.perf_counter()
    seconds = {}
    order = np.argsort(omega, kind="stable")
    # 1. sweep seeds, both ways
    if sweep:
        mms = mms_seeds(omega, sigma, zeta) if 2 in periods else [()] * omega.size
        for sw in (order, order[::-1]):
            prev = []
            for i in sw:
                found, _ = solve_point(omega[i], sigma, zeta, periods, prev, options, True,
                                       mms[i])
                merge_new_orbits(sols[i], found)
                prev = found
    seconds["sweep"] = time.perf_counter() - t0
    # transients at evenly spread points
    t1 = time.perf_counter()
    if transients > 0 and omega.size:
        picks = np.unique(np.round(np.linspace(0, omega.size - 1,
                                               min(transient_points, omega.size))).astype(int))
        for i in order[picks]:
            seeds = transient_seeds(omega[i], sigma, zeta, transients, **options)
            if seeds:
                found = shoot_seeds_minimal(omega[i], sigma, zeta, 2, seeds, options)
                merge_new_orbits(sols[i], [s for s in found
                                       if s["period"] in periods and s["period"] <= 2])
    seconds["transients"] = time.perf_counter() - t1
    result = LineResult(omega, float(sigma), float(zeta), sols, seconds=seconds)
    if not continuation or omega.size < 2:
        seconds["total"] = time.perf_counter() - t0
        return result
    # 2. continuation from every solution not yet on a traced branch
    t2 = time.perf_counter()
    span = omega.max() - omega.min()
    step = span / max(omega.size - 1, 1)
    w_lo, w_hi = max(omega.min() - step, 1e-3), omega.max() + step
    traced = [[] for _ in omega]           # solutions that lie on a traced branch
    guesses = [[] for _ in omega]          # (period, interpolated branch point) at grid points
    queue = [(i, s) for i in order for s in sols[i]]
    queue.sort(key=lambda t: (not t[1]["stable"], t[1]["period"]))
    flips_done = []
    copt = dict(exponent=float(exponent), model=model, rtol=float(rtol))
    ds = min(0.01, 0.5 * step)

    def absorb(branch):
        result.branches.append(branch)
        by_point = {}
        for i, x in grid_crossings(branch, omega):
            by_point.setdefault(i, []).append(x)
            guesses[i].append((branch.period, np.asarray(x)))
        for i, xs in by_point.items():
            got = shoot_seeds_minimal(omega[i], sigma, zeta, branch.period, xs, options)
            got = [g for g in got if g["period"] == branch.period]
            merge_new_orbits(traced[i], got)
            merge_new_orbits(sols[i], got)
        for sp in branch.special:
            d = sp.as_dict()
            d["branch"] = len(result.branches) - 1
            if not any(_same_special(d, e) for e in result.special):
                result.special.append(d)

    def trace(x0, w0, m, tangent=None):
        pieces = []
        dirs = (None,) if tangent is not None else (1.0, -1.0)
        for direction in dirs:
            b = cont.continue_orbit(zeta, x0, omega=w0, sigma=sigma, period=m, param="omega",
                                    direction=direction or 1.0, tangent=tangent, p_min=w_lo,
                                    p_max=w_hi, ds=ds, max_points=max_points,
                                    dp_max=0.5 * step, **copt)
            if b.status != cont.START_FAIL:
                absorb(b)
                pieces.append(b)
            if b.status == cont.CLOSED:
                break
        return pieces

    n_branches = 0
    while queue and n_branches < max_branches:
        i, s = queue.pop(0)
        if _covered(s, traced[i]) or s["period"] not in (1, 2):
            continue
        pieces = trace(s["x0"], omega[i], s["period"])
        if debug:
            print("trace from", omega[i], s["period"], s["stable"], s["ptp"],
                  [(b.status_name, len(b)) for b in pieces])
        n_branches += 1
        merge_new_orbits(traced[i], [s])
        # branch switching at the flips of 1T branches
        if 2 in periods:
            for b in pieces:
                for sp in b.special:
                    if sp.kind != "flip" or sp.period != 1:
                        continue
                    if any(abs(sp.omega - f) <= max(1e-6, 0.5 * step) for f in flips_done):
                        continue
                    flips_done.append(sp.omega)
                    sw = cont.switch_at_flip(zeta, sp, **copt)
                    if sw is None:
                        continue
                    x2, w2, _, tan = sw
                    for b2 in trace(x2, w2, 2, tangent=tan):
                        for sp2 in b2.special:
                            if sp2.kind == "branch_point":
                                flips_done.append(sp2.omega)
                    n_branches += 1
        queue = [(k, q) for (k, q) in queue if not _covered(q, traced[k])
                 and not _near(q, guesses[k])]
    seconds["continuation"] = time.perf_counter() - t2
    # the solutions per point, ordered as the block solver does (1T first, then by ptp)
    for i in range(omega.size):
        one = sorted([s for s in sols[i] if s["period"] == 1], key=lambda s: s["ptp"])
        two = sorted([s for s in sols[i] if s["period"] == 2], key=lambda s: s["ptp"])
        sols[i] = one + two
    result.special.sort(key=lambda d: (d["kind"], d["period"], d["omega"]))
    seconds["total"] = time.perf_counter() - t0
    return result
