"""The per-task costs a large study pays besides its solves, measured here, for docs/running.md's
"Scale on paper" (a study of 10^8 points on 1,000 workers).

    .venv/bin/python benchmarks/scale_overheads.py [--study STUDY.toml] [--tasks 2000]
        [--workers 8,32,64] [--sleep 2.0] [--rounds 3]

STUDY (default: the fine map's grid at 4000 omega x 2500 sigma, 10^7 points, written to a
temporary file: its tasks are those of a 10^8 study, which only has ten times as many) is
planned as ``hertzmap run`` plans it (scheduler.plan), and then:

1. **Client bookkeeping**: the plan and the task specs (scheduler.run.task_specs) for every
   task, built in this process: traced Python memory (tracemalloc) and one spec's pickle.
2. **Store**: the template written with Store.create (time, files), then one real block (8
   lines of the study solved here, tiled to the chunk's size) written 5 times with
   scheduler.store.BlockWriter: time per block write (what a worker now pays per task) and
   the chunk's bytes and files on disk.
3. **Client CPU per task, before and after, in one run**: a ``dask scheduler`` process and 2
   single-threaded worker processes (their own processes, so that the client's CPU is its
   own: psutil), 20 block-sized tasks in each mode, alternated:
   * *client writes* (hertzmap until this change): the task returns the block's arrays; the
     client receives them, writes the block, sets the flag, counts (block_counts) and samples;
   * *worker writes* (now): the task writes its block (store.write_task_block) and returns
     its summary (block_counts, the error-sample candidates); the client sets the flag and
     adds the counts.
   Printed: the client's and the scheduler's CPU ms per task, the wall per task.
4. **Many workers**: a ``dask scheduler`` process and ``dask worker --nworkers W`` for each W of
   ``--workers``; tasks that sleep ``--sleep`` s (a solve that costs no CPU) and then write a
   real block into the store as run_task does; ``--rounds`` tasks per worker. Printed: tasks
   per second against the W / sleep the workers could take, the client's, the scheduler's
   and the workers' CPU per task, the block write's wall on the worker. Then W = the largest,
   tasks that only sleep 0.05 s and write nothing: the most tasks per second the scheduler and
   the client pass on this machine, and which of the two is busy.
"""
from __future__ import annotations

import argparse
import os
import pickle
import shutil
import subprocess
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
    text = (ROOT / "scenes" / "fine_map.toml").read_text()
    text = text.replace("num = 400 }", "num = 4000 }").replace("num = 250 }", "num = 2500 }")
    text = text.replace('name = "fine_map"', 'name = "scale_1e7"')
    path = os.path.join(folder, "scale_1e7.toml")
    Path(path).write_text(text)
    return path


def noop(i):
    return {"index": (i, 0, 0), "seconds": 0.0, "pid": os.getpid()}


# -- what the tasks of sections 3 and 4 run (on the workers; the block is read from a file) ---

def _load_block(path: str) -> dict[str, np.ndarray]:
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def _slices(j: int, c_o: int) -> tuple[slice, slice, slice]:
    return (slice(0, c_o), slice(j, j + 1), slice(0, 1))


def task_returning_the_block(job: dict) -> dict:
    """Before: the block's arrays go back to the client."""
    arrays = _load_block(job["block"])
    return {"index": (0, job["j"], 0), "arrays": arrays, "seconds": 0.0, "pid": os.getpid()}


def task_writing_the_block(job: dict) -> dict:
    """Now (scheduler.worker.run_task after its solve): the worker writes its block and
    returns the run summary's counts and the error-sample candidates."""
    from hertzmap.scheduler.report import block_counts
    from hertzmap.scheduler.sample import block_candidates
    from hertzmap.scheduler.store import write_task_block

    time.sleep(job.get("sleep", 0.0))
    if job.get("block") is None:
        return {"index": (0, job["j"], 0), "seconds": 0.0, "write_seconds": 0.0,
                "pid": os.getpid(), "counts": None, "samples": []}
    arrays = _load_block(job["block"])
    t0 = time.perf_counter()
    write_task_block(job["store"], job["owner"], _slices(job["j"], job["c_o"]), arrays,
                     tuple(job["names"]))
    dt = time.perf_counter() - t0
    axes = (np.asarray(job["omega"]), np.array([0.5]), np.array([0.01]))
    return {"index": (0, job["j"], 0), "seconds": job.get("sleep", 0.0), "write_seconds": dt,
            "pid": os.getpid(), "counts": block_counts(arrays),
            "samples": block_candidates(arrays, axes, job["sample"])}


class Processes:
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


def client_cpu() -> float:
    t = os.times()
    return t.user + t.system


