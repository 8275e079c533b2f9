"""What a run costs and where its time goes: one script, a subcommand per measurement.

    .venv/bin/python benchmarks/run_cost.py grid [--every 4]        (default study, every 4th line)
    .venv/bin/python benchmarks/run_cost.py census [--lines 8]      (the vibro-impact scene's lines)
    .venv/bin/python benchmarks/run_cost.py curves [--pairs 3]      (about 10 min on 2 cores)
    .venv/bin/python benchmarks/run_cost.py throughput [--ceiling]  (1 and 2 Dask workers, ~1 min)
    .venv/bin/python benchmarks/run_cost.py task-size [--study scenes/fine_map.toml]
    .venv/bin/python benchmarks/run_cost.py store --vs OTHER/.venv/bin/python
    .venv/bin/python benchmarks/run_cost.py scale [--workers 8,32,64] [--tasks 1000]

* ``grid``: solver time per stored orbit against the kernel's per orbit, and where the rest goes
  (phases, shooting rows by outcome, the census's transients), blocks solved in this process;
* ``census``: where a census scene's time goes: shooting against the attractor census, CPU of
  this process;
* ``curves``: a traced curve's cost against the grid's ways of getting the same curve, and the
  default scene with and without curves (ABBA);
* ``throughput``: a small study on 1 and 2 Dask workers: points/s, Dask's overhead per task,
  peak memory, the error estimate; ``--ceiling``: two solver processes against one, no Dask;
* ``task-size``: one study with two ``--task-seconds`` targets in ABBA rounds: the grid's wall
  and the client's CPU;
* ``store``: bytes, files and write time of a store, this checkout's against another's, in
  ABBA rounds;
* ``scale``: the per-task costs a large study pays besides its solves (client, scheduler,
  store, many workers), for docs/running.md's "Scale on paper".

``run_cost.py SUBCOMMAND --help`` says what each measures and how. The A/B comparisons among
them run through benchmarks/abba.py (same run, ABBA rounds, ratios pair by pair).
``run_summary`` reads back the figures a ``hertzmap run`` prints (cold_start.py uses it too).
"""
from __future__ import annotations

import argparse
import inspect
import io
import json
import os
import pickle
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.abba import abba, load_average, load_line  # noqa: E402


# -- the figures of a `hertzmap run` summary ---------------------------------------------------

#: field -> pattern of the summary line that prints it (its first group: seconds)
PATTERNS = {
    "setup": r"setup ([\d.]+) s",
    "wall": r"points in ([\d.]+) s wall",
    "compute": r"task compute ([\d.]+) s",
    "curves": r"curves: .*?([\d.]+) s wall \([\d.]+ s loading",
}


def run_summary(text: str) -> dict[str, float | None]:
    """The figures of a ``hertzmap run`` summary (scheduler.report and scheduler.curve_tasks
    print it), read back by the benchmarks that time whole runs: setup, grid wall, task compute
    and the curve stage, in seconds; a field its text does not print is None (``curves``
    when the run traced none)."""
    found = {}
    for name, pattern in PATTERNS.items():
        m = re.search(pattern, text)
        found[name] = float(m.group(1)) if m else None
    return found


# -- grid: per stored orbit against the kernel -------------------------------------------------

def cmd_grid(a) -> int:
    """What a grid pays per stored orbit against what the kernel pays for the same orbit, one
    run (default: every 4th sigma line of the default study; ``--every 1``: all 77 lines, ~1 min
    of one core).

    1. **Grid.** The study's blocks (one omega line each, study.solve.block.solve_block with
       the study's own options, in this process, no Dask), every ``--every``-th sigma line:
       solver time per stored orbit (converged slots in the returned arrays).
    2. **Kernel.** A sample of those stored orbits (``--sample``, seeded) re-solved in one batch
       by the numba entry point (kernels.shooting.shoot_batch_into, the study's rtol, exponent
       and harmonics) from a guess 1e-2 away in q0 and q'0: time per orbit, the fastest of 5
       rounds. Printed: grid per stored orbit / kernel per orbit (issue 16's target: <= 3x).
    3. **Where the rest goes.** The same lines again with every shooting call timed row by row
       (each seed solved as a batch of one, so each has its own time; the per-call overhead of
       a few us is in these figures, and their sum is printed against the plain run's). The
       rows are classed by outcome: *stored* (the first converged solve of an orbit that ends
       in a slot), *again* (a converged solve of an orbit the point already had: the way down
       of the sweep, two seeds onto one orbit, re-solves at the minimal period), *not stored*
       (converged, but no slot holds it: a 2T solve onto the 1T orbit, more orbits than
       slots), *failed* (no convergence: exploratory seeds, continuation past a fold). The
       phases' times (sweeps, fold turning, census) are the LineSearch's own. Outside the
       shooting calls: the census's transients (its batch kernel and Lyapunov exponent), the
       period maps of the continuation (kernels.continuation.System.map: the fold turning's
       arc-length paths), and the solver's Python between kernel calls.
    4. **What the target leaves.** 3x the kernel per stored orbit, against the work no search
       of these orbits can skip: their first solves and the census's transients (which the
       census runs whatever the search found).
    """
    from hertzmap.kernels import attractors as attractors_mod
    from hertzmap.kernels import continuation as cont_mod
    from hertzmap.kernels.shooting import shoot_batch_into
    from hertzmap.study.solve import block as block_mod
    from hertzmap.study.solve import census as census_mod
    from hertzmap.study.solve import line as line_mod
    from hertzmap.study.solve import point as point_mod
    from hertzmap.study.spec import load_study

    study = load_study(a.study)
    kw = study.solver_kwargs()
    print(f"{study.name}: every {a.every}th sigma line; load average "
          + load_average(), flush=True)
    # compile (or load) everything first: the first line would otherwise pay it
    first = next(_grid_lines(study, a.every))
    block_mod.solve_block(first[0][:8], first[1], first[2], **kw)

    results, grid_s = _solve_grid(study, a.every)
    stored = _stored_orbits(results)
    points = sum(r[2].size for r in results)
    rng = np.random.default_rng(16)
    pick = rng.choice(len(stored), size=min(a.sample, len(stored)), replace=False)
    k_per, k_ok = _kernel_time(stored[pick], kw)
    g_per = grid_s / len(stored)
    print(f"grid: {grid_s:.2f} s of solver time for {points} points, {len(stored)} stored orbits: "
          f"{g_per * 1e6:.0f} us per stored orbit ({grid_s / points * 1e3:.2f} ms per point)")
    print(f"kernel: {len(pick)} of them from a guess 1e-2 away in one batch: "
          f"{k_per * 1e6:.1f} us per orbit (fastest of 5; {k_ok} converged back to the stored "
          f"start point)")
    print(f"grid per stored orbit / kernel per orbit: {g_per / k_per:.1f}x (target <= 3x)",
          flush=True)
    if a.no_breakdown:
        return 0

    rec = _Recorder()
    phases = defaultdict(float)
    point_mod.shoot_batch_into = rec
    # the other kernels' time: the census's transients, the continuation's period maps
    kernel_secs = defaultdict(float)

    def timed_kernel(fn, key):
        def call(*args, **kws):
            t0 = time.perf_counter()
            try:
                return fn(*args, **kws)
            finally:
                kernel_secs[key] += time.perf_counter() - t0
        return call
    system_map = cont_mod.System.map
    census_mod.attractor_batch_into = timed_kernel(census_mod.attractor_batch_into,
                                                   "census transients")
    census_mod.lyapunov_into = timed_kernel(census_mod.lyapunov_into, "census transients")
    cont_mod.System.map = timed_kernel(cont_mod.System.map, "continuation maps")
    originals = {}
    for name, key in (("sweep", "sweeps"), ("turn_folds", "fold turning"),
                      ("run_census", "census")):
        fn = getattr(line_mod.LineSearch, name)
        originals[name] = fn

        def timed(self, *args, _fn=fn, _key=key, **kws):
            t0 = time.perf_counter()
            try:
                return _fn(self, *args, **kws)
            finally:
                phases[_key] += time.perf_counter() - t0
        setattr(line_mod.LineSearch, name, timed)
    try:
        results2, grid2 = _solve_grid(study, a.every)
    finally:
        point_mod.shoot_batch_into = shoot_batch_into
        for name, fn in originals.items():
            setattr(line_mod.LineSearch, name, fn)
        census_mod.attractor_batch_into = attractors_mod.attractor_batch_into
        census_mod.lyapunov_into = attractors_mod.lyapunov_into
        cont_mod.System.map = system_map
    same = all(np.array_equal(r1[3]["q0"], r2[3]["q0"], equal_nan=True)
               for r1, r2 in zip(results, results2))
    secs, count = _classify(rec, stored)
    shoot_total = sum(secs.values())
    print(f"\nbreakdown (row by row; {grid2:.2f} s in all against {grid_s:.2f} s plain; "
          f"the same stored orbits: {same}):")
    print(f"  {'phase':28s} {'s':>7s} {'share':>6s}")
    for key in ("sweeps", "fold turning", "census"):
        print(f"  {key:28s} {phases[key]:7.2f} {phases[key] / grid2:6.1%}")
    print(f"  {'shooting calls (all phases)':28s} {shoot_total:7.2f} {shoot_total / grid2:6.1%}")
    print(f"  {'class of shooting row':28s} {'s':>7s} {'share':>6s} {'rows':>7s} {'us/row':>7s}")
    for cls in sorted(secs, key=lambda c: -secs[c]):
        print(f"  {cls:28s} {secs[cls]:7.2f} {secs[cls] / grid2:6.1%} {count[cls]:7d} "
              f"{secs[cls] / count[cls] * 1e6:7.0f}")
    rest = grid2 - shoot_total
    print(f"  {'outside shooting calls':28s} {rest:7.2f} {rest / grid2:6.1%}")
    for key in ("census transients", "continuation maps"):
        print(f"    {key:26s} {kernel_secs[key]:7.2f} {kernel_secs[key] / grid2:6.1%}")
    python = rest - sum(kernel_secs.values())
    print(f"    {'Python (solver, no kernel)':26s} {python:7.2f} {python / grid2:6.1%}")
    print(f"stored orbits {len(stored)}; first solves of them {count['stored']} "
          f"({secs['stored'] / max(1, count['stored']) * 1e6:.0f} us each, row by row)")
    # what the target leaves: 3x the kernel per stored orbit, against the work no search of
    # these orbits can skip (their first solves, and the census's transients, which the
    # census needs whatever the search)
    budget = 3.0 * k_per * len(stored)
    floor = secs["stored"] + kernel_secs["census transients"]
    print(f"the target's budget, 3 x {k_per * 1e6:.1f} us x {len(stored)} stored orbits: "
          f"{budget:.2f} s; the first solves of the stored orbits and the census's transients "
          f"alone: {floor:.2f} s ({floor / budget:.2f}x the budget)")
    return 0


