"""Run a study: plan, open/create the store, ship blocks to Dask, write results as they come.

The client is the only writer: for each finished task (``distributed.as_completed``) it
writes the block (a region write of whole chunks) and then sets the task's ``task_done`` flag.
Durability comes from the store, not from Dask: rerunning the same command computes only
the tasks not flagged.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import math
import os
import shutil
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from scheduler.cluster import (JOBQUEUE, ClusterSpec, WorkerJobsEnded, make_client,
                               wait_for_first_worker, worker_count)
from kernels.status import TIME_LIMIT
from scheduler.plan import (DEFAULT_TASK_SECONDS, DEFAULT_TASK_TIMEOUT, Plan, Task, choose_chunks,
                            make_plan)
from scheduler.store import Lock, Store, StoreError, open_or_create, read_attrs
from scheduler.worker import DEFAULT_SOLVER, Warmup, run_task, solve_points
from study.dataset import bytes_per_point, code_fingerprint, stored_variables
from study.spec import Study

#: Grid points re-solved by the error estimate.
ERROR_SAMPLE = 8
#: The error estimate re-solves at rtol * ERROR_RTOL_FACTOR (not below the solver's floor).
ERROR_RTOL_FACTOR = 1e-3
RTOL_FLOOR = 1e-13


class RunError(Exception):
    """The run could not start (exit code 2): nothing was written."""


@dataclass
class RunOptions:
    store: Path
    cluster: ClusterSpec = field(default_factory=ClusterSpec)
    overwrite: bool = False
    solver: str = DEFAULT_SOLVER
    task_seconds: float = DEFAULT_TASK_SECONDS
    task_timeout: float = DEFAULT_TASK_TIMEOUT
    error_sample: int = ERROR_SAMPLE
    command: str = "hertzmap run"


def default_store_path(study: Study) -> Path:
    return Path("results") / f"{study.name}.zarr"


def _fmt_bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n} B"  # pragma: no cover


def _fmt_time(s: float) -> str:
    if not math.isfinite(s):
        return "?"
    s = int(round(s))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}h{m:02d}m{sec:02d}s" if h else (f"{m}m{sec:02d}s" if m else f"{sec}s")


def plan_for(study: Study, store_path: Path, task_seconds: float) -> tuple[Plan, str]:
    """The plan, reusing the chunk shape of an existing store of the same study.
    Reads only (used by --dry-run). Returns (plan, note about the store)."""
    attrs = read_attrs(store_path) if store_path.exists() else None
    if attrs is not None and attrs.get("hertzmap_study_hash") == study.hash:
        plan = make_plan(study, tuple(attrs["hertzmap_chunk_shape"]))
        try:
            done = int(Store(store_path).done_mask().sum())
        except (StoreError, KeyError):
            done = 0
        return plan, f"exists (same study): resume, {done}/{len(plan.tasks)} tasks done"
    plan = make_plan(study, choose_chunks(study, task_seconds))
    if attrs is not None:
        return plan, "exists (another study or not hertzmap): refused unless --overwrite"
    if store_path.exists():
        return plan, "path exists and is not a zarr store: refused"
    return plan, "new"


#: Bytes the client holds per task while a study runs (plan, spec, future, bookkeeping).
CLIENT_BYTES_PER_TASK = 8_000
#: Refuse when the store's estimate exceeds this fraction of the free disk space / inodes.
DISK_MARGIN = 0.95
#: Set to 1 to skip the disk-space check (e.g. the store compresses far below its
#: uncompressed estimate, or a file system that misreports its free space).
SKIP_SPACE_ENV = "HERTZMAP_SKIP_SPACE_CHECK"


def _existing_parent(path: Path) -> Path:
    p = Path(path).absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _available_memory() -> int | None:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def resource_estimate(study: Study, plan: Plan) -> dict[str, int]:
    """Bytes and files a run needs: the store (uncompressed), its chunk files, the client's
    memory, one block in a worker's memory."""
    bpp = bytes_per_point(study)
    n_tasks = len(plan.tasks)
    block_points = math.prod(plan.chunks)
    return {
        "store_bytes": study.size * bpp + n_tasks * 64,
        "store_files": n_tasks * (len(stored_variables(study)) + 1) + 64,
        "client_bytes": n_tasks * CLIENT_BYTES_PER_TASK + 4 * block_points * bpp
        + 64 * sum(study.shape),
        "block_bytes": 4 * block_points * bpp,
    }


