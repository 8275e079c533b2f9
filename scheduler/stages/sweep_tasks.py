"""Stepped-sine sweeps, and swept sines at the study's rates, as a stage of a run (the
``sweeps`` output, issue 45), after the grid and the stages that read it: at each line of the
grid (each (sigma, zeta) for ``[sweep] axis = "omega"``, each (omega, zeta) for ``"sigma"``)
two stepped sweeps over the grid's values of the axis, up and down, each one task
(study.solve.sweep_runs.run_sweep: study.solve.sweep.stepped_sweep on a worker, its
record of numbers returned); then, with ``[sweep] rates``, one swept-sine run per line,
direction and rate, each one task (study.solve.sweep_runs.run_swept: study.solve.sweep.
swept_sine over the line's range, read at the product's samples, and the stepped sweep's jumps
read on it). A swept task is per (line, direction, rate), not per line: each needs the stepped
sweep of its own direction only (its start state and its jumps), its cost grows as 1 / rate and
the slowest rate's two directions then run on two workers side by side.

The commit rule: each record is staged in the store as it returns (scheduler.store.stage_file:
one .npz file, whole or not at all; the stepped sweeps' by scheduler.store.stage_sweep, the
swept runs' by stage_swept, in a subfolder of the same staging folder); the swept runs start once
every stepped sweep is staged (from their staged records); once every run is staged, the client
writes the product ``products/sweeps`` (study.products.stepped_sweeps.sweeps_dataset, with the
store's orbits along each line) and removes the staging folder with everything in it. A run
killed at any point resumes the stepped sweeps, then the swept runs, not staged; a rerun of a
store that holds the product computes nothing.
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np

from hertzmap.scheduler.stages.stage import Stage, Task, TaskRunner
from hertzmap.scheduler.store import (SWEEP_STAGE, has_run_product, remove_stage, stage_sweep,
                                      stage_swept, staged_sweeps, staged_swept, write_product)
from hertzmap.study.products.results import open_store
from hertzmap.study.products.stepped_sweeps import SWEEPS, jumps_of, sweeps_dataset
from hertzmap.study.solve.sweep_runs import run_sweep, run_swept, sweep_specs, swept_specs

def sweep_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One stepped sweep (runs on a worker): ``spec`` one of study.products.stepped_sweeps.
    sweep_specs (a line, a direction, stepped_sweep's arguments). Returns its record and the
    seconds it took."""
    t0 = time.perf_counter()
    record = run_sweep(spec)
    return {"record": record, "seconds": time.perf_counter() - t0}


