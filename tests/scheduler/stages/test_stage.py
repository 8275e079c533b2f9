"""scheduler.stages.stage: the one runner (tasks committed once each, a task on a lost worker counted as
run again, failures recorded, each stage's cost) and the recipe of docs/architecture.md's
"Where to add" for a new stage, followed here: one declaration in scheduler.run.STAGES plus
its pure function, and a run computes it, resumes it, costs it."""
from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hertzmap.scheduler.interrupt import DeferInterrupt
from hertzmap.scheduler.stages.stage import Stage, Task, TaskRunner, stage_costs_line
from tests.helpers import placeholder_run


def _square(spec: dict) -> dict:
    return {"value": spec["x"] ** 2, "seconds": 0.001}


def _fails_on_three(spec: dict) -> dict:
    if spec["x"] == 3:
        raise ValueError("three is refused")
    return {"value": spec["x"], "seconds": 0.0}


def _dies_once(spec: dict) -> dict:
    """Kills its worker process the first time (a marker file says it did), then returns."""
    import time

    marker = Path(spec["marker"])
    if spec["x"] == 0 and not marker.exists():
        marker.write_text("died")
        os._exit(1)
    time.sleep(0.05)
    return {"value": spec["x"], "seconds": 0.05}


def test_each_result_is_committed_once_and_the_stage_costed(client):
    runner = TaskRunner(client, DeferInterrupt(), io.StringIO())
    got: dict[int, int] = {}
    tasks = [Task(f"test-square-{x}", {"x": x}) for x in range(6)]
    cost = runner.map("squares", _square, tasks,
                      lambda task, res: got.setdefault(task.spec["x"], res["value"]))
    assert got == {x: x * x for x in range(6)}
    assert cost.tasks == 6 and cost.compute == pytest.approx(0.006) and not cost.failed
    assert cost.reruns == 0 and cost.workers_lost == 0
    assert runner.costs["squares"].tasks == 6
    line = stage_costs_line(runner.costs)
    assert line.startswith("stages: squares 6 tasks") and line.endswith("no worker lost")


def test_a_failed_task_is_recorded_not_committed(client):
    runner = TaskRunner(client, DeferInterrupt(), io.StringIO())
    got = []
    cost = runner.map("picky", _fails_on_three, [Task(f"test-picky-{x}", {"x": x})
                                                 for x in range(5)],
                      lambda task, res: got.append(res["value"]))
    assert sorted(got) == [0, 1, 2, 4] and cost.tasks == 4
    assert len(cost.failed) == 1 and "three is refused" in cost.failed[0][1]


def test_a_task_on_a_lost_worker_runs_again_and_the_runner_says_so(tmp_path):
    """A worker process dies in the middle of a task: Dask runs it on the other worker, the
    result is committed once, and the stage's cost counts the lost worker and the rerun."""
    from distributed import Client, LocalCluster

    marker = tmp_path / "died"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as c:
        runner = TaskRunner(c, DeferInterrupt(), io.StringIO(), n_workers=2)
        got: list[int] = []
        tasks = [Task(f"test-dies-{x}", {"x": x, "marker": str(marker)}) for x in range(4)]
        cost = runner.map("fragile", _dies_once, tasks, lambda t, res: got.append(res["value"]))
    assert marker.read_text() == "died"
    assert sorted(got) == [0, 1, 2, 3] and cost.tasks == 4 and not cost.failed
    assert cost.workers_lost == 1 and cost.reruns >= 1
    assert "ran again after 1 lost worker(s) (fragile" in stage_costs_line(runner.costs)


def test_a_window_of_tasks_shipped_one_by_one(client):
    runner = TaskRunner(client, DeferInterrupt(), io.StringIO())
    got = {}
    with runner.window("one-by-one", _square) as w:
        for x in range(3):
            w.submit(x, Task(f"test-window-{x}", {"x": x}))
        while w.in_flight:
            for name, res in w.wait():
                got[name] = res["value"]
    assert got == {0: 0, 1: 1, 2: 4} and runner.costs["one-by-one"].tasks == 3


# -- the recipe: a new stage ------------------------------------------------------------------

def longest_period(status: np.ndarray, period: np.ndarray) -> np.ndarray:
    """The stage's pure function: per grid point, the longest period among its converged
    orbits (0 where none converged)."""
    return np.where(status == 0, period, 0).max(axis=-1)


def longest_period_task(spec: dict) -> dict:
    """Runs on a worker: reads its block of the store, calls the pure function."""
    import time

    from hertzmap.scheduler.store import read_region

    t0 = time.perf_counter()
    block = tuple(slice(*s) for s in spec["slices"])
    read = read_region(spec["store"], {"status": block, "period": block})
    return {"longest": longest_period(read["status"], read["period"]),
            "seconds": time.perf_counter() - t0}


class LongestPeriodStage(Stage):
    """One task per block of the grid; the commit rule: the values into an array, written
    as products/longest_period once every block is in."""

    name = "longest_period"

    def pending(self) -> bool:
        from hertzmap.scheduler.store import list_products

        return self.name not in list_products(self.store.path)

    def run(self, runner: TaskRunner) -> dict:
        from hertzmap.scheduler.stages.plan import make_plan
        from hertzmap.scheduler.store import write_product

        plan = make_plan(self.study, self.store.chunks)
        where = str(self.store.path.resolve())
        longest = np.zeros(self.study.shape, np.int16)
        tasks = [Task(self.key(*t.index), {"store": where, "slices": [(s.start, s.stop)
                                                                      for s in t.slices]},
                      t.size) for t in plan.tasks]
        slices = {task.key: t.slices for task, t in zip(tasks, plan.tasks)}

        def commit(task: Task, res: dict) -> None:
            longest[slices[task.key]] = res["longest"]

        runner.map(self.name, longest_period_task, tasks, commit)
        ds = xr.Dataset({"longest_period": (("omega", "sigma", "zeta"), longest)},
                        coords={a: self.study.axis(a) for a in ("omega", "sigma", "zeta")})
        with self.interrupt.critical():
            write_product(self.store.path, self.name, ds, lock=False)
        return {"blocks": len(tasks)}


def test_a_new_stage_is_one_declaration_plus_its_pure_function(tmp_path, client, monkeypatch):
    from hertzmap.scheduler import run as run_module
    from hertzmap.scheduler.store import read_product

    monkeypatch.setattr(run_module, "STAGES", run_module.STAGES + (LongestPeriodStage,))
    out = tmp_path / "s.zarr"
    summary = placeholder_run(out, client)
    assert summary["complete"]
    n_blocks = summary["tasks_total"]
    assert summary["longest_period"] == {"blocks": n_blocks}
    assert summary["stages"]["longest_period"]["tasks"] == n_blocks
    # the product holds what an independent reading of the store gives
    ds = xr.open_zarr(out)
    want = xr.where(ds["status"] == 0, ds["period"], 0).max("solution")
    got = read_product(out, "longest_period")["longest_period"]
    np.testing.assert_array_equal(got.values, want.values)
    assert (got.values > 0).any()
    # a rerun finds it committed: nothing to compute
    again = placeholder_run(out, client)
    assert again["complete"] and "longest_period" not in again.get("stages", {})
