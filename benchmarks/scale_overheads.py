"""The per-task costs a large study pays besides its solves, measured here, for docs/running.md's
"Scale on paper" (a 10^7-point study on a cluster).

    .venv/bin/python benchmarks/scale_overheads.py [--study STUDY.toml] [--tasks 2000]

STUDY (default: the default study's grid at 4000 omega x 2500 sigma, 10^7 points, written to a
temporary file) is planned as ``hertzmap run`` plans it (scheduler.plan), and then:

1. **Client bookkeeping**: the plan and the task specs (what the client hands to Dask: the
   block's axes, the solver's options) for every task, built in this process: traced Python
   memory (tracemalloc) and the pickled size of one spec.
2. **Store**: the template written with Store.create into a temporary folder (metadata,
   coordinates and task flags only: time and files), then one block written with
   Store.write_block from a block of the default study (8 of its lines solved here and
   repeated to the chunk's size): time per block write and the chunk's bytes on disk
   (compressed) against its uncompressed bytes.
3. **Scheduler**: ``--tasks`` no-op tasks (returning a small dict) through a LocalCluster of 2
   single-threaded worker processes, submitted with client.map and gathered with
   as_completed, as the run does: scheduler + client time per task (the round trip a task
   costs beyond its work). And 20 tasks that each return one block's arrays (the chunk's size):
   the transfer's time per task.
"""
from __future__ import annotations

import argparse
import os
import pickle
import shutil
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.machine import load_average  # noqa: E402


def big_study_file(folder: str) -> str:
    text = (ROOT / "studies" / "fine_map.toml").read_text()
    text = text.replace("num = 400 }", "num = 4000 }").replace("num = 250 }", "num = 2500 }")
    text = text.replace('name = "fine_map"', 'name = "scale_1e7"')
    path = os.path.join(folder, "scale_1e7.toml")
    Path(path).write_text(text)
    return path


def noop(i):
    return {"index": (i, 0, 0), "seconds": 0.0, "pid": os.getpid()}


def block_payload(nbytes_spec):
    names, shape, slots = nbytes_spec
    from hertzmap.study.schema import empty_arrays
    return {"index": (0, 0, 0), "arrays": empty_arrays(shape, slots, names), "seconds": 0.0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study")
    ap.add_argument("--tasks", type=int, default=2000)
    a = ap.parse_args(argv)

    from hertzmap.scheduler.plan import choose_chunks, make_plan
    from hertzmap.scheduler.run import task_specs
    from hertzmap.scheduler.store import Store
    from hertzmap.study.schema import empty_arrays, stored_variables
    from hertzmap.study.solve.block import solve_block
    from hertzmap.study.spec import load_study

    tmp = tempfile.mkdtemp(prefix="hertzmap-scale-")
    try:
        study = load_study(a.study or big_study_file(tmp))
        chunks = choose_chunks(study)
        print(f"{study.name}: {study.size:,} points, chunk {chunks}; load average "
              + load_average(), flush=True)

        # 1. client bookkeeping
        tracemalloc.start()
        plan = make_plan(study, chunks)
        specs = task_specs(study, plan.tasks, study.solver_kwargs(), stored_variables(study),
                           None, 600.0)
        current, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        om, zt = study.axis("omega"), study.axis("zeta")
        kwargs, names = study.solver_kwargs(), stored_variables(study)
        one = len(pickle.dumps(specs[0]))
        print(f"client: {len(plan.tasks):,} tasks; plan + task specs {current / 2**20:.1f} MiB "
              f"traced ({current / len(plan.tasks) / 1024:.1f} KiB per task); one spec pickled "
              f"{one / 1024:.1f} KiB", flush=True)

        # 2. store
        path = os.path.join(tmp, "store.zarr")
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
        arrays = {k: np.concatenate([v] * reps, axis=0)[:c_o] for k, v in line.items()}
        vnames = names
        arrays = {k: v for k, v in arrays.items() if k in vnames}
        missing = [n for n in vnames if n not in arrays]
        if missing:
            arrays.update(empty_arrays((c_o, 1, 1), study.max_solutions, tuple(missing)))
        times = []
        for j in range(5):
            sl = (slice(0, c_o), slice(j, j + 1), slice(0, 1))
            t0 = time.perf_counter()
            store.write_block(sl, arrays, tuple(vnames))
            times.append(time.perf_counter() - t0)
        raw = sum(v.nbytes for v in arrays.values())
        before = size
        size = sum(os.path.getsize(os.path.join(d, x)) for d, _, f in os.walk(path) for x in f)
        per_chunk = (size - before) / 5
        print(f"block write: {np.median(times) * 1e3:.0f} ms per block (median of 5); one block "
              f"{raw / 2**20:.2f} MiB uncompressed, {per_chunk / 2**20:.2f} MiB on disk "
              f"({raw / per_chunk:.1f}x compression); {len(vnames)} variables", flush=True)
        payload_spec = (tuple(vnames), (c_o, 1, 1), study.max_solutions)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    # 3. scheduler
    from distributed import Client, LocalCluster, as_completed
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        client.submit(noop, -1).result()
        for label, fn, n, arg in (("no-op", noop, a.tasks, None),
                                  ("one block's arrays", block_payload, 20, payload_spec)):
            t0 = time.perf_counter()
            futs = client.map(fn, range(n), pure=False) if arg is None else \
                client.map(fn, [arg] * n, pure=False)
            for f in as_completed(futs):
                f.result()
                f.release()
            dt = time.perf_counter() - t0
            print(f"scheduler, 2 workers, {n} {label} tasks: {dt:.2f} s, {dt / n * 1e3:.2f} ms "
                  f"per task", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