def _grid_lines(study, every: int):
    omega = study.axis("omega")
    sigma = study.axis("sigma")
    zeta = study.axis("zeta")
    for j in range(0, sigma.size, every):
        for k in range(zeta.size):
            yield omega, sigma[j:j + 1], zeta[k:k + 1]


def _solve_grid(study, every: int):
    from hertzmap.study.solve import block as block_mod

    kw = study.solver_kwargs()
    out, seconds = [], 0.0
    for omega, sigma, zeta in _grid_lines(study, every):
        t0 = time.perf_counter()
        arrays = block_mod.solve_block(omega, sigma, zeta, **kw)
        seconds += time.perf_counter() - t0
        out.append((sigma[0], zeta[0], omega, arrays))
    return out, seconds


def _stored_orbits(results):
    """(omega, sigma, zeta, period, q0, v0, min_q, max_q, ptp, trace of M) of every converged
    slot."""
    from hertzmap.kernels import status as st

    rows = []
    for sigma, zeta, omega, a in results:
        ok = a["status"][:, 0, 0, :] == st.CONVERGED
        for i, s in zip(*np.nonzero(ok)):
            rows.append((omega[i], sigma, zeta, int(a["period"][i, 0, 0, s]),
                         a["q0"][i, 0, 0, s], a["v0"][i, 0, 0, s],
                         a["min_q"][i, 0, 0, s], a["max_q"][i, 0, 0, s],
                         a["ptp"][i, 0, 0, s], float(np.sum(a["multipliers"][i, 0, 0, s]).real)))
    return np.array(rows, float).reshape(-1, 10)


def _kernel_time(orbits: np.ndarray, kw: dict, rounds: int = 5):
    from hertzmap.kernels import status as st
    from hertzmap.kernels.model import MODELS
    from hertzmap.kernels.periodic_orbit import DEFAULT_MAX_STEPS
    from hertzmap.kernels.shooting import F, N_FIELDS, shoot_batch_into
    from hertzmap.study.solve import point as point_mod

    n = len(orbits)
    w, s, z = (np.ascontiguousarray(orbits[:, c]) for c in range(3))
    m = orbits[:, 3].astype(np.int64)
    q = np.ascontiguousarray(orbits[:, 4] + 1e-2)
    v = np.ascontiguousarray(orbits[:, 5] + 1e-2)
    rtol = float(kw.get("rtol", 1e-10))
    out = np.empty((n, N_FIELDS))
    args = (w, s, z, m, q, v, float(kw.get("exponent", 1.5)), MODELS[kw.get("model", "hertz")],
            rtol, rtol, point_mod.MAX_ITER_1T, 1.0, DEFAULT_MAX_STEPS,
            bool(kw.get("harmonics", True)), out)
    shoot_batch_into(*args)
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        shoot_batch_into(*args)
        best = min(best, time.perf_counter() - t0)
    back = np.abs(out[:, F["q0"]] - orbits[:, 4]) <= 1e-6 * (1 + np.abs(orbits[:, 4]))
    ok = (out[:, F["status"]] == st.CONVERGED) & back
    return best / n, int(ok.sum())


class _Recorder:
    """Wraps the shooting entry point of study.solve.point: each row solved alone and timed."""

    def __init__(self):
        from hertzmap.kernels.shooting import F, shoot_batch_into

        self.kernel, self.F = shoot_batch_into, F
        # (omega, sigma, zeta, period, seconds, status, q0, v0, min_q, max_q, ptp, trace of M)
        self.rows = []

    def __call__(self, w, s, z, m, q, v, *rest):
        out, F = rest[-1], self.F
        for i in range(len(w)):
            row = out[i:i + 1]
            t0 = time.perf_counter()
            self.kernel(w[i:i + 1], s[i:i + 1], z[i:i + 1], m[i:i + 1], q[i:i + 1],
                        v[i:i + 1], *rest[:-1], row)
            dt = time.perf_counter() - t0
            self.rows.append((w[i], s[i], z[i], int(m[i]), dt, int(row[0, F["status"]]),
                              row[0, F["q0"]], row[0, F["v0"]], row[0, F["min_q"]],
                              row[0, F["max_q"]], row[0, F["ptp"]], row[0, F["trace_m"]]))


def _classify(rec: _Recorder, stored: np.ndarray):
    """Seconds and counts per class (cmd_grid's section 3); a solve is a stored orbit's by
    study.orbit_rules.same_orbit, the rule the block solver keeps orbits by."""
    from hertzmap.kernels import status as st
    from hertzmap.study.orbit_rules import same_orbit

    index = defaultdict(list)
    for r in stored:
        index[(r[0], r[1], r[2], int(r[3]))].append(
            {"period": int(r[3]), "min_q": r[6], "max_q": r[7], "ptp": r[8], "trace_m": r[9]})
    seen = set()
    secs, count = defaultdict(float), defaultdict(int)
    for w, s, z, m, dt, status, q0, v0, mn, mx, ptp, trace in rec.rows:
        if status != st.CONVERGED:
            cls = f"failed {m}T"
        else:
            solved = {"period": m, "min_q": mn, "max_q": mx, "ptp": ptp, "trace_m": trace}
            match = next((n for n, orbit in enumerate(index.get((w, s, z, m), ()))
                          if same_orbit(solved, orbit)), None)
            if match is None:
                cls = "not stored"
            elif (w, s, z, m, match) in seen:
                cls = "again"
            else:
                seen.add((w, s, z, m, match))
                cls = "stored"
        secs[cls] += dt
        count[cls] += 1
    return secs, count


# -- census: shooting against the attractor census ---------------------------------------------

