"""CPU that an idle embedded Dask cluster burns: Dask's defaults against scheduler.cluster.clusters's
trimmed config (no stack profiler, 200 ms event-loop ticks, slower system and memory monitors).

    .venv/bin/python benchmarks/archive/dask_idle_cpu.py [--seconds 15] [--rounds 2] [--each]
                                                          (about a minute; --each: 3 minutes)

A LocalCluster of 2 single-threaded worker processes (as `hertzmap run` starts on 2 cores) sits
idle; the CPU time of this process and all its children (client, scheduler, nannies, workers)
over the window is printed as a share of one core. On a machine whose cores the solvers fill,
that share is taken from them. Configs alternate round by round.
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def tree_cpu_seconds(pid: int) -> float:
    import psutil

    root = psutil.Process(pid)
    total = 0.0
    for proc in [root] + root.children(recursive=True):
        try:
            t = proc.cpu_times()
            total += t.user + t.system
        except psutil.NoSuchProcess:
            pass
    return total


def idle_share(config: dict, seconds: float) -> float:
    import dask
    from distributed import Client, LocalCluster

    with dask.config.set(config):
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
        client = Client(cluster)
    try:
        time.sleep(3.0)                     # start-up done
        c0, t0 = tree_cpu_seconds(os.getpid()), time.perf_counter()
        time.sleep(seconds)
        c1, t1 = tree_cpu_seconds(os.getpid()), time.perf_counter()
    finally:
        client.close()
        cluster.close()
    return (c1 - c0) / (t1 - t0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=15.0)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--each", action="store_true",
                    help="also each setting of CLUSTER_CONFIG alone, on Dask's defaults")
    a = ap.parse_args(argv)
    from hertzmap.scheduler.cluster.clusters import CLUSTER_CONFIG

    configs = {"Dask defaults": {}, "scheduler.cluster.clusters.CLUSTER_CONFIG": CLUSTER_CONFIG}
    if a.each:
        configs.update({f"only {k.split('.', 1)[1]}": {k: v} for k, v in CLUSTER_CONFIG.items()})
    for r in range(a.rounds):
        for name, config in configs.items():
            share = idle_share(config, a.seconds)
            print(f"round {r + 1}, {name:40s}: {100 * share:5.1f} % of a core")


if __name__ == "__main__":
    main()