def check_resources(study: Study, plan: Plan, store_path: Path, *, new_store: bool) -> dict[str, int]:
    """Refuse (RunError naming ``grid``) a study whose store cannot fit on the disk of
    ``store_path`` or whose bookkeeping cannot fit in this machine's memory. Reads only."""
    est = resource_estimate(study, plan)
    where = _existing_parent(store_path)
    shape = " x ".join(str(n) for n in study.shape)
    if new_store and os.environ.get(SKIP_SPACE_ENV, "") not in ("1", "true", "yes"):
        try:
            free = shutil.disk_usage(where).free
            vfs = os.statvfs(where)
            free_files = vfs.f_favail if vfs.f_files else None
        except OSError:
            free, free_files = None, None
        if free is not None and est["store_bytes"] > DISK_MARGIN * free:
            raise RunError(
                f"grid: {shape} points x {study.max_solutions} slots need a store of about "
                f"{_fmt_bytes(est['store_bytes'])} (uncompressed), more than the "
                f"{_fmt_bytes(free)} free at {where}; split the study, use fewer "
                f"solution slots or products, or --store on a larger disk "
                f"({SKIP_SPACE_ENV}=1 to skip this check)")
        if free_files is not None and est["store_files"] > DISK_MARGIN * free_files:
            raise RunError(
                f"grid: the store needs about {est['store_files']} files (one per chunk and "
                f"variable), more than the {free_files} free inodes at {where}; raise "
                f"--task-seconds (fewer, larger chunks) or split the study")
    mem = _available_memory()
    if mem is not None and est["client_bytes"] > mem:
        raise RunError(
            f"grid: {shape} points in {len(plan.tasks)} tasks need about "
            f"{_fmt_bytes(est['client_bytes'])} of memory in the client, more than the "
            f"{_fmt_bytes(mem)} available; raise --task-seconds or split the study")
    return est


def describe(study: Study, opts: RunOptions) -> str:
    """The --dry-run report. Raises RunError when the study cannot fit (disk, memory)."""
    plan, note = plan_for(study, opts.store, opts.task_seconds)
    check_resources(study, plan, opts.store, new_store=not note.startswith("exists (same"))
    n_o, n_s, n_z = study.shape
    size = study.size * bytes_per_point(study)
    est = plan.estimated_seconds()
    workers = opts.cluster.workers if opts.cluster.kind == "local" else None
    per_worker = f", about {_fmt_time(est / (workers or 1))} on {workers} workers" if workers else ""
    lines = [
        f"study        {study.name} (hash {study.hash[:12]})",
        f"grid         {n_o} omega x {n_s} sigma x {n_z} zeta = {study.size} points, "
        f"{study.max_solutions} solution slots, periods {list(study.periods)}",
        f"model        {study.model}" + (f" exponent {study.exponent}" if study.exponent else "")
        + f", rtol {study.rtol:g}",
        f"products     {', '.join(study.products)} -> {', '.join(stored_variables(study))}",
        f"tasks        {len(plan.tasks)} (chunk {plan.chunks[0]} omega x {plan.chunks[1]} sigma x "
        f"{plan.chunks[2]} zeta; about {_fmt_time(est / max(1, len(plan.tasks)))} each)",
        f"compute      about {_fmt_time(est)} of one core{per_worker} (estimate)",
        f"store        {opts.store} ({note}); about {_fmt_bytes(size)} uncompressed",
        f"runs on      {opts.cluster.describe()}",
    ]
    return "\n".join(lines)


# -- deterministic sample of converged slots (for the error estimate) -----------------------

def _mix64(x: np.ndarray) -> np.ndarray:
    """splitmix64 finaliser: a fixed pseudo-random key per integer."""
    x = x.astype(np.uint64)
    with np.errstate(over="ignore"):
        x ^= x >> np.uint64(30)
        x *= np.uint64(0xBF58476D1CE4E5B9)
        x ^= x >> np.uint64(27)
        x *= np.uint64(0x94D049BB133111EB)
        x ^= x >> np.uint64(31)
    return x


