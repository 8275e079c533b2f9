"""How evenly a study's tasks load 2 workers: each task's solve time, and the tail it leaves.

    .venv/bin/python benchmarks/archive/task_balance.py [N_OMEGA N_SIGMA]     (default 161 77, ~25 s)

Plans the study of ``benchmarks/run_cost.py throughput`` (omega 0.5-2.5, sigma 0.05-1, zeta 0.01, 1T and 2T
seeds) with the chunking `hertzmap run` would choose, solves every task's block in this process
(``scheduler.stages.worker.run_task``, one at a time, after one warm-up), prints each task's time, and
the makespan of greedy list scheduling on 2 workers (each task to the first free worker, as
Dask hands out queued tasks) in submission order, reversed, and longest first, against the
ideal (total / 2). The gap is the share of the 2-worker wall time the tail costs.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks.run_cost import THROUGHPUT_STUDY as STUDY  # noqa: E402
from hertzmap.scheduler.stages.plan import choose_chunks, make_plan  # noqa: E402
from hertzmap.scheduler.stages.worker import run_task  # noqa: E402
from hertzmap.study.spec import load_study  # noqa: E402


def makespan(seconds: np.ndarray, order, workers: int = 2) -> float:
    free = np.zeros(workers)
    for i in order:
        free[np.argmin(free)] += seconds[i]
    return float(free.max())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("n_omega", nargs="?", type=int, default=161)
    ap.add_argument("n_sigma", nargs="?", type=int, default=77)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "s.toml"
        path.write_text(STUDY.format(n_omega=a.n_omega, n_sigma=a.n_sigma))
        study = load_study(path)
    plan = make_plan(study, choose_chunks(study))
    kwargs = study.solver_kwargs()
    om, sg, zt = study.axis("omega"), study.axis("sigma"), study.axis("zeta")
    seconds = []
    for k, task in enumerate(plan.tasks):
        so, ss, sz = task.slices
        spec = {"index": task.index, "omega": om[so], "sigma": sg[ss], "zeta": zt[sz],
                "kwargs": kwargs, "names": ["status"]}
        if k == 0:
            run_task(spec)                  # numba's disk cache, first-call costs
        seconds.append(run_task(spec)["seconds"])
        print(f"task {task.index}: omega {om[so][0]:.3f}-{om[so][-1]:.3f}, sigma "
              f"{sg[ss][0]:.3f}-{sg[ss][-1]:.3f}: {seconds[-1]:.3f} s")
    s = np.array(seconds)
    ideal = s.sum() / 2
    print(f"{len(s)} tasks, {s.sum():.2f} s in all (min {s.min():.3f}, max {s.max():.3f} s)")
    for label, order in (("submission order", range(len(s))),
                         ("reversed", range(len(s) - 1, -1, -1)),
                         ("longest first", np.argsort(-s))):
        m = makespan(s, order)
        print(f"2 workers, {label:16s}: makespan {m:.2f} s against {ideal:.2f} s ideal "
              f"(tail {100 * (m / ideal - 1):.1f} %)")


if __name__ == "__main__":
    main()