def cmd_census(a) -> int:
    """Where a census scene's time goes (default: scenes/vibro_impact.toml, every 8th sigma
    line): shooting (the seeded sweeps and the fold tracing) against the attractor census (its
    transients in the kernel, the exponent, and the shooting of the orbits the census finds),
    per omega line, in one process, the census's first pass (no longer-pass budget). CPU
    seconds (time.process_time) of this process, so that other work on the machine does not
    count; the whole scene's wall time on 2 workers is printed by ``hertzmap run
    scenes/vibro_impact.toml --workers 2``."""
    import hertzmap.study.solve.census as census_module
    from hertzmap.study.solve.line import LineSearch
    from hertzmap.study.spec import load_study

    s = load_study(a.study)
    omega, zeta = s.axis("omega"), float(s.axis("zeta")[0])
    options = dict(exponent=s.exponent or 1.5, model=s.model, rtol=s.rtol, harmonics=False,
                   seeds=())
    kernel = {"seconds": 0.0, "calls": 0}
    batch, lyap = census_module.attractor_batch_into, census_module.lyapunov_into

    def timed(fn):
        def wrapper(*args):
            t0 = time.process_time()
            fn(*args)
            kernel["seconds"] += time.process_time() - t0
            kernel["calls"] += 1
        return wrapper

    census_module.attractor_batch_into = timed(batch)
    census_module.lyapunov_into = timed(lyap)
    try:
        LineSearch(omega[:3], float(s.axis("sigma")[-1]), zeta, s.periods, options).sweep()
        census_module.census(1.0, 2.0, zeta, [], options, 2, 20, 32)        # compile
        kernel.update(seconds=0.0, calls=0)
        totals = dict(sweep=0.0, tracing=0.0, census=0.0)
        points = census_points = 0
        for sigma in s.axis("sigma")[::a.lines]:
            ls = LineSearch(omega, float(sigma), zeta, s.periods, options)
            t0 = time.process_time()
            ls.sweep()
            t1 = time.process_time()
            ls.turn_folds()
            t2 = time.process_time()
            ls.run_census(s.attractors, s.initial_states, s.transient_periods, s.record_periods)
            t3 = time.process_time()
            totals["sweep"] += t1 - t0
            totals["tracing"] += t2 - t1
            totals["census"] += t3 - t2
            points += omega.size
            census_points += len(ls.attractors)
    finally:
        census_module.attractor_batch_into, census_module.lyapunov_into = batch, lyap
    shooting = totals["sweep"] + totals["tracing"]
    transients = kernel["seconds"]
    census_shooting = totals["census"] - transients
    all_ = shooting + totals["census"]
    print(f"{points} points ({a.lines}-th sigma lines of {s.name}), census at {census_points}")
    print(f"shooting (sweeps {totals['sweep']:.1f} s + fold tracing {totals['tracing']:.1f} s): "
          f"{shooting:.1f} s ({100 * shooting / all_:.0f} %)")
    print(f"census transients and exponents (kernel): {transients:.1f} s "
          f"({100 * transients / all_:.0f} %), {1e3 * transients / max(census_points, 1):.0f} ms "
          "per census point")
    print(f"census shooting (orbits it found: refinement, close returns, tracing): "
          f"{census_shooting:.1f} s ({100 * census_shooting / all_:.0f} %)")
    print(f"per grid point: {1e3 * all_ / points:.1f} ms; the whole scene ({s.size} points) "
          f"about {all_ / points * s.size:.0f} s of one core")
    return 0


# -- curves: a traced curve against the grid's ways of getting it -----------------------------

AUTO_MS_PER_POINT = 1.0


def cmd_curves(a) -> int:
    """What a traced curve costs, against the grid's ways of getting the same curve (Hertz
    model, n = 3/2, rtol 1e-10, one process unless said), in one run:

    1. **Per traced vertex** (kernels.continuation.trace_curve, kernels warm): three curves
       across their windows -- the 1T flip curve at zeta 0.005 (orbits in contact), the
       isola's 2T fold curve at zeta 0.01 (long flights) and the 2T grazing curve at zeta 0.01
       -- ms and period maps per vertex, and the accuracy: the largest change of a vertex's
       parameter when the curve's equations are re-solved at rtol 1e-12 (the vertex held in
       the other parameter). AUTO-07p, run as a peer on this model, took about 1 ms per
       continuation point.
    2. **The same curve by bisection on grid lines** at equal accuracy (1e-8 in the free
       parameter): on each sigma line of the curve's window, bisection in omega of the sign
       change of 1 + tr M + det M of the 1T orbit (kernels.shoot at every trial, from the last
       orbit); for the 2T fold, bisection of where the 2T orbit stops existing (shooting from
       the orbit on the existing side). Time per point.
    3. **A grid fine enough for 1e-3**: the flip curve contoured (linear interpolation, as
       products.bifurcation_curves) from 1T grids of steps h in its window, its distance to
       the traced curve, and that grid's time at the measured cost per point; the 2T fold (an
       existence boundary) is known to one grid step only, so 1e-3 needs a step of 1e-3.
    4. **The default scene** (scenes/default.toml, which asks for curves) run with ``hertzmap
       run`` on 2 workers, with and without "curves" in its outputs, in ``--pairs`` ABBA
       rounds (benchmarks/abba.py): whole-command times and their ratio pair by pair (the
       median is the figure: the machine's speed drifts with other jobs), and the curve
       stage's share. ``--skip-scene``: sections 1-3; ``--scene-only``: section 4.
    """
    print(f"load average: {os.getloadavg()[0]:.2f} (2 cores)")
    if a.scene_only:
        _curves_scene(a.pairs)
        return 0
    traced = _curves_traced()
    _curves_bisection(traced)
    _curves_grid(traced)
    if not a.skip_scene:
        _curves_scene(a.pairs)
    return 0


def _flip_curve_seed(zeta, sigma=0.3):
    from hertzmap.kernels import continuation as cont
    from hertzmap.study.solve.seeds import linear_response_seed

    b = cont.continue_orbit(zeta, linear_response_seed(2.1, sigma, zeta), omega=2.1,
                            sigma=sigma, period=1, direction=-1, p_min=1.95, p_max=2.15,
                            dp_max=0.01)
    return [p for p in b.special if p.kind == "flip"][0]


def _isola_fold_seed():
    from hertzmap.study.solve.discovery import discover_line

    line = discover_line(np.linspace(1.0, 2.0, 21), 0.2, 0.01, transients=0)
    return min((d for d in line.special if d["kind"] == "fold" and d["period"] == 2),
               key=lambda d: d["omega"])


def _grazing_seed():
    from hertzmap.kernels import continuation as cont
    from hertzmap.study.solve.seeds import linear_response_seed

    z, s = 0.01, 0.5
    b1 = cont.continue_orbit(z, linear_response_seed(2.2, s, z), omega=2.2, sigma=s, period=1,
                             direction=-1, p_min=1.9, p_max=2.3, dp_max=0.01)
    flip = max((p for p in b1.special if p.kind == "flip"), key=lambda p: p.omega)
    x, w, _, tan = cont.switch_at_flip(z, flip)
    b2 = cont.continue_orbit(z, x, omega=w, sigma=s, period=2, tangent=tan, p_min=1.8,
                             p_max=2.5)
    return [p for p in b2.special if p.kind == "grazing"][0]


def _curve_accuracy(curve, kind, period, zeta, sample=12):
    """Largest change of a vertex's sigma (omega held) when re-solved at rtol 1e-12."""
    from hertzmap.kernels import continuation as cont
    from hertzmap.kernels.continuation.extended_system import CurveSystem, chord_correct

    system = CurveSystem(kind, period, ("omega", "sigma"), zeta, 1.5, "hertz", 1e-12, 10**6)
    V = curve.vertices
    worst = 0.0
    for i in np.linspace(1, len(curve) - 2, sample).astype(int):
        if int(V["flag"][i]) & cont.VERTEX_END:
            continue
        u = np.array([V["q0"][i], V["v0"][i], V["omega"][i], V["sigma"][i]])
        r = chord_correct(system, u, np.array([0.0, 0.0, 1.0, 0.0]), max_iter=30)
        if r is not None:
            worst = max(worst, abs(r.u[3] - u[3]))
    return worst


def _curves_traced():
    from hertzmap.kernels import continuation as cont

    print("## 1. traced curves: time per vertex (kernels warm)")
    cont.trace_curve((0.0, 0.0), 2.0, 0.5, 0.01, kind="grazing", period=2, max_points=3)
    cases = []
    f = _flip_curve_seed(0.005)
    cases.append(("1T flip, zeta 0.005 (in contact)", "flip", 1, 0.005,
                  lambda: cont.trace_curve(f.x0, f.omega, 0.3, 0.005, kind="flip", period=1,
                                           bounds={"omega": (1.9, 2.1), "sigma": (0.15, 1.0)})))
    d = _isola_fold_seed()
    cases.append(("2T fold of the isola, zeta 0.01 (long flights)", "fold", 2, 0.01,
                  lambda: cont.trace_curve((d["q0"], d["v0"]), d["omega"], 0.2, 0.01,
                                           kind="fold", period=2,
                                           bounds={"omega": (0.5, 2.5), "sigma": (0.05, 1.0)})))
    g = _grazing_seed()
    cases.append(("2T grazing, zeta 0.01", "grazing", 2, 0.01,
                  lambda: cont.trace_curve(g.x0, g.omega, 0.5, 0.01, kind="grazing", period=2,
                                           bounds={"omega": (0.5, 2.5), "sigma": (0.05, 1.0)})))
    out = {}
    print("| curve | vertices | time | ms / vertex | maps / vertex | accuracy (rtol 1e-12 vs "
          "1e-10) | vs AUTO ~1 ms / point |")
    print("|---|---|---|---|---|---|---|")
    for name, kind, period, zeta, run in cases:
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            c = run()
            times.append(time.perf_counter() - t0)
        t = min(times)
        acc = _curve_accuracy(c, kind, period, zeta)
        ms = 1e3 * t / len(c)
        print(f"| {name} | {len(c)} | {t:.3f} s | {ms:.3f} | {c.maps / len(c):.1f} | "
              f"{acc:.1e} | {AUTO_MS_PER_POINT / ms:.1f}x faster |")
        out[kind, period] = (c, ms)
    return out


