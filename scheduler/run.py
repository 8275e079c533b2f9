"""Run a study: plan, open/create the store, ship blocks to Dask, flag them as they come.

Each task's worker writes its own block into the store (scheduler.store.write_task_block: a
region write of whole chunks that no other task shares) and returns a summary of a few
hundred bytes; the client, which holds the store's lock, sets the task's ``task_done`` flag
once the task has returned (``distributed.as_completed``). Durability comes from the store,
not from Dask: rerunning the same command computes only the tasks not flagged.
"""

from __future__ import annotations

import contextlib
import importlib.util
import math
import sys
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from hertzmap.scheduler.cluster import (INPROCESS, JOBQUEUE, LOCAL_KINDS, ClusterSpec,
                                        WorkerJobsEnded, close_quietly, make_client,
                                        wait_for_first_worker, where_line, worker_count)
from hertzmap.scheduler.atlas_tasks import DEFAULT_ATLAS_TILE, AtlasRun
from hertzmap.scheduler.curve_tasks import DEFAULT_TRACER, CurveRun
from hertzmap.scheduler.dry_run import plan_for
from hertzmap.scheduler.defaults import DEFAULT_TASK_SECONDS, DEFAULT_TASK_TIMEOUT, ERROR_SAMPLE
from hertzmap.scheduler.error_estimate import estimate_error, record_error_estimate
from hertzmap.scheduler.sample import Sampler
from hertzmap.scheduler.errors import RunError
from hertzmap.scheduler.interrupt import DeferInterrupt
from hertzmap.scheduler.plan import choose_chunks, make_plan
from hertzmap.scheduler.progress import Progress
from hertzmap.scheduler.report import (KIND_COUNTS, SUMMED_COUNTS, WORST_COUNTS, add_counts,
                                       overhead, print_summary)
from hertzmap.scheduler.resources import check_resources
from hertzmap.scheduler.store import (GRID_STAGE, Lock, Store, StoreError, check_writer,
                                      commit_grid_block, open_or_create, remove_stage)
from hertzmap.scheduler.worker import DEFAULT_SOLVER, Warmup, run_task
from hertzmap.study.schema import code_fingerprint, stored_variables
from hertzmap.study.spec import Study


@dataclass
class RunOptions:
    store: Path
    cluster: ClusterSpec = field(default_factory=ClusterSpec)
    overwrite: bool = False
    solver: str = DEFAULT_SOLVER
    task_seconds: float = DEFAULT_TASK_SECONDS
    task_timeout: float = DEFAULT_TASK_TIMEOUT
    error_sample: int = ERROR_SAMPLE
    #: the command as the user ran it: resume hints tell them to run exactly this again
    command: str = "hertzmap run"
    #: what traces a curve (the "curves" output), module:function
    curve_tracer: str = DEFAULT_TRACER
    #: what computes one tile of an atlas round, module:function
    atlas_tile: str = DEFAULT_ATLAS_TILE
    #: False: the grid (and curves) without the atlas, a benchmark's baseline
    atlas: bool = True


def default_store_path(study: Study) -> Path:
    return Path("results") / f"{study.name}.zarr"


def check_solver(solver: str) -> None:
    module = solver.partition(":")[0]
    try:
        found = importlib.util.find_spec(module) is not None
    except ModuleNotFoundError:
        found = False
    if not found:
        raise RunError(f"block solver module {module!r} not found")