class Sampler:
    """Keeps the ``n`` converged slots with the smallest pseudo-random keys: the sample does
    not depend on the order in which blocks finish."""

    def __init__(self, study: Study, n: int):
        self.study = study
        self.n = n
        self.seed = np.uint64(int(hashlib.sha256(study.hash.encode()).hexdigest()[:15], 16))
        self.items: list[tuple[int, tuple]] = []

    def add(self, task: Task, arrays: dict[str, np.ndarray]) -> None:
        if self.n <= 0:
            return
        st = arrays["status"]
        idx = np.argwhere(st == 0)
        if idx.size == 0:
            return
        o0, s0, z0 = (s.start for s in task.slices)
        n_o, n_s, n_z = self.study.shape
        ns = self.study.max_solutions
        flat = ((((idx[:, 0] + o0) * n_s + idx[:, 1] + s0) * n_z + idx[:, 2] + z0) * ns + idx[:, 3])
        keys = _mix64(flat.astype(np.uint64) ^ self.seed)
        order = np.argsort(keys)[: self.n]
        om, sg, zt = self.study.axis("omega"), self.study.axis("sigma"), self.study.axis("zeta")
        for r in order:
            i, j, k, s = idx[r]
            self.items.append((int(keys[r]), (
                float(om[i + o0]), float(sg[j + s0]), float(zt[k + z0]), int(arrays["period"][i, j, k, s]),
                float(arrays["q0"][i, j, k, s]), float(arrays["v0"][i, j, k, s]))))
        self.items.sort(key=lambda t: t[0])
        del self.items[self.n:]

    @property
    def samples(self) -> list[tuple]:
        return [v for _, v in self.items]


def estimate_error(client, study: Study, samples: list[tuple], *, solver: str = DEFAULT_SOLVER,
                   rtol_factor: float = ERROR_RTOL_FACTOR) -> dict[str, Any]:
    """Re-solve sampled converged points at a tighter tolerance; report the deviation of (q0, v0).

    ``samples``: (omega, sigma, zeta, period, q0, v0) of converged slots. Each point is solved
    alone at rtol * rtol_factor (not below 1e-13), with the sampled orbit's own start point as
    one more seed (for solvers that take ``seeds``): Newton from 1e-10 away finds that orbit
    again, where the point's automatic seeds alone missed the orbits that only continuation
    reaches (5 of 8 samples matched on the default study, 2-3 of 8 on the fine map). Each
    sampled slot is matched with the nearest converged re-solved slot of the same period; one
    without a match within 1e-3 is counted as unmatched, not as an error.
    """
    rtol_ref = max(study.rtol * rtol_factor, RTOL_FLOOR)
    out: dict[str, Any] = {"n": len(samples), "rtol": study.rtol, "rtol_ref": rtol_ref,
                           "matched": 0, "max_deviation": math.nan}
    if not samples:
        return out
    kwargs = study.solver_kwargs()
    kwargs["rtol"] = rtol_ref
    points = [s[:3] for s in samples]
    seeds = [[(int(p), float(q0), float(v0))] for (_, _, _, p, q0, v0) in samples]
    fut = client.submit(solve_points, points, kwargs, solver, seeds, pure=False)
    refs = fut.result()
    devs = []
    for (w, s, z, p, q0, v0), ref in zip(samples, refs):
        ok = (ref["status"] == 0) & (ref["period"] == p)
        if not ok.any():
            continue
        d = np.maximum(np.abs(ref["q0"][ok] - q0), np.abs(ref["v0"][ok] - v0)).min()
        if d <= 1e-3:
            devs.append(float(d))
    out["matched"] = len(devs)
    if devs:
        out["max_deviation"] = max(devs)
    out["ref_equals_run"] = rtol_ref >= study.rtol
    return out