def run_tasks(client, fn, jobs, on_result) -> float:
    """Submit ``jobs`` as run.py does (client.map, as_completed), ``on_result`` on the client
    for each result; returns the wall."""
    from distributed import as_completed

    t0 = time.perf_counter()
    futs = client.map(fn, jobs, pure=False)
    for f in as_completed(futs):
        on_result(f.result())
        f.release()
    return time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study")
    ap.add_argument("--tasks", type=int, default=2000)
    ap.add_argument("--workers", default="8,32,64",
                    help="worker process counts of section 4 (comma-separated; empty: skip it)")
    ap.add_argument("--sleep", type=float, default=2.0)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args(argv)

    from hertzmap.scheduler.plan import choose_chunks, make_plan
    from hertzmap.scheduler.report import SUMMED_COUNTS, WORST_COUNTS, add_counts, block_counts
    from hertzmap.scheduler.run import task_specs
    from hertzmap.scheduler.sample import Sampler, block_candidates
    from hertzmap.scheduler.store import Lock, Store
    from hertzmap.study.schema import empty_arrays, stored_variables
    from hertzmap.study.solve.block import solve_block
    from hertzmap.study.spec import load_study

    tmp = tempfile.mkdtemp(prefix="hertzmap-scale-")
    procs: Processes | None = None
    try:
        study = load_study(a.study or big_study_file(tmp))
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
            return dict(base, j=j, sample=sampler.task_spec(task), **extra)

        # 3. client CPU per task, before and after (one run, modes alternated)
        from distributed import Client
        procs = Processes(2)
        with Client(procs.address) as client:
            client.wait_for_workers(2)
            client.run(lambda: __import__("hertzmap.scheduler.store"))
            client.submit(noop, -1).result()
            t0 = time.perf_counter()
            n = a.tasks
            futs = client.map(noop, range(n), pure=False)
            cpu0, c0 = client_cpu(), procs.cpu()
            from distributed import as_completed
            for f in as_completed(futs):
                f.result()
                f.release()
            dt = time.perf_counter() - t0
            c1 = procs.cpu()
            print(f"scheduler, 2 workers, {n} no-op tasks: {dt:.2f} s, {dt / n * 1e3:.2f} ms per "
                  f"task; client {(client_cpu() - cpu0) / n * 1e3:.2f} ms CPU per task, scheduler "
                  f"{(c1['scheduler'] - c0['scheduler']) / n * 1e3:.2f} ms", flush=True)

            results: dict[str, list] = {"client writes": [], "worker writes": []}
            next_j = [5]
            for _ in range(2):
                for mode in results:
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

                    cpu0, c0 = client_cpu(), procs.cpu()
                    if mode == "client writes":
                        wall = run_tasks(client, task_returning_the_block, jobs, before)
                    else:
                        wall = run_tasks(client, task_writing_the_block, jobs, after)
                    c1 = procs.cpu()
                    results[mode].append(((client_cpu() - cpu0) / n,
                                          (c1["scheduler"] - c0["scheduler"]) / n,
                                          (c1["workers"] - c0["workers"]) / n, wall / n))
            for mode, rows in results.items():
                cl, sc, wk, wl = (sorted(x) for x in zip(*rows))
                print(f"{mode}, 2 workers, 2 x 20 block-sized tasks: client {cl[0] * 1e3:.0f}-"
                      f"{cl[-1] * 1e3:.0f} ms CPU per task, scheduler {sc[0] * 1e3:.1f}-"
                      f"{sc[-1] * 1e3:.1f} ms, workers {wk[0] * 1e3:.0f}-{wk[-1] * 1e3:.0f} ms; "
                      f"wall {wl[0] * 1e3:.0f}-{wl[-1] * 1e3:.0f} ms per task", flush=True)
        procs.close()
        procs = None

        # 4. many workers
        counts = [int(w) for w in a.workers.split(",") if w.strip()]
        for w in counts:
            procs = Processes(w)
            with Client(procs.address) as client:
                client.wait_for_workers(w, timeout=900)
                client.run(lambda: __import__("hertzmap.scheduler.store"))
                client.map(noop, range(-w, 0), pure=False)
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
                    cpu0, c0 = client_cpu(), procs.cpu()
                    wall = run_tasks(client, task_writing_the_block, jobs, flag)
                    c1 = procs.cpu()
                    rate, ideal = n / wall, w / sleep
                    print(f"{w} workers, {n} tasks ({label}): {wall:.1f} s, {rate:.1f} tasks/s of "
                          f"{ideal:.0f} possible ({rate / ideal:.0%}); per task: client "
                          f"{(client_cpu() - cpu0) / n * 1e3:.1f} ms CPU, scheduler "
                          f"{(c1['scheduler'] - c0['scheduler']) / n * 1e3:.1f} ms, workers "
                          f"{(c1['workers'] - c0['workers']) / n * 1e3:.1f} ms; block write "
                          f"{np.median(writes) * 1e3:.0f} ms wall (median); client busy "
                          f"{(client_cpu() - cpu0) / wall:.0%}, scheduler "
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


if __name__ == "__main__":
    sys.exit(main())
