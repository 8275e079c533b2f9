"""One stage protocol and one runner for all the work a run ships to Dask.

A **stage** of a run (:class:`Stage`) is three things:

* its **tasks** (:class:`Task`: a key unique to the study, the stage and the task; a picklable
  spec; a size, the points it covers, for the progress line), read from the store so that a
  rerun ships only what is not committed yet (resume);
* **one pure function** that computes a task on a worker (module-level, so Dask ships it by
  name: the spec in, a dict out, with the seconds it computed as ``seconds``; it calls a pure
  ``study.solve`` function, and may stage its result in the store itself, as the grid's and the
  atlas's tasks do);
* a **commit rule**: what the client does with a task's result, inside the run's interrupt
  guard (a ``task_done`` flag, a region write, a staged round committed whole, a product).

``pending()`` says whether the store lacks the stage's results, ``run(runner)`` ships its tasks
through the one :class:`TaskRunner` and returns the stage's summary. The run's stages are
declared once, in order, in scheduler.run.STAGES (docs/architecture.md, "Where to add": a new
stage is one entry there plus its pure function).

The runner submits, prints progress, commits each result as it comes, and measures each stage:
the tasks run, their compute seconds, the wall time, the tasks that failed for good, and the
tasks that were on a worker when it was lost. Dask runs those again elsewhere (the store ends
right: a task's result is committed once, when it returns), and the run summary says how many
(read from the scheduler's ``remove-worker`` events, so it holds for every cluster kind).
"""
from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Sequence, TextIO

from hertzmap.kernels.model import contact_loss_level
from hertzmap.scheduler.stages.progress import Progress, WorkEstimate
from hertzmap.scheduler.store import Store
from hertzmap.study.spec import Study


@dataclass(frozen=True)
class Task:
    """One task of a stage: its Dask key, its spec (the function's one argument) and its size
    (the grid points it covers; 1 for a task of no grid block)."""
    key: str
    spec: Any
    size: int = 1
    #: where on the grid (its block's index): the progress line's estimate of the compute
    #: ahead interpolates the done tasks' costs over it (scheduler.stages.progress.WorkEstimate)
    place: tuple | None = None


@dataclass
class StageCost:
    """What a stage cost in one run: the tasks run, their compute seconds (as the tasks
    measured them), the wall time, the tasks that were on a lost worker and ran again, the
    workers lost meanwhile, and the tasks that failed for good (key, why)."""
    tasks: int = 0
    compute: float = 0.0
    wall: float = 0.0
    reruns: int = 0
    workers_lost: int = 0
    failed: list[tuple[str, str]] = field(default_factory=list)

    def add(self, other: "StageCost") -> None:
        self.tasks += other.tasks
        self.compute += other.compute
        self.wall += other.wall
        self.reruns += other.reruns
        self.workers_lost += other.workers_lost
        self.failed.extend(other.failed)

    def as_dict(self) -> dict[str, Any]:
        return {"tasks": self.tasks, "compute": self.compute, "wall": self.wall,
                "reruns": self.reruns, "workers_lost": self.workers_lost,
                "failed": list(self.failed)}


class SchedulerLost(RuntimeError):
    """The client lost its Dask scheduler during a stage: what is committed is kept."""


def scheduler_lost(client, exc: BaseException | None = None) -> bool:
    """True when the client lost its scheduler (futures cancelled for that reason)."""
    if exc is not None and "connection-lost" in str(getattr(exc, "reason", "") or exc):
        return True
    try:
        return client.status not in ("running", "newly-created")
    except Exception:
        return True


def _removal_events(client, since: float) -> list[dict]:
    """The scheduler's ``remove-worker`` events after ``since`` (its clock), unexpected ones
    only (a worker closed by its cluster on purpose hands its tasks over)."""
    try:
        events = client.get_events("all")
    except Exception:
        return []
    return [msg for ts, msg in events
            if ts > since and isinstance(msg, dict) and msg.get("action") == "remove-worker"
            and not msg.get("expected", False)]


def _last_event_time(client) -> float:
    try:
        events = client.get_events("all")
    except Exception:
        return math.inf
    return float(events[-1][0]) if events else -math.inf


