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
benchmarks/run_summary.py reads back the figures a ``hertzmap run`` prints.
"""
from __future__ import annotations

import argparse
import inspect
import io
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.abba import abba, load_average  # noqa: E402


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
    (scheduler.cluster.clusters.make_client: 1 then 2 single-threaded worker processes, Dask's
    housekeeping trimmed; started before timing, kernels warmed from the numba cache by the
    worker plugin). Figures:

    * points/s = grid points / wall time from submission to the last write (setup excluded);
      parallel efficiency = points/s on 2 workers / (2 x points/s on 1 worker);
    * Dask overhead per task: (workers x wall - sum of solver times inside the tasks) / tasks,
      and the round trip of an empty task (client.map over 200 no-ops);
    * cold start: a new process importing the block solver and solving one point
      (scheduler.stages.worker.warm_up), with an empty numba cache dir, then again from that cache;
    * peak memory: ru_maxrss of every worker process after the run (client.run);
    * the error estimate the run stored in the store's attrs (hertzmap_error_estimate).
    """
    if a.with_profiler:
        from hertzmap.scheduler.cluster import clusters as cluster
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
    code = ("import time; t = time.perf_counter(); from hertzmap.scheduler.stages.worker import warm_up; "
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
    from hertzmap.scheduler.cluster.clusters import ClusterSpec, make_client
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


# -- store: bytes, files and writes, two versions, ABBA ----------------------------------------

#: what each store run executes in the version's own Python: the run, then its summary as JSON
_STORE_RUN = r"""
import json, sys
from pathlib import Path
from hertzmap.scheduler.cluster.clusters import ClusterSpec
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


# -- the command line ------------------------------------------------------------------------------

def main(argv=None) -> int:
    from benchmarks.curve_cost import cmd_curves
    from benchmarks.scale_cost import cmd_scale, cmd_task_size

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
                   help="workers keep Dask's stack profiler on (what scheduler.cluster.clusters turns off)")
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