def run_study(study: Study, opts: RunOptions, *, out: TextIO | None = None,
              err: TextIO | None = None, client=None) -> dict[str, Any]:
    """Run (or resume) ``study`` into ``opts.store``. Returns the summary.

    ``client``: an existing distributed.Client to use (its cluster is not closed);
    otherwise one is made from ``opts.cluster``. Raises RunError / StoreError / ClusterError
    before anything is written when the run cannot start. An interrupt (Ctrl-C) is reported
    once, with the command that resumes it, and re-raised with ``reported = True``.
    """
    out = sys.stdout if out is None else out
    err = sys.stderr if err is None else err
    check_solver(opts.solver)
    opts.cluster.check()
    plan, note = plan_for(study, opts.store, opts.task_seconds)
    check_resources(study, plan, opts.store,
                    new_store=opts.overwrite or not note.startswith("exists (same"))
    chunks = choose_chunks(study, opts.task_seconds)
    early = warming = t_setup = None
    if client is None and not _store_complete(study, opts.store, len(plan.tasks), note):
        # connect (an existing scheduler) or have the first worker jobs accepted (a batch
        # system) before anything is written: an unreachable scheduler or a refused option
        # changes nothing. The embedded cluster starts here too, and its workers compile the
        # kernels while this process creates the store (1-1.5 s of the client's on the
        # default study, otherwise spent before the workers start)
        t_setup = time.perf_counter()
        early = make_client(opts.cluster, report=_printer(out))
        if opts.cluster.kind == "local":
            warming = start_warm_up(early[0], study, opts)
    try:
        store, resumed = open_or_create(opts.store, study, chunks, overwrite=opts.overwrite,
                                        action=f"{opts.command}: created")
        with Lock(store.path) as lock:
            return StudyRun(study, opts, store, out, err, warming, lock.owner).run(
                resumed, client, early, t_setup)
    except BaseException:
        if early is not None:
            close_quietly(*early)
        raise


def warm_up_plugin(study: Study, opts: RunOptions) -> Warmup:
    """The worker plugin that compiles (or loads) the study's kernels on every worker."""
    return Warmup(opts.solver, study.solver_kwargs(), curves="curves" in study.outputs)


def start_warm_up(client, study: Study, opts: RunOptions) -> Future:
    """Register the warm-up plugin from a thread: the returned future is done when every
    current worker has run it (its exception, if any, is raised by ``result()``)."""
    pool = ThreadPoolExecutor(1, thread_name_prefix="hertzmap-warmup")
    try:
        return pool.submit(client.register_plugin, warm_up_plugin(study, opts),
                           name="hertzmap-warmup")
    finally:
        pool.shutdown(wait=False)


def _printer(stream: TextIO):
    def report(line: str) -> None:
        print(line, file=stream, flush=True)
    return report


def _store_complete(study: Study, store_path: Path, n_tasks: int, note: str) -> bool:
    """True for a store of this study with every task flagged done (nothing to compute, so
    no cluster is started)."""
    if not note.startswith("exists (same"):
        return False
    try:
        return int(Store(store_path).done_mask().sum()) == n_tasks
    except (StoreError, KeyError, OSError):
        return False


def _scheduler_lost(client, exc: BaseException | None = None) -> bool:
    """True when the client lost its scheduler (futures cancelled for that reason)."""
    if exc is not None and "connection-lost" in str(getattr(exc, "reason", "") or exc):
        return True
    try:
        return client.status not in ("running", "newly-created")
    except Exception:
        return True


def _has_dashboard(client) -> bool:
    try:
        return importlib.util.find_spec("bokeh") is not None and bool(client.dashboard_link)
    except Exception:
        return False


def task_specs(study: Study, tasks, kwargs: dict[str, Any], names, solver, time_budget, *,
               store: Path, owner: dict[str, Any], sampler: Sampler) -> list[dict[str, Any]]:
    """What the client hands to Dask for each task (scheduler.worker.run_task's argument):
    the block's place and axes, the solver's options, the variables to store, where to write
    them (the store's absolute path: workers may run elsewhere) and as whose (``owner``, the
    client's lock record), and what the error sample needs of the block."""
    om, sg, zt = study.axis("omega"), study.axis("sigma"), study.axis("zeta")
    where = str(Path(store).resolve())
    specs = []
    for t in tasks:
        so, ss, sz = t.slices
        specs.append({"index": t.index, "slices": [(s.start, s.stop) for s in t.slices],
                      "omega": om[so], "sigma": sg[ss], "zeta": zt[sz],
                      "kwargs": kwargs, "names": names, "solver": solver,
                      "time_budget": time_budget, "store": where, "owner": owner,
                      "sample": sampler.task_spec(t)})
    return specs


