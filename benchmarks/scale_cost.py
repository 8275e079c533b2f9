"""``run_cost.py scale``: the per-task costs a large study pays besides its solves (client,
scheduler, store, many workers), for docs/running.md's "Scale on paper"; ``run_cost.py
task-size``: one study with two task sizes, ABBA.

    .venv/bin/python benchmarks/run_cost.py scale [--workers 8,32,64] [--tasks 1000]
"""
from __future__ import annotations

import os
import pickle
import re
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

from benchmarks.abba import abba, load_average, load_line  # noqa: E402
from benchmarks.run_summary import run_summary  # noqa: E402


# -- scale: per-task costs besides the solves --------------------------------------------------

def cmd_scale(a) -> int:
    """The per-task costs a large study pays besides its solves, measured here, for
    docs/running.md's "Scale on paper" (a study of 10^8 points on 1,000 workers).

    STUDY (``--study``; default: the fine map's grid at 4000 omega x 2500 sigma, 10^7 points,
    written to a temporary file: its tasks are those of a 10^8 study, which only has ten times
    as many) is planned as ``hertzmap run`` plans it (scheduler.stages.plan), and then:

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
    from hertzmap.scheduler.stages.plan import choose_chunks, make_plan
    from hertzmap.scheduler.doors.report import SUMMED_COUNTS, WORST_COUNTS, add_counts, block_counts
    try:                                        # the grid stage's module, since the stage runner
        from hertzmap.scheduler.stages.grid_tasks import task_specs
    except ImportError:
        from hertzmap.scheduler.run import task_specs
    from hertzmap.scheduler.stages.sample import Sampler, block_candidates
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
    """Now (scheduler.stages.worker.run_task after its solve): the worker stages its block and
    returns the run summary's counts and the error-sample candidates."""
    from hertzmap.scheduler.doors.report import block_counts
    from hertzmap.scheduler.stages.sample import block_candidates
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