def _on_curve(curve, kind, period, zeta, sigma, near_omega):
    """The traced curve's exact crossing of the sigma line near ``near_omega``: the curve's
    equations solved with sigma held, from the interpolated polyline."""
    from hertzmap.kernels.continuation.extended_system import CurveSystem, chord_correct

    V = curve.vertices
    system = CurveSystem(kind, period, ("omega", "sigma"), zeta, 1.5, "hertz", 1e-10, 10**6)
    k = np.nonzero(np.diff(np.sign(V["sigma"] - sigma)))[0]
    k = k[np.argmin(np.abs(V["omega"][k] - near_omega))]
    th = (sigma - V["sigma"][k]) / (V["sigma"][k + 1] - V["sigma"][k])
    u = np.array([V[n][k] + th * (V[n][k + 1] - V[n][k]) for n in ("q0", "v0", "omega")]
                 + [sigma])
    r = chord_correct(system, u, np.array([0.0, 0.0, 0.0, 1.0]), max_iter=30)
    return (r.u[2], r.u[:2]) if r is not None else (np.nan, u[:2])


def _distance_to_polyline(points, P):
    """Largest distance of ``points`` (k, 2) to the polyline P (n, 2)."""
    a, d = P[:-1], P[1:] - P[:-1]
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    worst = 0.0
    for p in points:
        th = np.clip(np.einsum("ij,ij->i", p - a, d) / dd, 0.0, 1.0)
        worst = max(worst, float(np.min(np.hypot(*(a + th[:, None] * d - p).T))))
    return worst


def _bisect(g, a, b, tol=1e-8, max_iter=80):
    """Bisection of a sign change of g on [a, b]; returns (root, evaluations)."""
    ga = g(a)
    gb = g(b)
    n = 2
    if not (np.isfinite(ga) and np.isfinite(gb)) or ga * gb > 0:
        return np.nan, n
    for _ in range(max_iter):
        if b - a <= tol:
            break
        m = 0.5 * (a + b)
        gm = g(m)
        n += 1
        if not np.isfinite(gm):
            return np.nan, n
        if gm * ga > 0:
            a, ga = m, gm
        else:
            b = m
    return 0.5 * (a + b), n


def _curves_bisection(traced):
    from hertzmap.kernels import continuation as cont
    from hertzmap.kernels import shoot
    from hertzmap.study.solve.seeds import linear_response_seed

    print("\n## 2. the same curves by bisection on grid lines (to 1e-8 in omega)")
    c, ms_traced = traced["flip", 1]
    V = c.vertices
    z = 0.005
    right = V["omega"] > 2.0
    sig = np.linspace(0.2, 1.0, 9)
    worst, evals, found = 0.0, 0, 0
    exact = {}
    for s in sig:
        wt = np.interp(s, V["sigma"][right][np.argsort(V["sigma"][right])],
                       V["omega"][right][np.argsort(V["sigma"][right])])
        exact[s] = _on_curve(c, "flip", 1, z, s, wt)[0]
    t0 = time.perf_counter()
    for s in sig:
        wt = exact[s]
        state = {"x": linear_response_seed(wt, s, z)}

        def g(w):
            o = shoot(w, s, z, 1, state["x"], harmonics=False)
            if not o.converged:
                return np.nan
            state["x"] = o.x0
            return cont.flip_function(o.monodromy)
        w, n = _bisect(g, wt - 0.01, wt + 0.01)
        evals += n
        if np.isfinite(w):
            found += 1
            worst = max(worst, abs(w - wt))
    t = time.perf_counter() - t0
    per = 1e3 * t / max(found, 1)
    print(f"1T flip, zeta 0.005: {found} lines, {per:.2f} ms per point ({evals / len(sig):.0f} "
          f"shoots each); traced {ms_traced:.3f} ms per vertex: bisection {per / ms_traced:.0f}x "
          f"slower per point; |omega_bisection - omega of the traced curve| <= {worst:.1e}")
    # the 2T fold: bisection of the existence boundary on sigma lines
    c, ms_traced = traced["fold", 2]
    V = c.vertices
    lines = [0.2, 0.25, 0.3]
    exact = {s: _on_curve(c, "fold", 2, 0.01, s, 1.1) for s in lines}
    t0 = time.perf_counter()
    found, evals, worst = 0, 0, 0.0
    for s in lines:
        wt, xt = exact[s]
        # the 2T orbit exists for omega above the fold (this side of the isola)
        state = {"x": xt}

        def exists(w):
            o = shoot(w, s, 0.01, 2, state["x"], harmonics=False, max_iter=20)
            ok = o.converged and o.minimal_period == 2
            if ok:
                state["x"] = o.x0
            return 1.0 if ok else -1.0
        lo, hi = wt - 5e-3, wt + 5e-3
        if exists(hi) < 0 or exists(lo) > 0:
            continue
        state["x"] = xt
        a, b, n = lo, hi, 2
        while b - a > 1e-8 and n < 80:
            m = 0.5 * (a + b)
            n += 1
            if exists(m) > 0:
                b = m
            else:
                a = m
        evals += n
        found += 1
        worst = max(worst, abs(0.5 * (a + b) - wt))
    t = time.perf_counter() - t0
    per = 1e3 * t / max(found, 1)
    print(f"2T fold (isola), zeta 0.01: {found} lines, {per:.2f} ms per point "
          f"({evals / max(found, 1):.0f} shoots each; the orbit's existence, bisected: Newton "
          f"slows down at a fold, so its 1e-8 is in omega of existence, not of the fold); traced "
          f"{ms_traced:.3f} ms per vertex: {per / ms_traced:.0f}x; |difference| <= {worst:.1e}")


def _curves_grid(traced):
    from hertzmap.kernels import shoot_batch
    from hertzmap.study.products.bifurcation_curves import contour_lines
    from hertzmap.study.solve.seeds import linear_response_seed

    print("\n## 3. a grid fine enough for the curve to 1e-3")
    c, _ = traced["flip", 1]
    V = c.vertices
    z = 0.005
    lo_w, hi_w, lo_s, hi_s = 1.96, 2.04, 0.2, 0.6
    ref_w, ref_s = V["omega"], V["sigma"]
    print("| grid step (omega = sigma) | points | 1T solve time | max distance of the contour to "
          "the traced curve |")
    print("|---|---|---|---|")
    per_point = None
    for h in (0.02, 0.01, 0.005, 0.0025):
        om = np.arange(lo_w, hi_w + 1e-12, h)
        sg = np.arange(lo_s, hi_s + 1e-12, h)
        W, S = np.meshgrid(om, sg, indexing="ij")
        guess = np.array([linear_response_seed(w, s, z) for w, s in zip(W.ravel(), S.ravel())])
        t0 = time.perf_counter()
        r = shoot_batch(W.ravel(), S.ravel(), z, 1, guess[:, 0], guess[:, 1], harmonics=False)
        t = time.perf_counter() - t0
        per_point = t / W.size
        mu1 = r["multiplier1_re"] + 1j * r["multiplier1_im"]
        mu2 = r["multiplier2_re"] + 1j * r["multiplier2_im"]
        g = np.real((1 + mu1) * (1 + mu2)).reshape(W.shape)
        g[r["status"].reshape(W.shape) != 0] = np.nan
        P = np.column_stack([ref_w, ref_s])
        worst = max((_distance_to_polyline(line, P) for line in contour_lines(om, sg, g, 0.0)),
                    default=np.nan)
        print(f"| {h:g} | {W.size} | {t:.2f} s | {worst:.1e} |")
    # error ~ C h^2 (linear interpolation of a smooth field): the step for 1e-3
    print(f"(measured {1e3 * per_point:.3f} ms per 1T point; a contour's error falls like h^2)")
    print("2T fold (existence boundary, products.curves boundary_2T / isola): one grid step; "
          "1e-3 needs step 1e-3: the default window (omega 0.5..2.5 x sigma 0.05..1) would be "
          f"{2001 * 951:,} points, {2001 * 951 * 0.772e-3 / 2 / 60:.0f} min on 2 workers at "
          "0.772 ms per 1T + 2T point (scheduler/plan.py), against one traced curve.")


def _curves_scene(pairs=3):
    print("\n### 4. the default scene with and without curves (hertzmap run, 2 workers, ABBA)")
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    text = (ROOT / "scenes" / "default.toml").read_text()
    outputs = re.search(r"^outputs = \[(.*)\]", text, re.M)
    assert outputs and '"curves"' in outputs.group(1), "scenes/default.toml asks for no curves"
    plain = ", ".join(o for o in re.findall(r'"\w+"', outputs.group(1)) if o != '"curves"')
    texts = {"plain": text[:outputs.start(1)] + plain + text[outputs.end(1):], "curves": text}
    with tempfile.TemporaryDirectory() as d:
        def variant(label):
            def run(k):
                study, store = Path(d) / f"{label}{k}.toml", Path(d) / f"{label}{k}.zarr"
                study.write_text(texts[label])
                t0 = time.perf_counter()
                r = subprocess.run([sys.executable, "-m", "hertzmap.scheduler.cli", "run",
                                    str(study), "--store", str(store), "--workers", "2"],
                                   capture_output=True, text=True, cwd=ROOT)
                total = time.perf_counter() - t0
                shutil.rmtree(store, ignore_errors=True)
                if r.returncode != 0:
                    raise RuntimeError(r.stdout + r.stderr)
                summary = run_summary(r.stdout)
                line = [ln for ln in r.stdout.splitlines() if ln.startswith("curves:")]
                print(f"  pair {k + 1} {label}: whole command {total:.1f} s, grid "
                      f"{summary['wall']:.1f} s wall"
                      + (f", curve stage {summary['curves']:.2f} s"
                         if summary["curves"] is not None else ""), flush=True)
                if line:
                    print("    " + line[0])
                return {"whole": total, "curve stage": summary["curves"] or 0.0}
            return run
        res = abba({"plain": variant("plain"), "curves": variant("curves")}, pairs)
    stage = [c / p for c, p in zip(res.of("curves", "curve stage"), res.of("plain", "whole"))]
    print(res.report("curves", "plain", "whole", "with curves / without (whole command)")
          + f"; the curve stage alone: median {100 * np.median(stage):.0f} % of the run without "
          "curves; issue 19 asks <= 1.5")


