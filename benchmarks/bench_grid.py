"""Throughput of a grid study on 1 and 2 Dask workers, Dask overhead per task, numba cold start
with and without the compile cache, peak memory per worker, and the study's own error estimate.

    .venv/bin/python benchmarks/bench_grid.py [--omega 41] [--sigma 25] [--workers 1,2]
                                                                          (about a minute)
    .venv/bin/python benchmarks/bench_grid.py --omega 400 --sigma 250 --workers 2
                                    (the 100,000-point target, run for real: 1-2 minutes)
    .venv/bin/python benchmarks/bench_grid.py --ceiling
                                    (two solver processes at once vs one, no Dask: ~10 s)
    .venv/bin/python benchmarks/bench_grid.py --omega 161 --sigma 77 --with-profiler
                                    (workers with Dask's stack profiler on, as Dask's default)

A small study (the default study's (omega, sigma) window at zeta 0.01, 1T and 2T seeds, rtol
1e-10; 41 x 25 = 1025 points by default) is run with ``scheduler.run.run_study`` into stores in a
temporary directory, on the LocalCluster `hertzmap run` starts (scheduler.cluster.make_client:
1 then 2 single-threaded worker processes, Dask's housekeeping trimmed; started before timing, kernels warmed from the numba cache by the worker plugin). Figures:

* points/s = grid points / wall time from submission to the last write (setup excluded);
  parallel efficiency = points/s on 2 workers / (2 x points/s on 1 worker);
* Dask overhead per task: (workers x wall - sum of solver times inside the tasks) / tasks, and the
  round trip of an empty task (client.map over 200 no-ops);
* cold start: a new process importing the block solver and solving one point
  (scheduler.worker.warm_up), with an empty numba cache dir, then again from that cache;
* peak memory: ru_maxrss of every worker process after the run (client.run);
* the error estimate the run stored in the store's attrs (hertzmap_error_estimate).
"""
from __future__ import annotations

import argparse
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

STUDY = """
[study]
name = "bench_grid"
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
max_solutions = 4

[search]
periods = [1, 2]

[products]
outputs = ["orbits", "measures"]
"""


def _maxrss_mb():
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _noop(i):
    return i


def cold_start(cache_dir: str) -> float:
    code = ("import time; t = time.perf_counter(); from hertzmap.scheduler.worker import warm_up; "
            "warm_up(); print(time.perf_counter() - t)")
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       check=True, cwd=Path(__file__).resolve().parents[1])
    return float(r.stdout.strip().splitlines()[-1])


def _solve_default_window(_):
    """Seconds per block (4 sigma lines x 161 omega of the default window), best of 3."""
    import numpy as np

    from hertzmap.study.solve.block import solve_block
    omega, sigma, zeta = np.linspace(0.5, 2.5, 161), np.array([0.1, 0.3, 0.5, 0.8]), np.array([0.01])
    solve_block(omega[:5], sigma[:1], zeta, harmonics=False)      # kernels from the cache
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        solve_block(omega, sigma, zeta, harmonics=False)
        times.append(time.perf_counter() - t0)
    return min(times)


def machine_ceiling() -> float:
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


def run_on(workers: int, study, tmp: Path) -> dict:
    from hertzmap.scheduler.cluster import ClusterSpec, make_client
    from hertzmap.scheduler.run import RunOptions, run_study
    from hertzmap.scheduler.store import read_attrs

    spec = ClusterSpec(kind="local", workers=workers)
    client, cluster = make_client(spec)     # the cluster `hertzmap run` would start
    try:
        opts = RunOptions(store=tmp / f"w{workers}.zarr", cluster=spec,
                          command=f"bench_grid {workers} workers")
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
        s["attr"] = json.loads((read_attrs(opts.store) or {}).get("hertzmap_error_estimate", "null") or "null")
    finally:
        client.close()
        cluster.close()
    return s


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--omega", type=int, default=41)
    ap.add_argument("--sigma", type=int, default=25)
    ap.add_argument("--workers", default="1,2",
                    help="comma-separated worker counts to run on (efficiency needs 1 and 2)")
    ap.add_argument("--ceiling", action="store_true",
                    help="only measure what the machine gives two solver processes (no Dask)")
    ap.add_argument("--with-profiler", action="store_true",
                    help="workers keep Dask's stack profiler on (what scheduler.cluster turns off)")
    ap.add_argument("--no-cold-start", action="store_true", help="skip the numba cold-start figure")
    a = ap.parse_args(argv)
    if a.with_profiler:
        from hertzmap.scheduler import cluster
        cluster.CLUSTER_CONFIG = {**cluster.CLUSTER_CONFIG,
                                            "distributed.worker.profile.enabled": True}
    if a.ceiling:
        machine_ceiling()
        return
    counts = [int(w) for w in a.workers.split(",")]
    import logging
    for name in ("distributed", "tornado", "asyncio"):   # shutdown chatter (closed comms)
        logging.getLogger(name).setLevel(logging.CRITICAL)
    from hertzmap.study.spec import load_study

    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start "
          "(shared machine: timings are noisy)")
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        (tmp / "s.toml").write_text(STUDY.format(n_omega=a.omega, n_sigma=a.sigma))
        study = load_study(tmp / "s.toml")
        print(f"study: {a.omega} omega x {a.sigma} sigma x 1 zeta = {study.size} points, "
              "periods 1 and 2, rtol 1e-10")
        res = {w: run_on(w, study, tmp) for w in counts}
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
        return
    with tempfile.TemporaryDirectory() as cache:
        cold = cold_start(cache)
        warm = cold_start(cache)
    print(f"numba cold start (new process, import the block solver, solve one point): "
          f"{cold:.1f} s with an empty cache, {warm:.2f} s from the disk cache")


if __name__ == "__main__":
    main()
