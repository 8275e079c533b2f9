"""benchmarks.run_summary.run_summary reads back what scheduler.doors.report and scheduler.stages.curve_tasks
print: a summary written by their own printers from known figures (and the cluster's start
line) is parsed into those figures."""
from __future__ import annotations

import io

from benchmarks.run_summary import run_summary
from hertzmap.scheduler.stages.curve_tasks import print_curve_summary
from hertzmap.scheduler.doors.report import print_summary

RUN = {"tasks_run": 77, "points": 12397, "wall": 12.34, "workers": 2,
       "points_per_second": 1004.6, "setup": 16.04, "orbits": 33831, "orbits_per_second": 2741.6,
       "failed_slots": 0, "converged_fraction": 1.0, "points_with_orbit": 12397,
       "overhead": 0.061, "compute": 23.17, "per_task": 0.3, "store": "x.zarr",
       "tasks_done_before": 0, "tasks_total": 77, "failed": []}
CURVES = {"complete": True, "compute": 5.0, "vertices_traced": 2478, "curves": 16,
          "curves_failed": 10, "seeds": 884, "vertices": 2478, "codim2": 6, "traced": 27,
          "dropped": 0, "duplicates": 1, "resumed": 0, "wall": 3.57, "warm_up": 0.27,
          "seeding": 1.15, "uncovered": {}, "failed": []}


def _printed(run=RUN, curves=CURVES) -> str:
    out = io.StringIO()
    out.write(f"running 77 tasks (12397 points) on 2 workers; setup {run['setup']:.1f} s; "
              "dashboard: unavailable\n")
    print_summary(run, out)
    if curves is not None:
        print_curve_summary(curves, out)
    return out.getvalue()


def test_the_figures_of_a_run_with_curves():
    got = run_summary(_printed())
    assert got == {"setup": 16.0, "wall": 12.34, "compute": 23.17, "curves": 3.57}


def test_a_run_without_curves_has_none():
    got = run_summary(_printed(curves=None))
    assert got["curves"] is None and got["wall"] == 12.34
