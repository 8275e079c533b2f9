"""The grid as a stage of a run (scheduler.stages.stage): one task per block of the store (a chunk
of omega x sigma x zeta points), solved on a worker by the block solver (scheduler.stages.worker.
run_task -> study.solve.block.solve_block), which stages the block in the store (one file) and
returns a summary of a few hundred bytes. The commit rule: once every block of a shard is
staged, the client packs them into the shard (scheduler.store.block_writes.pack_shard: the
shard written once, by the client alone) and sets their ``task_done`` flags; a rerun packs
what a killed run staged and ships only the blocks neither flagged nor staged.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from hertzmap.scheduler.stages.plan import make_plan, seconds_per_point, spread_order
from hertzmap.scheduler.doors.report import KIND_COUNTS, SUMMED_COUNTS, WORST_COUNTS, add_counts
from hertzmap.scheduler.stages.sample import Sampler
from hertzmap.scheduler.stages.stage import Stage, Task, TaskRunner
from hertzmap.scheduler.store import GRID_STAGE, remove_stage
from hertzmap.scheduler.store.block_writes import pack_shard, staged_blocks
from hertzmap.scheduler.store.layout import shard_members, shard_of
from hertzmap.scheduler.stages.worker import DEFAULT_SOLVER, run_task
from hertzmap.study.schema import stored_variables
from hertzmap.study.spec import Study


def task_specs(study: Study, tasks, kwargs: dict[str, Any], names, solver, time_budget, *,
               store: Path, owner: dict[str, Any], sampler: Sampler) -> list[dict[str, Any]]:
    """What the client hands to Dask for each task (scheduler.stages.worker.run_task's argument):
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


class GridStage(Stage):
    """The grid stage of one run of a study into its (locked) store."""

    name = "grid"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.plan = make_plan(self.study, self.store.chunks)
        self.names = stored_variables(self.study)
        solver = getattr(self.opts, "solver", DEFAULT_SOLVER)
        self.solver = solver
        #: the error estimate's sample of converged orbits (scheduler.stages.sample), filled as the
        #: blocks come back
        self.sampler = Sampler(self.study, int(getattr(self.opts, "error_sample", 0)))

    def todo(self) -> list:
        """The blocks neither flagged done nor staged."""
        done = self.store.done_mask()
        staged = staged_blocks(self.store.path)
        return [t for t in self.plan.tasks if not done[t.index] and t.index not in staged]

    def pack_staged(self) -> set:
        """Pack what a killed run staged, where its shard is whole; returns the blocks still
        staged."""
        staged = staged_blocks(self.store.path)
        self.pack_ready(staged)
        return staged

    def pack_ready(self, staged: set, shards=None) -> None:
        """Pack every shard (of ``shards``, default all) whose blocks are all done or staged."""
        blocks, counts = self.store.shard_blocks, self.plan.counts
        done = self.store.done_mask()
        for shard in sorted(shards if shards is not None
                            else {shard_of(i, blocks) for i in staged}):
            members = shard_members(shard, blocks, counts)
            if all(done[m] or m in staged for m in members):
                for m in pack_shard(self.store, shard, counts, self.names):
                    staged.discard(m)
        if not staged and self.store.done_mask().all():
            # what is left: the files of workers killed while staging
            remove_stage(self.store.path, GRID_STAGE)

    def shard_order(self, blocks) -> list:
        """The blocks in the order a run ships them: shard after shard (a shard is packed, and
        its staged files removed, as soon as its last block returns), each shard's blocks in
        plan.spread_order (the progress line's estimate knows every region's cost early)."""
        by_shard: dict = {}
        for b in spread_order(blocks):
            by_shard.setdefault(shard_of(b.index, self.store.shard_blocks), []).append(b)
        shards = spread_order(sorted(by_shard))
        return [b for s in shards for b in by_shard[s]]

    def pending(self) -> bool:
        return not bool(self.store.done_mask().all())

    def run(self, runner: TaskRunner) -> dict[str, Any]:
        """Solve the blocks not flagged done; returns the grid's counts (the run summary's)."""
        todo = self.shard_order(self.todo())
        n_done = len(self.plan.tasks) - len(todo)
        specs = task_specs(self.study, todo, self.study.solver_kwargs(), self.names,
                           self.solver, getattr(self.opts, "task_timeout", None),
                           store=self.store.path, owner=self.owner, sampler=self.sampler)
        tasks = [Task(self.key(*t.index), spec, t.size, t.index) for t, spec in zip(todo, specs)]
        by_key = {task.key: t for task, t in zip(tasks, todo)}
        tally = {"compute": 0.0, "write": 0.0, "points": 0, "pids": set(),
                 **{k: 0 for k in SUMMED_COUNTS}, **{k: math.nan for k in WORST_COUNTS}}

        staged = self.pack_staged()

        def commit(task: Task, res: dict) -> None:
            block = by_key[task.key]
            # the worker staged the block before its task returned: its shard is packed (and
            # its blocks flagged) once all its blocks are staged
            staged.add(block.index)
            self.pack_ready(staged, [shard_of(block.index, self.store.shard_blocks)])
            tally["write"] += res["write_seconds"]
            tally["pids"].add(res["pid"])
            add_counts(tally, res["counts"])
            tally["points"] += block.size
            self.sampler.merge(res["samples"])

        cost = runner.map(self.name, run_task, tasks, commit, label="grid",
                          total=len(self.plan.tasks), done_before=n_done,
                          prior=seconds_per_point(self.study))
        n_conv, n_fail = tally["conv"], tally["fail"]
        return dict(
            wall=cost.wall, compute=cost.compute, tasks_run=cost.tasks, failed=cost.failed,
            block_writes=tally["write"], points=tally["points"],
            orbits=n_conv, failed_slots=n_fail, points_with_orbit=tally["with"],
            time_limited=tally["cut"],
            converged_fraction=n_conv / (n_conv + n_fail) if n_conv + n_fail else math.nan,
            worker_processes_seen=len(tally["pids"]),
            liouville_worst=tally["liouville"], lyapunov_sum_worst=tally["lyapunov_sum"],
            attractors=tally["attractors"], stable=tally["stable"],
            slots=tally.get("slots", {}), attractor_kinds={k: tally[k] for k in KIND_COUNTS})