def record_error_estimate(store: Store, summary: dict[str, Any]) -> None:
    """The error estimate and the wall time of this run into the store's attrs
    (``hertzmap_error_estimate``, JSON; NaN as null), then the history line."""
    import json
    e = dict(summary.get("error") or {})
    e["wall_seconds"] = summary.get("wall")
    e = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in e.items()}
    try:
        store.set_attrs(hertzmap_error_estimate=json.dumps(e))
        dev = e.get("max_deviation")
        store.add_history(f"error estimate: max |d(q0, v0)| = "
                          f"{'n/a' if dev is None else format(dev, '.2e')} over {e.get('matched', 0)}/"
                          f"{e.get('n', 0)} orbits at rtol {e.get('rtol_ref')}; wall {e['wall_seconds']:.2f} s")
    except Exception as exc:  # a report, never a reason to fail the run
        summary.setdefault("error", {})["store_failed"] = f"{type(exc).__name__}: {exc}"


# -- progress -------------------------------------------------------------------------------

class Progress:
    def __init__(self, stream: TextIO, total_tasks: int, total_points: int, done_tasks: int):
        self.stream = stream
        self.tty = hasattr(stream, "isatty") and stream.isatty()
        self.total_tasks = total_tasks
        self.total_points = total_points
        self.done_tasks = done_tasks
        self.points = 0
        self.t0 = time.perf_counter()
        self.last = 0.0

    def update(self, points: int, force: bool = False) -> None:
        self.done_tasks += 1
        self.points += points
        now = time.perf_counter()
        if not force and now - self.last < (0.5 if self.tty else 10.0):
            return
        self.last = now
        elapsed = now - self.t0
        rate = self.points / elapsed if elapsed > 0 else 0.0
        eta = (self.total_points - self.points) / rate if rate > 0 else math.inf
        line = (f"hertzmap: {self.done_tasks}/{self.total_tasks} tasks  {rate:,.0f} points/s  "
                f"ETA {_fmt_time(eta)}")
        if self.tty:
            self.stream.write("\r" + line.ljust(72))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


# -- the run --------------------------------------------------------------------------------

def check_solver(solver: str) -> None:
    module = solver.partition(":")[0]
    try:
        found = importlib.util.find_spec(module) is not None
    except ModuleNotFoundError:
        found = False
    if not found:
        raise RunError(f"block solver module {module!r} not found (study/block.py missing?)")


def run_study(study: Study, opts: RunOptions, *, out: TextIO | None = None,
              err: TextIO | None = None, client=None) -> dict[str, Any]:
    """Run (or resume) ``study`` into ``opts.store``. Returns the summary.

    ``client``: an existing distributed.Client to use (its cluster is not closed);
    otherwise one is made from ``opts.cluster``. Raises RunError / StoreError before
    anything is written when the run cannot start.
    """
    out = sys.stdout if out is None else out
    err = sys.stderr if err is None else err
    check_solver(opts.solver)
    opts.cluster.check()
    plan, note = plan_for(study, opts.store, opts.task_seconds)
    check_resources(study, plan, opts.store,
                    new_store=opts.overwrite or not note.startswith("exists (same"))
    chunks = choose_chunks(study, opts.task_seconds)
    early = None
    if client is None and opts.cluster.kind != "local" and not _store_complete(
            study, opts.store, len(plan.tasks), note):
        # connect (an existing scheduler) or have the first worker jobs accepted (a batch
        # system) before anything is written: a refused option changes nothing
        early = make_client(opts.cluster, report=_printer(out))
    try:
        store, resumed = open_or_create(opts.store, study, chunks, overwrite=opts.overwrite,
                                        action=f"{opts.command}: created")
        with Lock(store.path):
            return _run_locked(study, opts, store, resumed, out, err, client, early)
    except BaseException:
        if early is not None:
            _close(*early)
        raise


def _printer(stream: TextIO):
    def report(line: str) -> None:
        print(line, file=stream, flush=True)
    return report


def _close(client, cluster) -> None:
    """Close the client, then the cluster (a batch cluster cancels its jobs)."""
    with contextlib.suppress(Exception):
        client.close()
    if cluster is not None:
        with contextlib.suppress(Exception):
            cluster.close()


def _store_complete(study: Study, store_path: Path, n_tasks: int, note: str) -> bool:
    """True for a store of this study with every task flagged done (nothing to compute, so
    no cluster is started)."""
    if not note.startswith("exists (same"):
        return False
    try:
        return int(Store(store_path).done_mask().sum()) == n_tasks
    except (StoreError, KeyError, OSError):
        return False