# -- throughput: a small study on 1 and 2 Dask workers ---------------------------------------

THROUGHPUT_STUDY = """
[study]
name = "throughput"
description = "benchmark grid"

[grid]
omega = {{ start = 0.5, stop = 2.5, num = {n_omega} }}
sigma = {{ start = 0.05, stop = 1.0, num = {n_sigma} }}
zeta = 0.01

[model]
kind = "hertz"
exponent = 1.5

[solver]
rtol = 1e-10

[search]
periods = [1, 2]

[products]
outputs = ["orbits", "measures"]
"""


def cmd_throughput(a) -> int:
    """Throughput of a grid study on 1 and 2 Dask workers, Dask overhead per task, numba cold
    start with and without the compile cache, peak memory per worker, and the study's own error
    estimate (about a minute; ``--omega 400 --sigma 250 --workers 2``: the 100,000-point target
    run for real, 1-2 minutes; ``--ceiling``: two solver processes at once against one, no
    Dask, ~10 s; ``--with-profiler``: workers with Dask's stack profiler on, as Dask's default).

    A small study (the default study's (omega, sigma) window at zeta 0.01, 1T and 2T seeds,
    rtol 1e-10; 41 x 25 = 1025 points by default) is run with ``scheduler.run.run_study`` into
    stores in a temporary directory, on the LocalCluster ``hertzmap run`` starts
    (scheduler.cluster.make_client: 1 then 2 single-threaded worker processes, Dask's
    housekeeping trimmed; started before timing, kernels warmed from the numba cache by the
    worker plugin). Figures:

    * points/s = grid points / wall time from submission to the last write (setup excluded);
      parallel efficiency = points/s on 2 workers / (2 x points/s on 1 worker);
    * Dask overhead per task: (workers x wall - sum of solver times inside the tasks) / tasks,
      and the round trip of an empty task (client.map over 200 no-ops);
    * cold start: a new process importing the block solver and solving one point
      (scheduler.worker.warm_up), with an empty numba cache dir, then again from that cache;
    * peak memory: ru_maxrss of every worker process after the run (client.run);
    * the error estimate the run stored in the store's attrs (hertzmap_error_estimate).
    """
    if a.with_profiler:
        from hertzmap.scheduler import cluster
        cluster.CLUSTER_CONFIG = {**cluster.CLUSTER_CONFIG,
                                  "distributed.worker.profile.enabled": True}
    if a.ceiling:
        _machine_ceiling()
        return 0
    counts = [int(w) for w in a.workers.split(",")]
    import logging
    for name in ("distributed", "tornado", "asyncio"):   # shutdown chatter (closed comms)
        logging.getLogger(name).setLevel(logging.CRITICAL)
    from hertzmap.study.spec import load_study

    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start "
          "(shared machine: timings are noisy)")
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        (tmp / "s.toml").write_text(THROUGHPUT_STUDY.format(n_omega=a.omega, n_sigma=a.sigma))
        study = load_study(tmp / "s.toml")
        print(f"study: {a.omega} omega x {a.sigma} sigma x 1 zeta = {study.size} points, "
              "periods 1 and 2, rtol 1e-10")
        res = {w: _run_on(w, study, tmp) for w in counts}
        for w, s in res.items():
            per_task_over = (s["workers"] * s["wall"] - s["compute"]) / max(1, s["tasks_run"])
            print(f"{w} worker(s): {s['points']} points in {s['wall']:.2f} s wall -> "
                  f"{s['points_per_second']:.0f} points/s ({1e3 * s['compute'] / s['points']:.1f} ms "
                  f"solver time per point); {s['tasks_run']} tasks of {1e3 * s['per_task']:.0f} ms; "
                  f"dask overhead {100 * s['overhead']:.1f} % = {1e3 * per_task_over:.0f} ms per task; "
                  f"empty-task round trip {1e3 * s['noop_per_task']:.2f} ms; "
                  f"peak RSS per worker {', '.join(f'{m:.0f}' for m in s['maxrss_mb'])} MB; "
                  f"client process (scheduler + writer) CPU {s['client_cpu']:.2f} s "
                  f"= {100 * s['client_cpu'] / s['wall']:.0f} % of a core")
            print("    printed by the run: " + [ln for ln in s["printed"].splitlines()
                                                 if ln.startswith("error estimate")][0])
            print(f"    store attrs hertzmap_error_estimate: {s['attr']}")
        if 1 in res and 2 in res:
            eff = res[2]["points_per_second"] / (2 * res[1]["points_per_second"])
            print(f"parallel efficiency on 2 workers: {100 * eff:.0f} % (points/s ratio; meaningless "
                  f"when the per-point solver time differs between the runs: "
                  f"{1e3 * res[1]['compute'] / res[1]['points']:.1f} vs "
                  f"{1e3 * res[2]['compute'] / res[2]['points']:.1f} ms)")
        if 2 in res:
            print(f"2-worker utilisation (solver time inside tasks / (2 x wall)): "
                  f"{100 * (1 - res[2]['overhead']):.0f} %")
            pps = res[2]["points_per_second"]
            print(f"100,000 points (1T and 2T seeds) at this rate on 2 workers: {1e5 / pps:.0f} s "
                  f"(target < 60 s)")
    if a.no_cold_start:
        return 0
    with tempfile.TemporaryDirectory() as cache:
        cold = _warm_up_seconds(cache)
        warm = _warm_up_seconds(cache)
    print(f"numba cold start (new process, import the block solver, solve one point): "
          f"{cold:.1f} s with an empty cache, {warm:.2f} s from the disk cache")
    return 0


def _maxrss_mb():
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _noop(i):
    return i


def _warm_up_seconds(cache_dir: str) -> float:
    code = ("import time; t = time.perf_counter(); from hertzmap.scheduler.worker import warm_up; "
            "warm_up(); print(time.perf_counter() - t)")
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       check=True, cwd=ROOT)
    return float(r.stdout.strip().splitlines()[-1])


def _solve_default_window(_):
    """Seconds per block (4 sigma lines x 161 omega of the default window), best of 3."""
    from hertzmap.study.solve.block import solve_block
    omega, sigma, zeta = np.linspace(0.5, 2.5, 161), np.array([0.1, 0.3, 0.5, 0.8]), np.array([0.01])
    solve_block(omega[:5], sigma[:1], zeta, harmonics=False)      # kernels from the cache
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        solve_block(omega, sigma, zeta, harmonics=False)
        times.append(time.perf_counter() - t0)
    return min(times)


def _machine_ceiling() -> float:
    """What this machine gives two concurrent solver processes, without Dask: the rate of two
    processes at once over twice the rate of one alone."""
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(1) as pool:
        one = pool.map(_solve_default_window, [0])[0]
    with ctx.Pool(2) as pool:
        two = pool.map(_solve_default_window, [0, 1])
    print(f"machine ceiling (no Dask): one solver process {one:.3f} s per block; two at once "
          f"{two[0]:.3f} and {two[1]:.3f} s -> {100 * one / max(two):.0f} % of twice one process")
    return one / max(two)


def _run_on(workers: int, study, tmp: Path) -> dict:
    from hertzmap.scheduler.cluster import ClusterSpec, make_client
    from hertzmap.scheduler.run import RunOptions, run_study
    from hertzmap.scheduler.store import read_attrs

    spec = ClusterSpec(kind="local", workers=workers)
    client, cluster = make_client(spec)     # the cluster `hertzmap run` would start
    try:
        opts = RunOptions(store=tmp / f"w{workers}.zarr", cluster=spec,
                          command=f"run_cost throughput {workers} workers")
        buf = io.StringIO()
        cpu0 = time.process_time()
        s = run_study(study, opts, out=buf, err=io.StringIO(), client=client)
        # CPU of this process (client, scheduler, single writer): on a 2-core machine it
        # competes with the workers
        s["client_cpu"] = time.process_time() - cpu0
        futs = client.map(_noop, range(200), pure=False)   # empty-task round trip
        t0 = time.perf_counter()
        futs = client.map(_noop, range(1000, 1200), pure=False)
        client.gather(futs)
        s["noop_per_task"] = (time.perf_counter() - t0) / 200
        s["maxrss_mb"] = sorted(client.run(_maxrss_mb).values())
        s["printed"] = buf.getvalue()
        s["attr"] = json.loads((read_attrs(opts.store) or {}).get("hertzmap_error_estimate",
                                                                   "null") or "null")
    finally:
        client.close()
        cluster.close()
    return s


