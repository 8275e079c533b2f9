"""The subharmonic thresholds in zeta as a stage of a run (the ``thresholds`` output), after
the traced curves: sigma*(zeta) (the lowest point of the 1T flip curve) and sigma**(zeta) (the
lowest point of the isola's 2T fold curve, with the isola's join traced from each of its
vertices), each continued over the study's zeta range by one task
(study.solve.thresholds.star_threshold, double_star_threshold). The commit rule: once both
have returned, the client writes the product ``products/thresholds``
(study.products.damping.thresholds_dataset); a run killed before that computes both again.
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np

from hertzmap.scheduler.stages.stage import Stage, Task, TaskRunner
from hertzmap.scheduler.store import (TRACED_CURVES, has_run_product, list_products,
                                      read_product, write_product)
from hertzmap.study.products.damping import isola_start_of, thresholds_dataset
from hertzmap.study.products.results import open_store

#: the product the stage writes
THRESHOLDS = "thresholds"


def threshold_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One threshold continued in zeta (runs on a worker): ``spec["which"]`` "star" or
    "double_star", the study's zeta values, the isola's start (double_star) and the
    integration options."""
    from hertzmap.study.solve import thresholds as th

    t0 = time.perf_counter()
    if spec["which"] == "star":
        result = th.star_threshold(spec["zetas"], **spec["options"])
    else:
        result = th.double_star_threshold(spec["zetas"], spec["start"], **spec["options"])
    return {"result": result, "seconds": time.perf_counter() - t0}


class ThresholdStage(Stage):
    """The thresholds stage of one run of a study into its (locked) store."""

    name = "thresholds"

    def pending(self) -> bool:
        return THRESHOLDS in self.study.outputs and not has_run_product(
            self.store.path, THRESHOLDS, self.study.hash)

    def run(self, runner: TaskRunner) -> dict[str, Any]:
        """Continue both thresholds in zeta, write products/thresholds. Returns the stage's
        summary (also printed)."""
        t0 = time.perf_counter()
        zetas = np.sort(np.asarray(self.study.axis("zeta"), float))
        traced = (read_product(self.store.path, TRACED_CURVES)
                  if TRACED_CURVES in list_products(self.store.path) else None)
        options = {k: self.options[k] for k in ("exponent", "model", "rtol")}
        tasks = [Task(self.key("star"), {"which": "star", "zetas": zetas, "options": options}),
                 Task(self.key("double_star"), {"which": "double_star", "zetas": zetas,
                                                "start": isola_start_of(traced),
                                                "options": options})]
        got: dict[str, Any] = {}
        cost = runner.map(self.name, threshold_task, tasks,
                          lambda task, res: got.update({task.spec["which"]: res["result"]}),
                          unit="tasks")
        summary: dict[str, Any] = {"compute": cost.compute, "failed": cost.failed,
                                   "complete": not cost.failed}
        if cost.failed:
            print(f"thresholds: {len(cost.failed)} task(s) failed ({cost.failed[0][1]}); rerun "
                  "the same command to retry them", file=self.out, flush=True)
            return summary
        product = thresholds_dataset(open_store(self.store.path), got["star"],
                                     got["double_star"])
        with self.interrupt.critical():
            write_product(self.store.path, THRESHOLDS, product, lock=False)
            self.store.add_history(f"{self.command}: thresholds: sigma* and sigma** continued "
                                   f"in zeta ({product.attrs['maps']} period maps)")
        summary.update(
            star_vertices=int(product.sizes.get("star_vertex", 0)),
            double_star_vertices=int(product.sizes.get("double_star_vertex", 0)),
            joins=int(product.sizes.get("join_vertex", 0)),
            star_ends=product.attrs["hertzmap_star_ends"],
            double_star_ends=product.attrs["hertzmap_double_star_ends"],
            wall=time.perf_counter() - t0)
        print(f"thresholds: sigma*(zeta) {summary['star_vertices']} vertices (ends: "
              f"{summary['star_ends']}), sigma**(zeta) {summary['double_star_vertices']} "
              f"(ends: {summary['double_star_ends']}), {summary['joins']} joins; "
              f"{cost.compute:.1f} s compute, {summary['wall']:.1f} s wall "
              f"(products/{THRESHOLDS})", file=self.out, flush=True)
        return summary
