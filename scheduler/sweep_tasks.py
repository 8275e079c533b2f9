"""Stepped-sine sweeps as a stage of a run (the ``sweeps`` output, issue 45), after the grid
and the stages that read it: at each line of the grid (each (sigma, zeta) for ``[sweep] axis =
"omega"``, each (omega, zeta) for ``"sigma"``) two sweeps over the grid's values of the axis, up
and down, each one task (study.products.stepped_sweeps.run_sweep: study.solve.sweep.
stepped_sweep on a worker, its record of numbers returned). The commit rule: each sweep's record
is staged in the store as it returns (scheduler.store.stage_sweep: one .npz file, whole or not
at all); once every sweep is staged, the client writes the product ``products/sweeps``
(study.products.stepped_sweeps.sweeps_dataset, with the store's orbits along each line) and
removes the staged files. A run killed at any point resumes the sweeps not staged; a rerun of
a store that holds the product computes nothing.
"""
from __future__ import annotations

import time
from typing import Any

from hertzmap.scheduler.stage import Stage, Task, TaskRunner
from hertzmap.scheduler.store import (SWEEP_STAGE, has_run_product, remove_stage, stage_sweep,
                                      staged_sweeps, write_product)
from hertzmap.study.products.results import open_store
from hertzmap.study.products.stepped_sweeps import (SWEEPS, jumps_of, run_sweep, sweep_specs,
                                                    sweeps_dataset)


def sweep_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One stepped sweep (runs on a worker): ``spec`` one of study.products.stepped_sweeps.
    sweep_specs (a line, a direction, stepped_sweep's arguments). Returns its record and the
    seconds it took."""
    t0 = time.perf_counter()
    record = run_sweep(spec)
    return {"record": record, "seconds": time.perf_counter() - t0}


class SweepStage(Stage):
    """The sweeps stage of one run of a study into its (locked) store."""

    name = "sweeps"

    def pending(self) -> bool:
        return "sweeps" in self.study.outputs and not has_run_product(
            self.store.path, SWEEPS, self.study.hash)

    def run(self, runner: TaskRunner) -> dict[str, Any]:
        """Run the sweeps not staged yet, stage each as it returns, then write products/sweeps.
        Returns the stage's summary (also printed)."""
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
        product = sweeps_dataset(open_store(self.store.path), staged, self.study)
        with self.interrupt.critical():
            write_product(self.store.path, SWEEPS, product, lock=False)
            remove_stage(self.store.path, SWEEP_STAGE)
            self.store.add_history(f"{self.command}: sweeps: {len(specs)} stepped sweeps, "
                                   f"{product.sizes['jump']} jumps")
        rows = jumps_of(product)
        kinds: dict[str, int] = {}
        for r in rows:
            kinds[r["kind"]] = kinds.get(r["kind"], 0) + 1
        summary.update(jumps=len(rows), kinds=kinds, wall=time.perf_counter() - t0)
        n = product.sizes["line"]
        print(f"sweeps: {len(specs)} stepped sweeps ({n} line{'s' if n != 1 else ''} x up, "
              f"down; {product.sizes['step']} steps each along {product.attrs['sweep_axis']}), "
              f"{len(rows)} jump{'s' if len(rows) != 1 else ''} ("
              + (", ".join(f"{n} {k}" for k, n in sorted(kinds.items())) or "none")
              + f"); {cost.compute:.1f} s compute, {summary['wall']:.1f} s wall "
              f"(products/{SWEEPS})", file=self.out, flush=True)
        return summary