class _DeferInterrupt:
    """SIGINT (Ctrl-C) raises KeyboardInterrupt at once, except inside :meth:`critical`
    (a block write and its flag, a history line), where it is deferred to the section's end.
    Only in the main thread (signal handlers cannot be set elsewhere)."""

    def __init__(self):
        self.pending = False
        self.inside = False
        self.old = None

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self.old = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc):
        if self.old is not None:
            signal.signal(signal.SIGINT, self.old)
            self.old = None

    def _handler(self, signum, frame):
        if self.inside:
            self.pending = True
        else:
            raise KeyboardInterrupt

    @contextlib.contextmanager
    def critical(self):
        self.inside = True
        try:
            yield
        finally:
            self.inside = False
        if self.pending:
            self.pending = False
            raise KeyboardInterrupt


def _scheduler_lost(client, exc: BaseException | None = None) -> bool:
    """True when the client lost its scheduler (futures cancelled for that reason)."""
    if exc is not None and "connection-lost" in str(getattr(exc, "reason", "") or exc):
        return True
    try:
        return client.status not in ("running", "newly-created")
    except Exception:
        return True


def _run_locked(study, opts, store: Store, resumed: bool, out, err, client,
                early=None) -> dict[str, Any]:
    plan = make_plan(study, store.chunks)
    names = stored_variables(study)
    done = store.done_mask()
    if resumed:
        # a damaged store is repaired, never silently mixed: tasks flagged done whose
        # chunks are missing or unreadable (or whose flag is unreadable) are recomputed
        damaged = store.verify([t for t in plan.tasks if done[t.index]], names)
        for idx in store.unreadable_flags():
            damaged.setdefault(idx, []).append("task_done: flag unreadable")
        if damaged:
            for idx in damaged:
                store.unmark(idx)
            done = store.done_mask()
            first = "; ".join(f"task {i}: {', '.join(p)}" for i, p in list(damaged.items())[:3])
            print(f"warning: {store.path}: {len(damaged)} task(s) flagged done have damaged "
                  f"chunks ({first}{' ...' if len(damaged) > 3 else ''}); they are recomputed",
                  file=err)
            store.add_history(f"{opts.command}: {len(damaged)} damaged task(s) re-queued: "
                              + ", ".join("-".join(map(str, i)) for i in damaged))
    todo = [t for t in plan.tasks if not done[t.index]]
    n_done0 = len(plan.tasks) - len(todo)
    if resumed:
        note = ""
        code = code_fingerprint()
        if todo and n_done0 and store.attrs.get("hertzmap_code_hash") not in (None, code):
            note = (f" (solver code changed: {str(store.attrs.get('hertzmap_code_hash'))[:12]} -> "
                    f"{code[:12]})")
            print(f"warning: the solver code (kernels/, study/) changed since {store.path} was "
                  "created: blocks computed now may differ from the earlier ones; use "
                  "--overwrite for a store computed by one version", file=err)
        store.add_history(f"{opts.command}: resumed with {n_done0}/{len(plan.tasks)} tasks done{note}")
        print(f"resuming {store.path}: {n_done0}/{len(plan.tasks)} tasks already done", file=out)
    summary: dict[str, Any] = {"store": str(store.path), "tasks_total": len(plan.tasks),
                               "tasks_done_before": n_done0, "tasks_run": 0, "failed": []}
    if not todo:
        print(f"{store.path}: all {len(plan.tasks)} tasks done, nothing to compute", file=out)
        summary.update(complete=True, wall=0.0)
        return summary

    own_client = client is None
    cluster = None
    t_setup = time.perf_counter()
    if own_client:
        client, cluster = early if early is not None else make_client(opts.cluster,
                                                                       report=_printer(out))
    interrupt = _DeferInterrupt()
    futures = []
    try:
        return _compute(study, opts, store, plan, names, todo, n_done0, summary, client,
                        cluster, own_client, t_setup, out, err, interrupt, futures)
    except KeyboardInterrupt:
        with contextlib.suppress(Exception):
            client.cancel(futures)
        n = int(store.done_mask().sum())
        with contextlib.suppress(Exception):
            store.add_history(f"{opts.command}: interrupted with {n}/{len(plan.tasks)} tasks done")
        print(f"\nhertzmap: interrupted: {n}/{len(plan.tasks)} tasks are done and kept in "
              f"{store.path}; rerun the same command ({opts.command}) to resume", file=err,
              flush=True)
        raise
    finally:
        interrupt.__exit__()
        if own_client:
            _close(client, cluster)