class TaskRunner:
    """Ships the tasks of every stage of one run to a Dask client (its own cluster or the
    user's), commits their results and keeps each stage's :class:`StageCost`."""

    def __init__(self, client, interrupt, err: TextIO, n_workers: int = 1):
        self.client = client
        self.interrupt = interrupt
        self.err = err
        self.n_workers = max(1, int(n_workers))
        #: the cost of each stage run so far, by name, in the order they ran
        self.costs: dict[str, StageCost] = {}
        #: the futures in flight (cancelled on an interrupt)
        self.futures: list = []
        #: the :meth:`timed` blocks open, innermost last: [stage, since]
        self._timing: list[list] = []

    def cost(self, stage: str) -> StageCost:
        return self.costs.setdefault(stage, StageCost())

    @contextlib.contextmanager
    def timed(self, stage: str):
        """The wall time of the block is the stage's (its reading, committing and waiting
        besides its tasks'): the run wraps each stage's ``run`` in it. A block of another
        stage inside it (the atlas's census rounds) is that stage's time, not both."""
        if self._timing and self._timing[-1][0] == stage:
            yield
            return
        now = time.perf_counter()
        if self._timing:
            outer = self._timing[-1]
            self.cost(outer[0]).wall += now - outer[1]
        self._timing.append([stage, now])
        try:
            yield
        finally:
            name, t0 = self._timing.pop()
            now = time.perf_counter()
            self.cost(name).wall += now - t0
            if self._timing:
                self._timing[-1][1] = now

    def _add(self, stage: str, cost: StageCost) -> None:
        own = self.cost(stage)
        own.add(cost)
        if any(name == stage for name, _ in self._timing):   # a timed block measures it
            own.wall -= cost.wall

    # -- a list of tasks, each result committed as it comes --------------------------------
    def map(self, stage: str, function: Callable[[Any], dict], tasks: Sequence[Task],
            commit: Callable[[Task, dict], None], *, label: str | None = None,
            total: int | None = None, done_before: int = 0, unit: str = "points",
            prior: float | None = None) -> StageCost:
        """Run ``function`` on each task's spec and call ``commit(task, result)`` (in the
        interrupt guard) as each returns. A task that fails for good (after Dask's retries) is
        recorded in the cost's ``failed`` and not committed; the scheduler lost raises
        :class:`SchedulerLost`. ``label``, ``total`` and ``done_before``: the progress line's
        (default: the stage's name, the tasks given, none); ``prior``: the plan's compute
        seconds per point, the time left's estimate until a task is done (with the tasks'
        places: scheduler.stages.progress.WorkEstimate). Tasks are shipped in the order given.
        Returns this call's cost (also added to the stage's)."""
        from distributed import as_completed

        cost = StageCost()
        if not tasks:
            return cost
        t0 = time.perf_counter()
        since = _last_event_time(self.client)
        work = None
        if prior is not None and all(t.place is not None for t in tasks):
            work = WorkEstimate({t.key: t.place for t in tasks}, {t.key: t.size for t in tasks},
                                prior)
        progress = Progress(self.err, label or stage, done_before + len(tasks) if total is None
                            else total, sum(t.size for t in tasks), done_before, unit=unit,
                            work=work)
        by_key = {t.key: t for t in tasks}
        futures = self.client.map(function, [t.spec for t in tasks],
                                  key=[t.key for t in tasks], pure=False)
        self.futures = futures
        lost = None
        try:
            for fut in as_completed(futures):
                try:
                    res = fut.result()
                except Exception as exc:
                    if scheduler_lost(self.client, exc):
                        lost = exc
                        break
                    cost.failed.append((str(fut.key), f"{type(exc).__name__}: {exc}"))
                    fut.release()
                    continue
                task = by_key[fut.key]
                with self.interrupt.critical():
                    commit(task, res)
                fut.release()
                cost.tasks += 1
                cost.compute += float(res.get("seconds", 0.0))
                progress.update(task.size, key=task.key, seconds=float(res.get("seconds", 0.0)))
        finally:
            progress.close()
            self.futures = []
        if lost is None and cost.failed and scheduler_lost(self.client):
            lost = RuntimeError("scheduler lost")
        cost.wall = time.perf_counter() - t0
        self._count_reruns(cost, by_key, since)
        self._add(stage, cost)
        if lost is not None:
            raise SchedulerLost(str(lost))
        return cost

    # -- tasks shipped one by one (a stage that decides what to ship from what came back) -----
    def window(self, stage: str, function: Callable[[Any], dict]) -> "TaskWindow":
        """A :class:`TaskWindow` of ``stage``: submit tasks one at a time and wait for any of
        them (the traced curves: their seeds are decided in order as traces come back)."""
        return TaskWindow(self, stage, function)

    def _count_reruns(self, cost: StageCost, keys: Iterable[str], since: float) -> None:
        if since == math.inf:       # the scheduler's events could not be read
            return
        keys = set(keys)
        for msg in _removal_events(self.client, since):
            hit = keys & (set(msg.get("processing-tasks") or ())
                          | set(msg.get("lost-computed-tasks") or ()))
            cost.workers_lost += 1
            cost.reruns += len(hit)

    def cancel(self) -> None:
        """Cancel what is in flight (an interrupt)."""
        try:
            self.client.cancel(self.futures)
        except Exception:
            pass

    # -- the summary ------------------------------------------------------------------------
    def total(self) -> StageCost:
        out = StageCost()
        for c in self.costs.values():
            out.add(c)
        return out


