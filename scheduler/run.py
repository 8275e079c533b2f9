"""Run a study: plan, open (or create) and lock the store, then run each pending stage of
:data:`STAGES` in order through one scheduler.stages.stage.TaskRunner: the grid (each block written by
its worker, flagged ``task_done`` by the client once the task has returned), the error sample,
the atlas rounds and census rounds, the traced curves, the thresholds in zeta, the stepped
sweeps. Durability comes from the store, not from Dask: rerunning the same command computes
only what no stage has committed. The run summary ends with each stage's cost and the tasks
that ran again after a lost worker.
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

from hertzmap.scheduler.cluster.clusters import (INPROCESS, JOBQUEUE, LOCAL_KINDS, ClusterSpec,
                                        WorkerJobsEnded, close_quietly, default_workers,
                                        make_client, wait_for_first_worker, where_line,
                                        worker_count)
from hertzmap.scheduler.stages.atlas_tasks import DEFAULT_ATLAS_TILE, AtlasStage
from hertzmap.scheduler.stages.curve_tasks import DEFAULT_TRACER, CurveStage
from hertzmap.scheduler.doors.dry_run import plan_for
from hertzmap.scheduler.defaults import DEFAULT_TASK_SECONDS, DEFAULT_TASK_TIMEOUT, ERROR_SAMPLE
from hertzmap.scheduler.stages.error_estimate import estimate_error, record_error_estimate
from hertzmap.scheduler.errors import ClusterError, RunError
from hertzmap.scheduler.stages.grid_tasks import GridStage
from hertzmap.scheduler.interrupt import DeferInterrupt
from hertzmap.scheduler.stages.plan import choose_chunks, is_small_study
from hertzmap.scheduler.doors.report import overhead, print_summary
from hertzmap.scheduler.resources import check_resources
from hertzmap.scheduler.stages.stage import SchedulerLost, Stage, TaskRunner, stage_costs_line
from hertzmap.scheduler.store import Lock, Store, StoreError, check_writer, open_or_create
from hertzmap.scheduler.stages.sweep_tasks import SweepStage
from hertzmap.scheduler.stages.threshold_tasks import ThresholdStage
from hertzmap.scheduler.stages.worker import DEFAULT_SOLVER, Warmup
from hertzmap.study.schema import code_fingerprint
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


def cluster_for(study: Study, *, scheduler: str | None = None, cluster: str | None = None,
                workers: int | None = None,
                options: dict[str, Any] | None = None) -> ClusterSpec:
    """Where a run goes (``hertzmap run`` and hertzmap.run): an existing scheduler at
    ``scheduler``; else a dask-jobqueue cluster of kind ``cluster`` (``options``: its class's
    keywords) or the embedded local cluster of ``workers`` processes (default one per core);
    nothing said of where (no cluster, no workers), a small study runs in this process.
    Raises ClusterError on an option that cannot be met."""
    if scheduler:
        spec = ClusterSpec(kind="address", address=scheduler, workers=workers)
    else:
        spec = ClusterSpec(kind=cluster or "local", workers=workers, options=dict(options or {}))
        if spec.kind == "local" and options:
            raise ClusterError("--cluster-option is for dask-jobqueue clusters (--cluster slurm "
                               "...)")
    spec.check()
    if spec.kind == "local" and spec.workers is None:
        spec = (ClusterSpec(kind=INPROCESS) if cluster is None and is_small_study(study)
                else ClusterSpec(kind="local", workers=default_workers()))
    return spec


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


def _has_dashboard(client) -> bool:
    try:
        return importlib.util.find_spec("bokeh") is not None and bool(client.dashboard_link)
    except Exception:
        return False


#: The stages of a run, in order, declared once (scheduler.stages.stage): each reads what the stages
#: before it committed, and a rerun resumes the first one not committed. A new stage is one
#: entry here plus its pure function (docs/architecture.md, "Where to add").
STAGES: tuple[type[Stage], ...] = (GridStage, AtlasStage, CurveStage, ThresholdStage,
                                   SweepStage)


class StudyRun:
    """One run of a study into its (locked) store: repair, resume, then every stage of
    :data:`STAGES` that is pending, through one scheduler.stages.stage.TaskRunner; summarise."""

    def __init__(self, study: Study, opts: RunOptions, store: Store, out: TextIO, err: TextIO,
                 warming: Future | None = None, owner: dict[str, Any] | None = None,
                 stages: tuple[type[Stage], ...] | None = None):
        self.study = study
        self.opts = opts
        self.store = store
        self.out = out
        self.err = err
        self.interrupt = DeferInterrupt()
        #: the store's lock record of this client: its tasks' workers write only while it holds
        self.owner = owner
        #: the warm-up plugin's registration, started with the embedded cluster (start_warm_up)
        self.warming = warming
        self.stages = [cls(study, store, out, err, self.interrupt, opts.command, owner, opts)
                       for cls in (STAGES if stages is None else stages)]
        self.grid = self.stages[0]
        self.plan = self.grid.plan
        self.names = self.grid.names
        self.runner: TaskRunner | None = None
        self.summary: dict[str, Any] = {"store": str(store.path), "tasks_total": len(self.plan.tasks),
                                        "tasks_done_before": 0, "tasks_run": 0, "failed": []}

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
            # the blocks a killed run staged, packed into their shards (no recomputing)
            with self.interrupt.critical():
                self.grid.pack_staged()
        todo = self.grid.todo()
        n_done = len(self.plan.tasks) - len(todo)
        self.summary["tasks_done_before"] = n_done
        if resumed:
            self.note_resume(n_done, todo)
        if not todo:
            print(f"{self.store.path}: all {len(self.plan.tasks)} tasks done, nothing to compute",
                  file=self.out)
            self.summary.update(complete=True, wall=0.0)
            if not any(s.pending() for s in self.stages[1:]):
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
                return self.compute(client, cluster, todo, t_setup, own_client)
        except KeyboardInterrupt as exc:
            self.report_interrupt()
            exc.reported = True
            raise
        finally:
            if own_client:
                close_quietly(client, cluster)

    def report_interrupt(self) -> None:
        if self.runner is not None:
            self.runner.cancel()
        n = int(self.store.done_mask().sum())
        total = len(self.plan.tasks)
        if n < total:
            what, note = f"{n}/{total} tasks are done and", f"with {n}/{total} tasks done"
        else:
            what, note = ("the grid and the stages committed so far are", "after the grid")
        with contextlib.suppress(Exception):
            self.store.add_history(f"{self.opts.command}: interrupted {note}")
        print(f"\nhertzmap: interrupted: {what} kept in {self.store.path}; to resume, run "
              f"again: {self.opts.command}", file=self.err, flush=True)

    def workers_without_the_store(self, client) -> list[str]:
        """The connected workers that cannot write this client's store (scheduler.store.
        check_writer on each), with why: workers on other machines need it on a shared file
        system. A worker that joins later is checked by its first task."""
        replies = client.run(check_writer, str(self.store.path.resolve()), self.owner,
                             on_error="return")
        return [f"{w}: {r}" for w, r in sorted(replies.items()) if isinstance(r, Exception)]

    def stop(self, what: str, why: str, msg: str) -> dict[str, Any]:
        """The run stops before its tasks: ``msg`` printed with how to resume, ``why`` in the
        store's history, ``what`` (what is missing) the summary's failure."""
        msg = f"{msg}; fix that and rerun: the store ({self.store.path}) resumes"
        with self.interrupt.critical():
            self.store.add_history(f"{self.opts.command}: stopped, {why}")
        print(f"hertzmap: error: {msg}", file=self.err, flush=True)
        self.summary.update(complete=False, failed=[(what, msg)])
        return self.summary

    def wait_for_workers(self, client, cluster, own_client: bool) -> dict[str, Any] | None:
        """Wait for the cluster's workers, warm them up, check that they can write the store;
        returns the summary of a run that stops here, else None."""
        opts = self.opts
        if opts.cluster.kind not in LOCAL_KINDS and own_client:
            print(f"waiting for workers ({opts.cluster.describe()}) ...", file=self.out, flush=True)
        if cluster is not None and opts.cluster.kind in JOBQUEUE:
            try:
                wait_for_first_worker(client, cluster, opts.cluster, _printer(self.out))
            except WorkerJobsEnded as exc:
                return self.stop("worker jobs", "no worker job started", str(exc))
        else:
            # an existing scheduler with --workers N: wait for N workers before starting
            client.wait_for_workers(opts.cluster.workers if opts.cluster.kind == "address"
                                    and opts.cluster.workers else 1)
        if self.warming is not None:
            self.warming.result()       # registered when the embedded cluster started
        elif opts.cluster.kind != INPROCESS and self.grid.pending():
            client.register_plugin(warm_up_plugin(self.study, opts), name="hertzmap-warmup")
        # (in-process, the one worker thread loads the kernels its first task calls: a warm-up
        # there would load every entry point, the census's and the curves' too, in this
        # process, and compete with the store's creation for its interpreter lock)
        if opts.cluster.kind not in LOCAL_KINDS:
            blind = self.workers_without_the_store(client)
            if blind:
                return self.stop("shared file system", "workers cannot write the store",
                                 f"{len(blind)} worker(s) cannot write the store: {blind[0]}"
                                 f"{' ...' if len(blind) > 1 else ''}")
        return None

    def compute(self, client, cluster, todo, t_setup, own_client) -> dict[str, Any]:
        stopped = self.wait_for_workers(client, cluster, own_client)
        if stopped is not None:
            return stopped
        n_workers = worker_count(client)
        self.runner = TaskRunner(client, self.interrupt, self.err, n_workers)
        try:
            if todo:
                self.compute_grid(client, n_workers, todo, time.perf_counter() - t_setup)
            if self.summary.get("complete"):
                self.after_grid()
        except SchedulerLost:
            return self.scheduler_lost()
        finally:
            self.summary["stages"] = {n: c.as_dict() for n, c in self.runner.costs.items()}
        if self.runner.costs:
            print(stage_costs_line(self.runner.costs), file=self.out, flush=True)
        self.settle_slots()
        return self.summary

    def compute_grid(self, client, n_workers: int, todo, setup: float) -> None:
        opts, store, summary = self.opts, self.store, self.summary
        summary["where"] = where_line(opts.cluster, n_workers)
        dash = (client.dashboard_link if _has_dashboard(client) else "unavailable (pip install bokeh)"
                ) if opts.cluster.kind != INPROCESS else "none (in-process)"
        print(f"running {len(todo)} tasks ({sum(t.size for t in todo)} points) "
              f"{summary['where']}; setup {setup:.1f} s; dashboard: {dash}", file=self.out, flush=True)
        with self.runner.timed(self.grid.name):
            grid = self.grid.run(self.runner)
        wall = grid["wall"]
        summary.update(grid)
        summary.update(
            setup=setup, workers=n_workers,
            overhead=overhead(grid["compute"], wall, n_workers, grid["tasks_run"]),
            per_task=grid["compute"] / max(1, grid["tasks_run"]),
            points_per_second=grid["points"] / wall if wall > 0 else math.nan,
            orbits_per_second=grid["orbits"] / wall if wall > 0 else math.nan)
        total = len(self.plan.tasks)
        with self.interrupt.critical():
            if summary["failed"]:
                summary["complete"] = False
                store.add_history(f"{opts.command}: stopped, {len(summary['failed'])} tasks failed")
            else:
                summary["complete"] = bool(store.done_mask().all())
                store.add_history(f"{opts.command}: completed {total}/{total} tasks")
        try:
            summary["error"] = estimate_error(self.runner, self.study, self.grid.sampler.samples,
                                              solver=self.grid.solver)
        except SchedulerLost:
            raise
        except Exception as exc:  # the estimate is a report, never a reason to fail the run
            summary["error"] = {"n": 0, "failed": f"{type(exc).__name__}: {exc}"}
        record_error_estimate(store, summary)
        print_summary(summary, self.out)

    def after_grid(self) -> None:
        """The stages that read the complete grid, in the order of :data:`STAGES`."""
        for stage in self.stages[1:]:
            if stage.pending():
                with self.runner.timed(stage.name):
                    self.summary[stage.name] = stage.run(self.runner)
            else:
                why = stage.not_run()
                if why:
                    print(why, file=self.out, flush=True)

    def settle_slots(self) -> None:
        """Once nothing is left to compute: the store's slot dims cut to the most any point
        holds (scheduler.store.Store.settle_slots; they grew by whole chunks during the run)."""
        if any(s.pending() for s in self.stages):
            return
        with self.interrupt.critical():
            self.store.settle_slots()

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