def _compute(study, opts, store, plan, names, todo, n_done0, summary, client, cluster,
             own_client, t_setup, out, err, interrupt, futures) -> dict[str, Any]:
    interrupt.__enter__()
    if True:
        if opts.cluster.kind != "local" and own_client:
            print(f"waiting for workers ({opts.cluster.describe()}) ...", file=out, flush=True)
        if cluster is not None and opts.cluster.kind in JOBQUEUE:
            try:
                wait_for_first_worker(client, cluster, opts.cluster, _printer(out))
            except WorkerJobsEnded as exc:
                msg = f"{exc}; fix that and rerun: the store ({store.path}) resumes"
                with interrupt.critical():
                    store.add_history(f"{opts.command}: stopped, no worker job started")
                print(f"hertzmap: error: {msg}", file=err, flush=True)
                summary.update(complete=False, failed=[("worker jobs", msg)])
                return summary
        else:
            # an existing scheduler with --workers N: wait for N workers before starting
            client.wait_for_workers(opts.cluster.workers if opts.cluster.kind == "address"
                                    and opts.cluster.workers else 1)
        kwargs = study.solver_kwargs()
        client.register_plugin(Warmup(opts.solver, kwargs), name="hertzmap-warmup")
        n_workers = worker_count(client)
        setup = time.perf_counter() - t_setup
        dash = client.dashboard_link if _has_dashboard(client) else "unavailable (pip install bokeh)"
        print(f"running {len(todo)} tasks ({sum(t.size for t in todo)} points) on {n_workers} "
              f"workers; setup {setup:.1f} s; dashboard: {dash}", file=out, flush=True)

        specs = []
        om, sg, zt = study.axis("omega"), study.axis("sigma"), study.axis("zeta")
        for t in todo:
            so, ss, sz = t.slices
            specs.append({"index": t.index, "omega": om[so], "sigma": sg[ss], "zeta": zt[sz],
                          "kwargs": kwargs, "names": names, "solver": opts.solver,
                          "time_budget": opts.task_timeout})
        by_index = {t.index: t for t in todo}
        keys = [t.key(study.hash) for t in todo]

        from distributed import as_completed

        progress = Progress(err, len(plan.tasks), sum(t.size for t in todo), n_done0)
        sampler = Sampler(study, opts.error_sample)
        compute = 0.0
        per_pid: dict[int, float] = {}
        n_cut = 0
        n_conv = n_fail = n_points_with = n_points_run = 0
        t0 = time.perf_counter()
        futures.extend(client.map(run_task, specs, key=keys, pure=False))
        lost = None
        for fut in as_completed(futures):
            try:
                res = fut.result()
            except Exception as exc:  # a task failed for good (after Dask's retries)
                if _scheduler_lost(client, exc):
                    lost = exc
                    break
                summary["failed"].append((fut.key, f"{type(exc).__name__}: {exc}"))
                fut.release()
                continue
            task = by_index[tuple(res["index"])]
            arrays = res["arrays"]
            with interrupt.critical():
                store.write_block(task.slices, arrays, names)   # 1. the block ...
                store.mark_done(task.index)                     # 2. ... then its flag
            fut.release()
            compute += res["seconds"]
            per_pid[res["pid"]] = per_pid.get(res["pid"], 0.0) + res["seconds"]
            st = arrays["status"]
            n_conv += int((st == 0).sum())
            n_fail += int(((st > 0) & (st != TIME_LIMIT)).sum())
            n_cut += int((st == TIME_LIMIT).sum())
            n_points_with += int((st == 0).any(axis=-1).sum())
            sampler.add(task, arrays)
            summary["tasks_run"] += 1
            n_points_run += task.size
            progress.update(task.size)
        wall = time.perf_counter() - t0
        progress.close()

        if lost is not None or (len(summary["failed"]) and _scheduler_lost(client)):
            n = int(store.done_mask().sum())
            msg = (f"lost the Dask scheduler ({opts.cluster.describe()}) after {n}/"
                   f"{len(plan.tasks)} tasks: they are kept in {store.path}; restart the "
                   f"scheduler and rerun the same command ({opts.command}) to resume")
            with interrupt.critical():
                store.add_history(f"{opts.command}: scheduler lost with {n}/{len(plan.tasks)} tasks done")
            print(f"hertzmap: {msg}", file=err, flush=True)
            summary.update(complete=False, scheduler_lost=True,
                           failed=[("scheduler", msg)], tasks_done=n)
            return summary
        n_run = summary["tasks_run"]
        overhead = 1.0 - compute / (n_workers * wall) if wall > 0 else math.nan
        summary.update(
            wall=wall, setup=setup, workers=n_workers, compute=compute,
            overhead=overhead, per_task=compute / max(1, n_run),
            points=n_points_run, points_per_second=n_points_run / wall if wall > 0 else math.nan,
            orbits=n_conv, failed_slots=n_fail, points_with_orbit=n_points_with,
            time_limited=n_cut,
            converged_fraction=n_conv / (n_conv + n_fail) if n_conv + n_fail else math.nan,
            orbits_per_second=n_conv / wall if wall > 0 else math.nan,
            worker_processes_seen=len(per_pid),
        )
        with interrupt.critical():
            if summary["failed"]:
                summary["complete"] = False
                store.add_history(f"{opts.command}: stopped, {len(summary['failed'])} tasks failed")
            else:
                summary["complete"] = bool(store.done_mask().all())
                store.add_history(f"{opts.command}: completed {len(plan.tasks)}/{len(plan.tasks)} tasks")
        try:
            summary["error"] = estimate_error(client, study, sampler.samples, solver=opts.solver)
        except Exception as exc:  # the estimate is a report, never a reason to fail the run
            summary["error"] = {"n": 0, "failed": f"{type(exc).__name__}: {exc}"}
        record_error_estimate(store, summary)
        print_summary(summary, out)
        return summary