class StudyRun:
    """One run of a study into its (locked) store: repair, resume, compute, summarise."""

    def __init__(self, study: Study, opts: RunOptions, store: Store, out: TextIO, err: TextIO,
                 warming: Future | None = None, owner: dict[str, Any] | None = None):
        self.study = study
        self.opts = opts
        self.store = store
        self.out = out
        self.err = err
        self.plan = make_plan(study, store.chunks)
        self.names = stored_variables(study)
        self.interrupt = DeferInterrupt()
        self.futures: list = []
        #: the store's lock record of this client: its tasks' workers write only while it holds
        self.owner = owner
        #: the warm-up plugin's registration, started with the embedded cluster (start_warm_up)
        self.warming = warming
        self.summary: dict[str, Any] = {"store": str(store.path), "tasks_total": len(self.plan.tasks),
                                        "tasks_done_before": 0, "tasks_run": 0, "failed": []}
        # the atlas, after the grid and before the curves
        self.atlas = AtlasRun(study, store, out, err, self.interrupt, opts.command,
                              enabled=opts.solver == DEFAULT_SOLVER and opts.atlas,
                              tile=opts.atlas_tile, owner=owner)
        # the traced curves of a study with the "curves" output, after its grid
        self.curves = CurveRun(study, store, out, err, self.interrupt, opts.command,
                               opts.curve_tracer)

    # -- before computing -----------------------------------------------------------------
    def repair(self) -> None:
        """Tasks flagged done whose chunks are missing or unreadable (or whose flag is
        unreadable) are unflagged and recomputed: a damaged store is repaired, never mixed."""
        done = self.store.done_mask()
        damaged = self.store.verify([t for t in self.plan.tasks if done[t.index]], self.names)
        for idx in self.store.unreadable_flags():
            damaged.setdefault(idx, []).append("task_done: flag unreadable")
        if not damaged:
            return
        for idx in damaged:
            self.store.unmark(idx)
        first = "; ".join(f"task {i}: {', '.join(p)}" for i, p in list(damaged.items())[:3])
        print(f"warning: {self.store.path}: {len(damaged)} task(s) flagged done have damaged "
              f"chunks ({first}{' ...' if len(damaged) > 3 else ''}); they are recomputed",
              file=self.err)
        self.store.add_history(f"{self.opts.command}: {len(damaged)} damaged task(s) re-queued: "
                               + ", ".join("-".join(map(str, i)) for i in damaged))

    def note_resume(self, n_done: int, todo: list) -> None:
        note = ""
        code = code_fingerprint()
        recorded = self.store.attrs.get("hertzmap_code_hash")
        if todo and n_done and recorded not in (None, code):
            note = f" (solver code changed: {str(recorded)[:12]} -> {code[:12]})"
            print(f"warning: the solver code (kernels/, study/) changed since {self.store.path} "
                  "was created: blocks computed now may differ from the earlier ones; use "
                  "--overwrite for a store computed by one version", file=self.err)
        total = len(self.plan.tasks)
        self.store.add_history(f"{self.opts.command}: resumed with {n_done}/{total} tasks done{note}")
        print(f"resuming {self.store.path}: {n_done}/{total} tasks already done", file=self.out)

    # -- the run --------------------------------------------------------------------------
    def run(self, resumed: bool, client=None, early=None,
            t_setup: float | None = None) -> dict[str, Any]:
        """``early``: (client, cluster) made before the store was opened, used instead of
        making them; ``t_setup``: when the setup began (the cluster's start), else now."""
        if resumed:
            # a resize cut short by a kill made whole (every slot array as long as the longest)
            self.store.settle_slots(self.store.slot_extents())
            self.repair()
        done = self.store.done_mask()
        todo = [t for t in self.plan.tasks if not done[t.index]]
        n_done = len(self.plan.tasks) - len(todo)
        self.summary["tasks_done_before"] = n_done
        if resumed:
            self.note_resume(n_done, todo)
        if not todo:
            print(f"{self.store.path}: all {len(self.plan.tasks)} tasks done, nothing to compute",
                  file=self.out)
            self.summary.update(complete=True, wall=0.0)
            if self.atlas.pending() or self.curves.pending():
                return self.stages_only(client, early)
            self.settle_slots()
            if early is not None:
                close_quietly(*early)
            return self.summary
        own_client = client is None
        cluster = None
        if t_setup is None:
            t_setup = time.perf_counter()
        if own_client:
            client, cluster = early if early is not None else make_client(
                self.opts.cluster, report=_printer(self.out))
        try:
            with self.interrupt:
                return self.compute(client, cluster, todo, n_done, t_setup, own_client)
        except KeyboardInterrupt as exc:
            self.report_interrupt(client)
            exc.reported = True
            raise
        finally:
            if own_client:
                close_quietly(client, cluster)

    def report_interrupt(self, client) -> None:
        with contextlib.suppress(Exception):
            client.cancel(self.futures)
        n = int(self.store.done_mask().sum())
        total = len(self.plan.tasks)
        with contextlib.suppress(Exception):
            self.store.add_history(f"{self.opts.command}: interrupted with {n}/{total} tasks done")
        print(f"\nhertzmap: interrupted: {n}/{total} tasks are done and kept in "
              f"{self.store.path}; to resume, run again: {self.opts.command}", file=self.err,
              flush=True)

    def task_specs(self, todo, kwargs, sampler: Sampler) -> list[dict[str, Any]]:
        return task_specs(self.study, todo, kwargs, self.names, self.opts.solver,
                          self.opts.task_timeout, store=self.store.path, owner=self.owner,
                          sampler=sampler)

    def workers_without_the_store(self, client) -> list[str]:
        """The connected workers that cannot write this client's store (scheduler.store.
        check_writer on each), with why: workers on other machines need it on a shared file
        system. A worker that joins later is checked by its first task."""
        replies = client.run(check_writer, str(self.store.path.resolve()), self.owner,
                             on_error="return")
        return [f"{w}: {r}" for w, r in sorted(replies.items()) if isinstance(r, Exception)]

    def compute(self, client, cluster, todo, n_done, t_setup, own_client) -> dict[str, Any]:
        from distributed import as_completed

        opts, store, summary = self.opts, self.store, self.summary
        if opts.cluster.kind not in LOCAL_KINDS and own_client:
            print(f"waiting for workers ({opts.cluster.describe()}) ...", file=self.out, flush=True)
        if cluster is not None and opts.cluster.kind in JOBQUEUE:
            try:
                wait_for_first_worker(client, cluster, opts.cluster, _printer(self.out))
            except WorkerJobsEnded as exc:
                msg = f"{exc}; fix that and rerun: the store ({store.path}) resumes"
                with self.interrupt.critical():
                    store.add_history(f"{opts.command}: stopped, no worker job started")
                print(f"hertzmap: error: {msg}", file=self.err, flush=True)
                summary.update(complete=False, failed=[("worker jobs", msg)])
                return summary
        else:
            # an existing scheduler with --workers N: wait for N workers before starting
            client.wait_for_workers(opts.cluster.workers if opts.cluster.kind == "address"
                                    and opts.cluster.workers else 1)
        kwargs = self.study.solver_kwargs()
        if self.warming is not None:
            self.warming.result()       # registered when the embedded cluster started
        elif opts.cluster.kind != INPROCESS:
            client.register_plugin(warm_up_plugin(self.study, opts), name="hertzmap-warmup")
        # (in-process, the one worker thread loads the kernels its first task calls: a warm-up
        # there would load every entry point, the census's and the curves' too, in this
        # process, and compete with the store's creation for its interpreter lock)
        if opts.cluster.kind not in LOCAL_KINDS:
            blind = self.workers_without_the_store(client)
            if blind:
                msg = (f"{len(blind)} worker(s) cannot write the store: {blind[0]}"
                       f"{' ...' if len(blind) > 1 else ''}; fix that and rerun: the store "
                       f"({store.path}) resumes")
                with self.interrupt.critical():
                    store.add_history(f"{opts.command}: stopped, workers cannot write the store")
                print(f"hertzmap: error: {msg}", file=self.err, flush=True)
                summary.update(complete=False, failed=[("shared file system", msg)])
                return summary
        n_workers = worker_count(client)
        setup = time.perf_counter() - t_setup
        summary["where"] = where_line(opts.cluster, n_workers)
        dash = (client.dashboard_link if _has_dashboard(client) else "unavailable (pip install bokeh)"
                ) if opts.cluster.kind != INPROCESS else "none (in-process)"
        print(f"running {len(todo)} tasks ({sum(t.size for t in todo)} points) "
              f"{summary['where']}; setup {setup:.1f} s; dashboard: {dash}", file=self.out, flush=True)

        by_index = {t.index: t for t in todo}
        keys = [t.key(self.study.hash) for t in todo]
        progress = Progress(self.err, len(self.plan.tasks), sum(t.size for t in todo), n_done)
        sampler = Sampler(self.study, opts.error_sample)
        tally = {"compute": 0.0, "write": 0.0, "points": 0, **{k: 0 for k in SUMMED_COUNTS},
                 **{k: math.nan for k in WORST_COUNTS}}
        pids: set[int] = set()
        t0 = time.perf_counter()
        self.futures.extend(client.map(run_task, self.task_specs(todo, kwargs, sampler), key=keys,
                                       pure=False))
        lost = None
        for fut in as_completed(self.futures):
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
            # the worker wrote the block before its task returned (or staged it, when it
            # holds more slots than the store's dims: written here, the dims grown): only now
            # its flag
            with self.interrupt.critical():
                if res.get("staged"):
                    commit_grid_block(store, task.slices, task.index, self.names)
                else:
                    store.note_slots_used(res["counts"].get("slots", {}))
                store.mark_done(task.index)
            fut.release()
            tally["compute"] += res["seconds"]
            tally["write"] += res["write_seconds"]
            pids.add(res["pid"])
            add_counts(tally, res["counts"])
            tally["points"] += task.size
            sampler.merge(res["samples"])
            summary["tasks_run"] += 1
            progress.update(task.size)
        wall = time.perf_counter() - t0
        progress.close()
        if store.done_mask().all():
            remove_stage(store.path, GRID_STAGE)

        if lost is not None or (len(summary["failed"]) and _scheduler_lost(client)):
            return self.scheduler_lost()
        n_run = summary["tasks_run"]
        n_conv, n_fail = tally["conv"], tally["fail"]
        summary.update(
            wall=wall, setup=setup, workers=n_workers, compute=tally["compute"],
            block_writes=tally["write"],
            overhead=overhead(tally["compute"], wall, n_workers, n_run),
            per_task=tally["compute"] / max(1, n_run),
            points=tally["points"],
            points_per_second=tally["points"] / wall if wall > 0 else math.nan,
            orbits=n_conv, failed_slots=n_fail, points_with_orbit=tally["with"],
            time_limited=tally["cut"],
            converged_fraction=n_conv / (n_conv + n_fail) if n_conv + n_fail else math.nan,
            orbits_per_second=n_conv / wall if wall > 0 else math.nan,
            worker_processes_seen=len(pids),
            liouville_worst=tally["liouville"], lyapunov_sum_worst=tally["lyapunov_sum"],
            attractors=tally["attractors"], stable=tally["stable"],
            slots=tally.get("slots", {}), attractor_kinds={k: tally[k] for k in KIND_COUNTS},
        )
        total = len(self.plan.tasks)
        with self.interrupt.critical():
            if summary["failed"]:
                summary["complete"] = False
                store.add_history(f"{opts.command}: stopped, {len(summary['failed'])} tasks failed")
            else:
                summary["complete"] = bool(store.done_mask().all())
                store.add_history(f"{opts.command}: completed {total}/{total} tasks")
        try:
            summary["error"] = estimate_error(client, self.study, sampler.samples,
                                              solver=opts.solver)
        except Exception as exc:  # the estimate is a report, never a reason to fail the run
            summary["error"] = {"n": 0, "failed": f"{type(exc).__name__}: {exc}"}
        record_error_estimate(store, summary)
        print_summary(summary, self.out)
        if summary["complete"]:
            self.after_grid(client, n_workers)
        return summary

    def after_grid(self, client, n_workers: int) -> None:
        """The stages that read the complete grid: the atlas, then the traced curves (whose
        seeds see the atlas's orbits)."""
        if self.atlas.pending():
            self.summary["atlas"] = self.atlas.run(client, n_workers)
            grid = self.summary.get("compute")
            if grid:
                print(f"atlas cost: {self.summary['atlas']['compute'] / grid:.0%} of the "
                      "grid's compute", file=self.out, flush=True)
        elif self.atlas.enabled and not self.atlas.applies():
            print("atlas: not run (it matches orbits by min_q, max_q and ptp: add the "
                  "\"measures\" output)", file=self.out, flush=True)
        if self.curves.pending():
            self.summary["curves"] = self.curves.run(client, n_workers)
        self.settle_slots()

    def settle_slots(self) -> None:
        """Once nothing is left to compute: the store's slot dims cut to the most any point
        holds (scheduler.store.Store.settle_slots; they grew by whole chunks during the run)."""
        if self.atlas.pending() or self.curves.pending() or not self.store.done_mask().all():
            return
        with self.interrupt.critical():
            self.store.settle_slots()

    # -- the stages after the grid ---------------------------------------------------------
    def stages_only(self, client, early) -> dict[str, Any]:
        """The grid is complete but its atlas or curves are not: run (or resume) them."""
        own_client = client is None
        cluster = None
        if own_client:
            client, cluster = early if early is not None else make_client(self.opts.cluster)
        try:
            with self.interrupt:
                client.wait_for_workers(1)
                self.after_grid(client, worker_count(client))
        except KeyboardInterrupt as exc:
            with contextlib.suppress(Exception):
                self.store.add_history(f"{self.opts.command}: interrupted after the grid")
            print(f"\nhertzmap: interrupted: the atlas rounds and curves committed so far are kept in "
                  f"{self.store.path}; to resume, run again: {self.opts.command}", file=self.err,
                  flush=True)
            exc.reported = True
            raise
        finally:
            if own_client:
                close_quietly(client, cluster)
        return self.summary

    def scheduler_lost(self) -> dict[str, Any]:
        n = int(self.store.done_mask().sum())
        total = len(self.plan.tasks)
        msg = (f"lost the Dask scheduler ({self.opts.cluster.describe()}) after {n}/{total} "
               f"tasks: they are kept in {self.store.path}; restart the scheduler and run "
               f"again to resume: {self.opts.command}")
        with self.interrupt.critical():
            self.store.add_history(f"{self.opts.command}: scheduler lost with {n}/{total} tasks done")
        print(f"hertzmap: {msg}", file=self.err, flush=True)
        self.summary.update(complete=False, scheduler_lost=True,
                            failed=[("scheduler", msg)], tasks_done=n)
        return self.summary