class TaskWindow:
    """A stage's tasks shipped one at a time (TaskRunner.window); used as a context manager:
    on exit, what is still in flight is cancelled and the stage's cost is recorded."""

    def __init__(self, runner: TaskRunner, stage: str, function: Callable[[Any], dict]):
        self.runner = runner
        self.stage = stage
        self.function = function
        self.cost = StageCost()
        self.in_flight: dict[Any, Any] = {}
        self.keys: set[str] = set()

    def __enter__(self) -> "TaskWindow":
        self.t0 = time.perf_counter()
        self.since = _last_event_time(self.runner.client)
        return self

    def submit(self, name: Any, task: Task) -> None:
        """Ship ``task`` under ``name`` (what :meth:`wait` returns it by)."""
        self.keys.add(task.key)
        self.in_flight[name] = self.runner.client.submit(self.function, task.spec,
                                                         key=task.key, pure=False)

    def cancel(self, name: Any) -> None:
        fut = self.in_flight.pop(name, None)
        if fut is not None:
            fut.cancel()

    def wait(self) -> list[tuple[Any, dict | None]]:
        """Wait for at least one task in flight; return (name, result) of each that returned
        (result None: it failed for good, recorded in the cost's ``failed``)."""
        from distributed import wait

        done, _ = wait(list(self.in_flight.values()), return_when="FIRST_COMPLETED")
        out = []
        for name, fut in list(self.in_flight.items()):
            if fut not in done:
                continue
            del self.in_flight[name]
            try:
                res = fut.result()
            except Exception as exc:
                if scheduler_lost(self.runner.client, exc):
                    raise SchedulerLost(str(exc)) from None
                self.cost.failed.append((str(fut.key), f"{type(exc).__name__}: {exc}"))
                out.append((name, None))
                continue
            finally:
                fut.release()
            self.cost.tasks += 1
            self.cost.compute += float(res.get("seconds", 0.0))
            out.append((name, res))
        return out

    def __exit__(self, *exc) -> None:
        for fut in self.in_flight.values():
            fut.cancel()
        self.in_flight.clear()
        self.cost.wall = time.perf_counter() - self.t0
        self.runner._count_reruns(self.cost, self.keys, self.since)
        self.runner._add(self.stage, self.cost)


class Stage:
    """A stage of one run of a study into its (locked) store (the module's docstring): the
    study, the store, the lock's owner, where to print, the run's interrupt guard and command,
    and the solver's options its tasks integrate with. A subclass sets :attr:`name` and
    defines :meth:`pending` and :meth:`run`."""

    #: the stage's name in the run summary, the store's history and its tasks' keys
    name = "stage"

    def __init__(self, study: Study, store: Store, out: TextIO, err: TextIO, interrupt,
                 command: str = "hertzmap run", owner: dict | None = None, opts: Any = None):
        self.study = study
        #: the store's lock record of this run's client (scheduler.store.Lock.owner): workers
        #: write into the store only while it holds it
        self.owner = owner
        self.store = store
        self.out = out
        self.err = err
        self.interrupt = interrupt
        self.command = command
        #: the run's options (scheduler.run.RunOptions), for a stage that takes one of them
        self.opts = opts
        kw = study.solver_kwargs()
        #: the integration options of the stage's tasks (exponent, model, rtol)
        self.options = {"exponent": kw["exponent"], "model": kw["model"], "rtol": kw["rtol"]}
        #: the contact-loss level (the grazing test)
        self.level = contact_loss_level(kw["model"], kw["exponent"])

    def key(self, *parts: Any) -> str:
        """A task key unique to the study and the stage."""
        return "-".join(["hertzmap", self.name, self.study.hash[:12], *map(str, parts)])

    def pending(self) -> bool:
        """True when the store lacks this stage's results (a run computes, or resumes, it)."""
        raise NotImplementedError

    def run(self, runner: TaskRunner) -> dict[str, Any]:
        """Ship the stage's tasks through ``runner``, commit them, return its summary (also
        printed)."""
        raise NotImplementedError

    def not_run(self) -> str | None:
        """Why a stage the study asks for does not run (printed by the run), else None."""
        return None


def stage_costs_line(costs: dict[str, StageCost]) -> str:
    """The run summary's line of what each stage cost, and the tasks rerun after lost
    workers."""
    parts = []
    for name, c in costs.items():
        if not c.tasks and not c.failed:
            continue
        parts.append(f"{name} {c.tasks} task{'s' if c.tasks != 1 else ''}, "
                     f"{c.compute:.1f} s compute, {c.wall:.1f} s wall")
    line = "stages: " + ("; ".join(parts) if parts else "none ran")
    reruns = {n: c.reruns for n, c in costs.items() if c.reruns}
    lost = sum(c.workers_lost for c in costs.values())
    if reruns or lost:
        line += (f"; {sum(reruns.values())} task(s) ran again after {lost} lost worker(s) ("
                 + ", ".join(f"{n} {k}" for n, k in reruns.items()) + ")" if reruns else
                 f"; {lost} worker(s) lost, no task of this run on them")
    else:
        line += "; no worker lost"
    return line