# -- task-size: two --task-seconds targets, ABBA -----------------------------------------------

def cmd_task_size(a) -> int:
    """Task size against the client's share of the cores: one study run with two
    ``--task-seconds`` targets in ABBA rounds of benchmarks/abba.py (A B, then B A, ...), in one
    session (default study, 0.25 against 2 s; ``--pairs`` rounds).

    Each run is ``hertzmap run STUDY --workers 2 --task-seconds S`` into a temporary store
    (warm numba cache: run the study once before). Printed per run: the tasks, the grid's wall
    and task compute as the run's summary gives them (run_summary), and the CPU seconds of the
    client process itself (scheduler and single writer) sampled from /proc while the run lasts.
    Then the ratio of the grid walls, A / B, pair by pair. On a 2-core machine the client
    shares the cores with the two workers, so its CPU is taken from theirs."""
    print(f"{a.study}; A: --task-seconds {a.a}, B: --task-seconds {a.b}; {load_line()}")

    def show(run):
        r = run.value
        print(f"  {run.name}: {r['tasks']:4d} tasks, grid {r['wall']:6.2f} s wall, task compute "
              f"{r['compute']:6.2f} s, client CPU {r['client']:5.2f} s (whole run); "
              f"{load_line()}", flush=True)

    res = abba({"A": lambda k: _task_size_run(a.study, a.a),
                "B": lambda k: _task_size_run(a.study, a.b)}, a.pairs, each=show)
    print(res.report("A", "B", "wall", "grid wall A / B"))
    return 0


def _task_size_run(study: str, task_seconds: float) -> dict:
    import psutil

    with tempfile.TemporaryDirectory() as tmp:
        cmd = [str(ROOT / ".venv/bin/hertzmap"), "run", study, "--workers", "2",
               "--store", str(Path(tmp) / "s.zarr"), "--task-seconds", str(task_seconds),
               "--error-sample", "0"]
        with open(Path(tmp) / "out.txt", "w") as out:
            p = subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=subprocess.STDOUT)
            client = psutil.Process(p.pid)
            cpu = 0.0
            while p.poll() is None:
                try:
                    t = client.cpu_times()
                    cpu = t.user + t.system
                except psutil.Error:
                    break
                time.sleep(0.2)
        text = (Path(tmp) / "out.txt").read_text()
    if p.returncode != 0:
        raise SystemExit(f"run failed ({p.returncode}):\n{text}")
    tasks = int(re.search(r"running (\d+) tasks", text).group(1))
    return dict(run_summary(text), tasks=tasks, client=cpu)


# -- store: bytes, files and writes, two versions, ABBA ----------------------------------------

#: what each store run executes in the version's own Python: the run, then its summary as JSON
_STORE_RUN = r"""
import json, sys
from pathlib import Path
from hertzmap.scheduler.cluster import ClusterSpec
from hertzmap.scheduler.run import RunOptions, run_study
from hertzmap.study.scenes import study_path
from hertzmap.study.spec import load_study
import io
study = load_study(study_path(sys.argv[1]))
opts = RunOptions(store=Path(sys.argv[2]), cluster=ClusterSpec(kind="local", workers=int(sys.argv[3])),
                  error_sample=0)
s = run_study(study, opts, out=io.StringIO(), err=io.StringIO())
atlas = s.get("atlas") or {}
print(json.dumps({"tasks": s["tasks_run"], "block_writes": s.get("block_writes"),
                  "compute": s.get("compute"), "wall": s.get("wall"),
                  "atlas": atlas.get("compute")}))
"""


def cmd_store(a) -> int:
    """What a store costs on disk and to write: bytes, files per task, write time per block,
    for two versions of hertzmap in the same run (each scene run by each version in turn, in
    ``--pairs`` ABBA rounds of benchmarks/abba.py).

    ``--vs``: the Python of another checkout's venv (e.g. a ``git worktree add ../base REV``
    with its own ``bash scripts/install.sh``): version B; version A is this checkout's
    (.venv/bin/python). Each run is ``run_study`` (the command line's path) on an embedded
    LocalCluster of ``--workers`` workers into a new store; printed per scene and version: the
    store's bytes on disk (its files' sizes, products excluded: the run's own groups), its
    files and files per grid task, the run's block writes (the workers' write time, summed,
    per task), the grid's task compute and wall, and the atlas's compute; then B / A pair by
    pair."""
    versions = {"A": str(ROOT / ".venv" / "bin" / "python"), "B": a.vs}
    scenes = a.scene or ["default", "fine_map", "vibro_impact"]
    where = a.keep or Path(tempfile.mkdtemp(prefix="hertzmap-store-cost-"))
    where.mkdir(parents=True, exist_ok=True)
    print(f"A: {versions['A']}\nB: {versions['B']}\nstores in {where}")
    for scene in scenes:
        def variant(v, scene=scene):
            def run(k):
                store = where / f"{Path(scene).stem}-{v}-{k}.zarr"
                r = _store_run(versions[v], scene, store, a.workers)
                r["files per task"] = r["files"] / r["tasks"]
                r["write per task"] = r["block_writes"] / r["tasks"]
                print(f"{scene} {v}: {r['bytes'] / 1e6:.1f} MB in {r['files']} files, "
                      f"{r['files per task']:.1f} files per task ({r['tasks']} tasks), "
                      f"block writes {1000 * r['write per task']:.1f} ms per task, "
                      f"grid compute {r['compute']:.1f} s, wall {r['wall']:.1f} s, atlas "
                      f"{(r['atlas'] or 0):.1f} s", flush=True)
                if a.keep is None:
                    shutil.rmtree(store, ignore_errors=True)
                return r
            return run
        res = abba({"A": variant("A"), "B": variant("B")}, a.pairs)
        for key, what in (("bytes", "bytes"), ("files", "files"),
                          ("write per task", "write time per task")):
            print(res.report("B", "A", key, f"{scene}: {what} B / A"))
    if a.keep is None:
        shutil.rmtree(where, ignore_errors=True)
    return 0


def _store_disk(store: Path) -> tuple[int, int]:
    """(bytes, files) of a store, its products/ groups left out."""
    size = files = 0
    for p in store.rglob("*"):
        if p.is_file() and "products" not in p.relative_to(store).parts:
            size += p.stat().st_size
            files += 1
    return size, files


def _store_run(python: str, scene: str, store: Path, workers: int) -> dict:
    r = subprocess.run([python, "-c", _STORE_RUN, scene, str(store), str(workers)],
                       capture_output=True, text=True, cwd=ROOT)
    if r.returncode != 0:
        raise SystemExit(f"{python} {scene}: {r.stderr[-2000:]}")
    out = json.loads(r.stdout.strip().splitlines()[-1])
    out["bytes"], out["files"] = _store_disk(store)
    return out


# -- scale: per-task costs besides the solves --------------------------------------------------