def swept_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One swept-sine run (runs on a worker): ``spec`` one of study.products.stepped_sweeps.
    swept_specs (a line, a direction, a rate, swept_sine's arguments, the stepped sweep's
    jumps to read on it). Returns its record and the seconds it took."""
    t0 = time.perf_counter()
    record = run_swept(spec)
    return {"record": record, "seconds": time.perf_counter() - t0}


class SweepStage(Stage):
    """The sweeps stage of one run of a study into its (locked) store."""

    name = "sweeps"

    def pending(self) -> bool:
        return "sweeps" in self.study.outputs and not has_run_product(
            self.store.path, SWEEPS, self.study.hash)

    def run(self, runner: TaskRunner) -> dict[str, Any]:
        """Run the stepped sweeps not staged yet, then the swept runs not staged yet, stage
        each as it returns, then write products/sweeps. Returns the stage's summary (also
        printed)."""
        t0 = time.perf_counter()
        specs = sweep_specs(self.study)
        staged = staged_sweeps(self.store.path)
        todo = [s for s in specs if (s["line"], s["direction"]) not in staged]
        if staged:
            print(f"resuming the sweeps of {self.store.path}: {len(specs) - len(todo)}/"
                  f"{len(specs)} staged", file=self.out, flush=True)
        tasks = [Task(self.key(s["line"], s["direction"]), s, len(s["sweep"]["values"]))
                 for s in todo]

        def commit(task: Task, res: dict[str, Any]) -> None:
            stage_sweep(self.store.path, task.spec["line"], task.spec["direction"],
                        res["record"])
            staged[(task.spec["line"], task.spec["direction"])] = res["record"]

        cost = runner.map(self.name, sweep_task, tasks, commit, unit="tasks",
                          total=len(specs), done_before=len(specs) - len(todo))
        summary: dict[str, Any] = {"sweeps": len(specs), "resumed": len(specs) - len(todo),
                                   "compute": cost.compute, "failed": cost.failed,
                                   "complete": not cost.failed}
        if cost.failed:
            print(f"sweeps: {len(cost.failed)} sweep(s) failed ({cost.failed[0][1]}); rerun "
                  "the same command to retry them (the others are staged)", file=self.out,
                  flush=True)
            return summary
        swept = self._swept(runner, staged, summary)
        if swept is None:
            return summary
        product = sweeps_dataset(open_store(self.store.path), staged, self.study, swept)
        n_swept = len(swept)
        with self.interrupt.critical():
            write_product(self.store.path, SWEEPS, product, lock=False)
            remove_stage(self.store.path, SWEEP_STAGE)
            self.store.add_history(f"{self.command}: sweeps: {len(specs)} stepped sweeps, "
                                   f"{product.sizes['jump']} jumps"
                                   + (f", {n_swept} swept sines" if n_swept else ""))
        rows = jumps_of(product)
        kinds: dict[str, int] = {}
        for r in rows:
            kinds[r["kind"]] = kinds.get(r["kind"], 0) + 1
        summary.update(jumps=len(rows), kinds=kinds, wall=time.perf_counter() - t0)
        n = product.sizes["line"]
        swept_text = ""
        if n_swept:
            read = int(np.isfinite(product["swept_jump_value"].values).sum())
            nr = product.sizes["rate"]
            swept_text = (f"; {n_swept} swept sines ({nr} rate{'s' if nr != 1 else ''} x up, "
                          f"down), {read} of their {product['swept_jump_value'].size} jump "
                          "readings found")
            summary.update(swept_jumps=read)
        print(f"sweeps: {len(specs)} stepped sweeps ({n} line{'s' if n != 1 else ''} x up, "
              f"down; {product.sizes['step']} steps each along {product.attrs['sweep_axis']}), "
              f"{len(rows)} jump{'s' if len(rows) != 1 else ''} ("
              + (", ".join(f"{n} {k}" for k, n in sorted(kinds.items())) or "none")
              + f"){swept_text}; {summary['compute']:.1f} s compute, {summary['wall']:.1f} s "
              f"wall (products/{SWEEPS})", file=self.out, flush=True)
        return summary

    def _swept(self, runner: TaskRunner, staged: dict, summary: dict[str, Any]
               ) -> dict[tuple[int, str, int], dict[str, np.ndarray]] | None:
        """Run the swept-sine runs of the study's rates not staged yet (each from its stepped
        sweep's staged record), staging each as it returns. Returns every run's record, or
        None when some failed (the summary says which; the others are staged)."""
        specs = swept_specs(self.study, staged)
        summary["swept"] = len(specs)
        if not specs:
            return {}
        done = staged_swept(self.store.path)
        todo = [s for s in specs if (s["line"], s["direction"], s["rate_index"]) not in done]
        if done:
            print(f"resuming the swept sines of {self.store.path}: {len(specs) - len(todo)}/"
                  f"{len(specs)} staged", file=self.out, flush=True)
        tasks = [Task(self.key("swept", s["line"], s["direction"], s["rate_index"]), s)
                 for s in todo]

        def commit(task: Task, res: dict[str, Any]) -> None:
            s = task.spec
            stage_swept(self.store.path, s["line"], s["direction"], s["rate_index"],
                        res["record"])
            done[(s["line"], s["direction"], s["rate_index"])] = res["record"]

        cost = runner.map(self.name, swept_task, tasks, commit, label="swept sines",
                          unit="tasks", total=len(specs), done_before=len(specs) - len(todo))
        summary["compute"] += cost.compute
        summary["swept_resumed"] = len(specs) - len(todo)
        if cost.failed:
            summary["failed"] = cost.failed
            summary["complete"] = False
            print(f"sweeps: {len(cost.failed)} swept sine(s) failed ({cost.failed[0][1]}); "
                  "rerun the same command to retry them (the others are staged)",
                  file=self.out, flush=True)
            return None
        return done
