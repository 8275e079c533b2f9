"""What Dask's worker stack profiler costs the solvers: the same block on 2 busy workers with the
profiler's periodic callbacks started and stopped in alternation (ABBA), in one cluster.

    .venv/bin/python benchmarks/archive/dask_profiler_ab.py [--rounds 20]      (about 30 s)

Each round both workers solve the same block (161 omega x 2 sigma, 1T and 2T seeds, rtol 1e-10)
at once, with the profiler on or off in both. Printed: wall time per block, median and fastest,
and their ratios on / off. scheduler.cluster.clusters starts its workers with the profiler off
(CLUSTER_CONFIG); ``run_cost.py throughput --with-profiler`` compares whole studies (noisier).
"""
from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def solve_one_block(_tag):
    import time

    from hertzmap.study.solve.block import solve_block
    t0 = time.perf_counter()
    solve_block(np.linspace(0.5, 2.5, 161), np.array([0.4, 0.5]), np.array([0.01]),
                periods=(1, 2), rtol=1e-10)
    return time.perf_counter() - t0


def set_profiler(on, dask_worker):
    for name in ("profile", "profile-cycle"):
        callback = dask_worker.periodic_callbacks[name]
        callback.start() if on else callback.stop()
    return on


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=20)
    a = ap.parse_args(argv)
    import dask
    from distributed import Client, LocalCluster

    # start with the profiler on (Dask's default), whatever the local config says
    with dask.config.set({"distributed.worker.profile.enabled": True}):
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    try:
        workers = list(client.scheduler_info()["workers"])
        client.gather([client.submit(solve_one_block, w, workers=[w], pure=False)
                       for w in workers])                               # warm the kernels
        times = {True: [], False: []}
        for r in range(a.rounds):
            for on in ((True, False) if r % 2 == 0 else (False, True)):
                client.run(set_profiler, on)
                futures = [client.submit(solve_one_block, (r, on, w), workers=[w], pure=False)
                           for w in workers]
                times[on] += client.gather(futures)
    finally:
        client.close()
        cluster.close()
    for on in (True, False):
        t = np.array(times[on])
        print(f"profiler {'on ' if on else 'off'}: {t.size} blocks, wall per block median "
              f"{np.median(t):.3f} s, fastest {t.min():.3f} s")
    print(f"on / off: median {np.median(times[True]) / np.median(times[False]):.3f}, fastest "
          f"{min(times[True]) / min(times[False]):.3f}")


if __name__ == "__main__":
    main()