def cmd_scale(a) -> int:
    """The per-task costs a large study pays besides its solves, measured here, for
    docs/running.md's "Scale on paper" (a study of 10^8 points on 1,000 workers).

    STUDY (``--study``; default: the fine map's grid at 4000 omega x 2500 sigma, 10^7 points,
    written to a temporary file: its tasks are those of a 10^8 study, which only has ten times
    as many) is planned as ``hertzmap run`` plans it (scheduler.plan), and then:

    1. **Client bookkeeping**: the plan and the task specs (scheduler.run.task_specs) for every
       task, built in this process: traced Python memory (tracemalloc) and one spec's pickle.
    2. **Store**: the template written with Store.create (time, files), then one real block (8
       lines of the study solved here, tiled to the chunk's size) written 5 times with
       scheduler.store.BlockWriter: time per block write (what a worker now pays per task) and
       the chunk's bytes and files on disk.
    3. **Client CPU per task, before and after, in one run**: a ``dask scheduler`` process and
       2 single-threaded worker processes (their own processes, so that the client's CPU is its
       own: psutil); first ``--tasks`` no-op tasks (Dask's own cost per task), then 20
       block-sized tasks in each mode, in two ABBA rounds of benchmarks/abba.py:
       * *client writes* (hertzmap until the workers wrote their blocks): the task returns the
         block's arrays; the client receives them, writes the block, sets the flag, counts
         (block_counts) and samples;
       * *worker writes* (now): the task stages its block (store.stage_task_block) and returns
         its summary (block_counts, the error-sample candidates); the client sets the flag and
         adds the counts.
       Printed: the client's and the scheduler's CPU ms per task, the wall per task, and the
       client's CPU worker writes / client writes pair by pair.
    4. **Many workers**: a ``dask scheduler`` process and ``dask worker --nworkers W`` for each
       W of ``--workers``; tasks that sleep ``--sleep`` s (a solve that costs no CPU) and then
       write a real block into the store as run_task does; ``--rounds`` tasks per worker.
       Printed: tasks per second against the W / sleep the workers could take, the client's,
       the scheduler's and the workers' CPU per task, the block write's wall on the worker.
       Then W = the largest, tasks that only sleep 0.05 s and write nothing: the most tasks per
       second the scheduler and the client pass on this machine, and which of the two is busy.
    """
    from hertzmap.scheduler.plan import choose_chunks, make_plan
    from hertzmap.scheduler.report import SUMMED_COUNTS, WORST_COUNTS, add_counts, block_counts
    try:                                        # the grid stage's module, since the stage runner
        from hertzmap.scheduler.grid_tasks import task_specs
    except ImportError:
        from hertzmap.scheduler.run import task_specs
    from hertzmap.scheduler.sample import Sampler, block_candidates
    from hertzmap.scheduler.store import Lock, Store
    from hertzmap.study.schema import empty_arrays, stored_variables
    from hertzmap.study.solve.block import solve_block
    from hertzmap.study.spec import load_study

    tmp = tempfile.mkdtemp(prefix="hertzmap-scale-")
    procs: _Processes | None = None
    try:
        study = load_study(a.study or _big_study_file(tmp))
        chunks = choose_chunks(study)
        print(f"{study.name}: {study.size:,} points, chunk {chunks}; load average "
              + load_average(), flush=True)
        path = os.path.join(tmp, "store.zarr")
        sampler = Sampler(study, 8)

        # 1. client bookkeeping
        tracemalloc.start()
        plan = make_plan(study, chunks)
        specs = task_specs(study, plan.tasks, study.solver_kwargs(), stored_variables(study),
                           None, 600.0, store=Path(path), owner={"host": "h", "pid": 1,
                                                                  "token": "0" * 32},
                           sampler=sampler)
        current, _ = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        om, zt = study.axis("omega"), study.axis("zeta")
        kwargs, names = study.solver_kwargs(), stored_variables(study)
        one = len(pickle.dumps(specs[0]))
        print(f"client: {len(plan.tasks):,} tasks; plan + task specs {current / 2**20:.1f} MiB "
              f"traced ({current / len(plan.tasks) / 1024:.1f} KiB per task); one spec pickled "
              f"{one / 1024:.1f} KiB", flush=True)
        del specs

        # 2. store
        t0 = time.perf_counter()
        store = Store.create(path, study, chunks, action="scale_overheads")
        t_create = time.perf_counter() - t0
        files = sum(len(f) for _, _, f in os.walk(path))
        size = sum(os.path.getsize(os.path.join(d, x)) for d, _, f in os.walk(path) for x in f)
        print(f"store template: {t_create:.2f} s, {files} files, {size / 2**20:.1f} MiB",
              flush=True)
        # a real block: 8 lines of the default study's sigma range, tiled to the chunk's size
        c_o = chunks[0]
        omega = om[:c_o]
        line = solve_block(np.ascontiguousarray(omega[:: max(1, c_o // 400)][:400]),
                           np.array([0.5]), zt[:1], **kwargs)
        reps = -(-c_o // line["status"].shape[0])
        arrays = {k: np.concatenate([v] * reps, axis=0)[:c_o] for k, v in line.items()
                  if k in names}
        missing = [n for n in names if n not in arrays]
        if missing:
            arrays.update(empty_arrays((c_o, 1, 1), study.max_solutions, tuple(missing)))
        block_file = os.path.join(tmp, "block.npz")
        np.savez(block_file, **arrays)
        times = []
        for j in range(5):
            t0 = time.perf_counter()
            store.write_block(_slices(j, c_o), arrays, tuple(names))
            times.append(time.perf_counter() - t0)
        raw = sum(v.nbytes for v in arrays.values())
        before, before_files = size, files
        size = sum(os.path.getsize(os.path.join(d, x)) for d, _, f in os.walk(path) for x in f)
        files = sum(len(f) for _, _, f in os.walk(path))
        per_chunk = (size - before) / 5
        print(f"block write: {np.median(times) * 1e3:.0f} ms per block (median of 5); one block "
              f"{raw / 2**20:.2f} MiB uncompressed, {per_chunk / 2**20:.2f} MiB on disk "
              f"({raw / per_chunk:.1f}x compression) in {(files - before_files) / 5:.0f} files; "
              f"{len(names)} variables", flush=True)

        lock = Lock(path)
        lock.acquire()
        base = {"c_o": c_o, "names": list(names), "store": str(Path(path).resolve()),
                "owner": lock.owner, "omega": omega, "block": block_file}

        def job(j, **extra):
            task = plan.tasks[j]
            return dict(base, j=j, index=task.index, sample=sampler.task_spec(task), **extra)

        # 3. client CPU per task, before and after (one run, modes alternated)
        from distributed import Client
        procs = _Processes(2)
        with Client(procs.address) as client:
            client.wait_for_workers(2)
            client.run(lambda: __import__("hertzmap.scheduler.store"))
            client.submit(_noop_task, -1).result()
            t0 = time.perf_counter()
            n = a.tasks
            futs = client.map(_noop_task, range(n), pure=False)
            cpu0, c0 = _client_cpu(), procs.cpu()
            from distributed import as_completed
            for f in as_completed(futs):
                f.result()
                f.release()
            dt = time.perf_counter() - t0
            c1 = procs.cpu()
            print(f"scheduler, 2 workers, {n} no-op tasks: {dt:.2f} s, {dt / n * 1e3:.2f} ms per "
                  f"task; client {(_client_cpu() - cpu0) / n * 1e3:.2f} ms CPU per task, scheduler "
                  f"{(c1['scheduler'] - c0['scheduler']) / n * 1e3:.2f} ms", flush=True)

            next_j = [5]

            def mode(name):
                def run(_k):
                    tally = {"points": 0, **{k: 0 for k in SUMMED_COUNTS},
                             **{k: float("nan") for k in WORST_COUNTS}}
                    n = 20
                    jobs = [job(j) for j in range(next_j[0], next_j[0] + n)]
                    next_j[0] += n

                    def before(res, tally=tally):
                        j = res["index"][1]
                        store.write_block(_slices(j, c_o), res["arrays"], tuple(names))
                        store.mark_done(plan.tasks[j].index)
                        add_counts(tally, block_counts(res["arrays"]))
                        sampler.merge(block_candidates(res["arrays"], (omega, [0.5], [0.01]),
                                                       sampler.task_spec(plan.tasks[j])))

                    def after(res, tally=tally):
                        store.mark_done(plan.tasks[res["index"][1]].index)
                        add_counts(tally, res["counts"])
                        sampler.merge(res["samples"])

                    cpu0, c0 = _client_cpu(), procs.cpu()
                    if name == "client writes":
                        wall = _run_tasks(client, _task_returning_the_block, jobs, before)
                    else:
                        wall = _run_tasks(client, _task_writing_the_block, jobs, after)
                    c1 = procs.cpu()
                    return {"client": (_client_cpu() - cpu0) / n,
                            "scheduler": (c1["scheduler"] - c0["scheduler"]) / n,
                            "workers": (c1["workers"] - c0["workers"]) / n,
                            "wall per task": wall / n}
                return run
            res = abba({m: mode(m) for m in ("client writes", "worker writes")}, 2)
            for name in res.names:
                cl, sc, wk, wl = (sorted(res.of(name, key)) for key in
                                  ("client", "scheduler", "workers", "wall per task"))
                print(f"{name}, 2 workers, 2 x 20 block-sized tasks: client {cl[0] * 1e3:.0f}-"
                      f"{cl[-1] * 1e3:.0f} ms CPU per task, scheduler {sc[0] * 1e3:.1f}-"
                      f"{sc[-1] * 1e3:.1f} ms, workers {wk[0] * 1e3:.0f}-{wk[-1] * 1e3:.0f} ms; "
                      f"wall {wl[0] * 1e3:.0f}-{wl[-1] * 1e3:.0f} ms per task", flush=True)
            print(res.report("worker writes", "client writes", "client",
                             "client CPU per task, worker writes / client writes"), flush=True)
        procs.close()
        procs = None

        # 4. many workers
        counts = [int(w) for w in a.workers.split(",") if w.strip()]
        for w in counts:
            procs = _Processes(w)
            with Client(procs.address) as client:
                client.wait_for_workers(w, timeout=900)
                client.run(lambda: __import__("hertzmap.scheduler.store"))
                client.map(_noop_task, range(-w, 0), pure=False)
                runs = [("sleep %.2f s + block write" % a.sleep, a.sleep, block_file, a.rounds * w)]
                if w == counts[-1]:
                    runs.append(("sleep 0.05 s, no write", 0.05, None, 40 * w))
                for label, sleep, blk, n in runs:
                    # chunks not written yet, while there are (then written again)
                    jobs = [dict(job(5 + (next_j[0] + i) % (len(plan.tasks) - 5)), sleep=sleep,
                                 block=blk) for i in range(n)]
                    next_j[0] += n
                    writes = []

                    def flag(res):
                        store.mark_done(plan.tasks[res["index"][1]].index)
                        if res["counts"] is not None:
                            add_counts(tally, res["counts"])
                        sampler.merge(res["samples"])
                        writes.append(res["write_seconds"])

                    tally = {"points": 0, **{k: 0 for k in SUMMED_COUNTS},
                             **{k: float("nan") for k in WORST_COUNTS}}
                    cpu0, c0 = _client_cpu(), procs.cpu()
                    wall = _run_tasks(client, _task_writing_the_block, jobs, flag)
                    c1 = procs.cpu()
                    rate, ideal = n / wall, w / sleep
                    print(f"{w} workers, {n} tasks ({label}): {wall:.1f} s, {rate:.1f} tasks/s of "
                          f"{ideal:.0f} possible ({rate / ideal:.0%}); per task: client "
                          f"{(_client_cpu() - cpu0) / n * 1e3:.1f} ms CPU, scheduler "
                          f"{(c1['scheduler'] - c0['scheduler']) / n * 1e3:.1f} ms, workers "
                          f"{(c1['workers'] - c0['workers']) / n * 1e3:.1f} ms; block write "
                          f"{np.median(writes) * 1e3:.0f} ms wall (median); client busy "
                          f"{(_client_cpu() - cpu0) / wall:.0%}, scheduler "
                          f"{(c1['scheduler'] - c0['scheduler']) / wall:.0%} of a core; load "
                          + load_average(), flush=True)
            procs.close()
            procs = None
        lock.release()
    finally:
        if procs is not None:
            procs.close()
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


def _big_study_file(folder: str) -> str:
    text = (ROOT / "scenes" / "fine_map.toml").read_text()
    text = text.replace("num = 400 }", "num = 4000 }").replace("num = 250 }", "num = 2500 }")
    text = text.replace('name = "fine_map"', 'name = "scale_1e7"')
    path = os.path.join(folder, "scale_1e7.toml")
    Path(path).write_text(text)
    return path


def _noop_task(i):
    return {"index": (i, 0, 0), "seconds": 0.0, "pid": os.getpid()}


# -- what the tasks of sections 3 and 4 run (on the workers; the block is read from a file) ---

def _load_block(path: str) -> dict[str, np.ndarray]:
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def _slices(j: int, c_o: int) -> tuple[slice, slice, slice]:
    return (slice(0, c_o), slice(j, j + 1), slice(0, 1))


def _task_returning_the_block(job: dict) -> dict:
    """Before: the block's arrays go back to the client."""
    arrays = _load_block(job["block"])
    return {"index": (0, job["j"], 0), "arrays": arrays, "seconds": 0.0, "pid": os.getpid()}


def _task_writing_the_block(job: dict) -> dict:
    """Now (scheduler.worker.run_task after its solve): the worker stages its block and
    returns the run summary's counts and the error-sample candidates."""
    from hertzmap.scheduler.report import block_counts
    from hertzmap.scheduler.sample import block_candidates
    from hertzmap.scheduler.store import stage_task_block

    time.sleep(job.get("sleep", 0.0))
    if job.get("block") is None:
        return {"index": (0, job["j"], 0), "seconds": 0.0, "write_seconds": 0.0,
                "pid": os.getpid(), "counts": None, "samples": []}
    arrays = _load_block(job["block"])
    t0 = time.perf_counter()
    stage_task_block(job["store"], job["owner"], tuple(job["index"]), arrays)
    dt = time.perf_counter() - t0
    axes = (np.asarray(job["omega"]), np.array([0.5]), np.array([0.01]))
    return {"index": (0, job["j"], 0), "seconds": job.get("sleep", 0.0), "write_seconds": dt,
            "pid": os.getpid(), "counts": block_counts(arrays),
            "samples": block_candidates(arrays, axes, job["sample"])}


class _Processes:
    """A ``dask scheduler`` process and ``dask worker`` processes on the loopback."""

    def __init__(self, workers: int):
        from distributed.utils import open_port

        port = open_port()
        self.address = f"tcp://127.0.0.1:{port}"
        env = dict(os.environ, PYTHONPATH=str(ROOT), DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED="False",
                   DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL="200ms",
                   DASK_DISTRIBUTED__ADMIN__SYSTEM_MONITOR__INTERVAL="2s",
                   DASK_DISTRIBUTED__WORKER__MEMORY__MONITOR_INTERVAL="1s")
        quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env}
        self.scheduler = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
             "--port", str(port), "--no-dashboard"], **quiet)
        self.workers = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", self.address, "--nworkers",
             str(workers), "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1",
             "--memory-limit", "0"], **quiet)
        self.n = workers

    def cpu(self) -> dict[str, float]:
        """CPU seconds so far of the scheduler and of every worker process (nannies included)."""
        import psutil

        def total(p):
            t = p.cpu_times()
            return t.user + t.system

        sched = psutil.Process(self.scheduler.pid)
        top = psutil.Process(self.workers.pid)
        workers = total(top) + sum(total(c) for c in top.children(recursive=True))
        return {"scheduler": total(sched), "workers": workers}

    def close(self) -> None:
        for p in (self.workers, self.scheduler):
            p.terminate()
        for p in (self.workers, self.scheduler):
            try:
                p.wait(timeout=60)
            except subprocess.TimeoutExpired:
                p.kill()