def _has_dashboard(client) -> bool:
    try:
        return importlib.util.find_spec("bokeh") is not None and bool(client.dashboard_link)
    except Exception:
        return False


def print_summary(s: dict[str, Any], out: TextIO) -> None:
    lines = [
        f"done: {s['tasks_run']} tasks, {s['points']} points in {s['wall']:.2f} s wall on "
        f"{s['workers']} workers ({s['points_per_second']:,.0f} points/s; setup {s['setup']:.1f} s)",
        f"orbits: {s['orbits']} converged ({s['orbits_per_second']:,.0f} orbits/s), "
        f"{s['failed_slots']} failed slots, converged fraction {s['converged_fraction']:.4f}, "
        f"{s['points_with_orbit']} points with at least one orbit",
        f"dask overhead: {100 * s['overhead']:.1f} % (task compute {s['compute']:.2f} s over "
        f"{s['workers']} workers x {s['wall']:.2f} s wall; {1000 * s['per_task']:.0f} ms per task)",
    ]
    if s.get("time_limited"):
        lines.append(f"time limit: {s['time_limited']} grid points not solved within "
                     f"--task-timeout (status time_limit); rerun with --overwrite and a larger "
                     f"--task-timeout to compute them")
    e = s.get("error") or {}
    if e.get("failed"):
        lines.append(f"error estimate: failed ({e['failed']})")
    elif e.get("n"):
        lines.append(f"error estimate: max |d(q0, v0)| = {e['max_deviation']:.2e} over "
                     f"{e['matched']}/{e['n']} sampled orbits re-solved at rtol {e['rtol_ref']:g}"
                     f" (wall {s['wall']:.2f} s; in the store's attrs: hertzmap_error_estimate)"
                     + (" (reference rtol not tighter than the run's)" if e.get("ref_equals_run") else ""))
    lines.append(f"store: {s['store']} ({s['tasks_done_before'] + s['tasks_run']}/{s['tasks_total']} tasks done)")
    if s["failed"]:
        lines.append(f"FAILED tasks: {len(s['failed'])} (rerun the same command to retry them)")
        for key, msg in s["failed"][:5]:
            lines.append(f"  {key}: {msg}")
    out.write("\n".join(lines) + "\n")
    out.flush()