def _client_cpu() -> float:
    t = os.times()
    return t.user + t.system


def _run_tasks(client, fn, jobs, on_result) -> float:
    """Submit ``jobs`` as run.py does (client.map, as_completed), ``on_result`` on the client
    for each result; returns the wall."""
    from distributed import as_completed

    t0 = time.perf_counter()
    futs = client.map(fn, jobs, pure=False)
    for f in as_completed(futs):
        on_result(f.result())
        f.release()
    return time.perf_counter() - t0


# -- the command line ------------------------------------------------------------------------------

def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="what", required=True, metavar="SUBCOMMAND")

    def command(name, fn, short):
        p = sub.add_parser(name, help=short, description=inspect.cleandoc(fn.__doc__),
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        p.set_defaults(run=fn)
        return p

    p = command("grid", cmd_grid,
                "solver time per stored orbit against the kernel's, and where the rest goes")
    p.add_argument("--study", default=str(ROOT / "scenes" / "default.toml"))
    p.add_argument("--every", type=int, default=4, help="every k-th sigma line (default 4)")
    p.add_argument("--sample", type=int, default=1000, help="stored orbits re-solved")
    p.add_argument("--no-breakdown", action="store_true")

    p = command("census", cmd_census,
                "shooting against the attractor census on a scene's lines, CPU")
    p.add_argument("--study", default="scenes/vibro_impact.toml")
    p.add_argument("--lines", type=int, default=8, help="every k-th sigma line")

    p = command("curves", cmd_curves,
                "a traced curve against bisection and fine grids; the default scene with and without curves")
    p.add_argument("--skip-scene", action="store_true", help="sections 1-3 only")
    p.add_argument("--scene-only", action="store_true", help="section 4 only")
    p.add_argument("--pairs", type=int, default=3, help="ABBA rounds of the default scene")

    p = command("throughput", cmd_throughput,
                "a small study on 1 and 2 Dask workers; --ceiling: the machine's own")
    p.add_argument("--omega", type=int, default=41)
    p.add_argument("--sigma", type=int, default=25)
    p.add_argument("--workers", default="1,2",
                   help="comma-separated worker counts to run on (efficiency needs 1 and 2)")
    p.add_argument("--ceiling", action="store_true",
                   help="only measure what the machine gives two solver processes (no Dask)")
    p.add_argument("--with-profiler", action="store_true",
                   help="workers keep Dask's stack profiler on (what scheduler.cluster turns off)")
    p.add_argument("--no-cold-start", action="store_true", help="skip the numba cold-start figure")

    p = command("task-size", cmd_task_size,
                "two --task-seconds targets, ABBA: grid wall and the client's CPU")
    p.add_argument("--study", default="scenes/default.toml")
    p.add_argument("--a", type=float, default=0.25,
                   help="task seconds of run A (one sigma line per task on the default study "
                        "and the fine map, as before 2026-11-24)")
    p.add_argument("--b", type=float, default=2.0, help="task seconds of run B (the default)")
    p.add_argument("--pairs", type=int, default=2, help="ABBA rounds")

    p = command("store", cmd_store,
                "a store's bytes, files and writes, this checkout against another, ABBA")
    p.add_argument("--vs", required=True, help="the other version's Python (its venv)")
    p.add_argument("--scene", action="append", help="a shipped scene (repeatable)")
    p.add_argument("--pairs", type=int, default=1, help="ABBA rounds per scene")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--keep", type=Path, default=None, help="keep the stores in this folder")

    p = command("scale", cmd_scale,
                "per-task costs besides the solves: client, scheduler, store, many workers")
    p.add_argument("--study")
    p.add_argument("--tasks", type=int, default=2000)
    p.add_argument("--workers", default="8,32,64",
                   help="worker process counts of section 4 (comma-separated; empty: skip it)")
    p.add_argument("--sleep", type=float, default=2.0)
    p.add_argument("--rounds", type=int, default=3)

    a = ap.parse_args(argv)
    return a.run(a)


if __name__ == "__main__":
    sys.exit(main())
