"""The end-of-run summary's overhead line says what it measures (issue 20): with fewer tasks than
workers, the idle workers are not counted as Dask's overhead, and the line says how many idled."""
from __future__ import annotations

import pytest

from hertzmap.scheduler.doors.report import overhead, overhead_line


def _summary(workers, tasks_run, compute, wall):
    """The fields of a run's summary, the overhead computed as scheduler.run computes it."""
    return {"workers": workers, "tasks_run": tasks_run, "compute": compute, "wall": wall,
            "per_task": compute / max(1, tasks_run),
            "overhead": overhead(compute, wall, workers, tasks_run)}


@pytest.mark.parametrize("workers, tasks_run, compute, wall, expected", [
    (2, 20, 18.0, 10.0, 0.1),       # 1 - 18 / (2 x 10)
    (2, 1, 0.9, 1.0, 0.1),          # one busy worker: 1 - 0.9 / 1, not 1 - 0.9 / 2
    (4, 3, 2.7, 1.0, 0.1),          # three busy of four
])
def test_overhead_is_of_the_busy_workers_time(workers, tasks_run, compute, wall, expected):
    assert overhead(compute, wall, workers, tasks_run) == pytest.approx(expected)


def test_overhead_of_busy_workers_when_every_worker_had_a_task():
    line = overhead_line(_summary(workers=2, tasks_run=20, compute=18.0, wall=10.0))
    # 1 - 18 / (2 x 10) = 10 %
    assert line == ("dask overhead: 10.0 % (task compute 18.00 s over 2 busy workers x 10.00 s "
                    "wall; 900 ms per task)")


@pytest.mark.parametrize("workers, idle", [(2, 1), (4, 3)])
def test_one_task_for_several_workers_counts_one_busy_worker_and_says_the_rest_idled(workers, idle):
    line = overhead_line(_summary(workers=workers, tasks_run=1, compute=0.9, wall=1.0))
    # over the one busy worker: 1 - 0.9 / 1.0 = 10 %, not 1 - 0.9 / (workers x 1.0)
    assert line.startswith("dask overhead: 10.0 % (task compute 0.90 s over 1 busy worker x "
                           "1.00 s wall; 900 ms per task)")
    assert line.endswith(f"; 1 task for {workers} workers, so {idle} stayed idle")


def test_the_certificates_line_keeps_the_worst_of_every_block():
    """The worst certificate over the blocks as they come (converged orbits only, attractor
    slots that hold one), and a line that says so; none without a value."""
    import math

    import numpy as np

    from hertzmap.scheduler.doors.report import certificates_line, worst_certificates

    tally = {"liouville": math.nan, "lyapunov_sum": math.nan, "attractors": 0}
    status = np.array([[0, 0, 1, -1]])
    worst_certificates(tally, {"status": status,
                               "liouville_residual": np.array([[2e-11, 5e-10, 0.3, np.nan]])})
    worst_certificates(tally, {"status": np.array([[0, -1, -1, -1]]),
                               "liouville_residual": np.array([[1e-12, np.nan, np.nan, np.nan]]),
                               "attractor_kind": np.array([[1, 2, 0, 0]]),
                               "lyapunov_sum_error": np.array([[3e-13, 4e-9, np.nan, np.nan]])})
    assert tally == {"liouville": 5e-10, "lyapunov_sum": 4e-9, "attractors": 2}
    line = certificates_line({"liouville_worst": 5e-10, "orbits": 3, "lyapunov_sum_worst": 4e-9,
                              "attractors": 2})
    assert line == ("certificates: Liouville residual <= 5.0e-10 over the 3 orbits (relative, "
                    "|det M - exp(-2 zeta P)|); |lambda1 + lambda2 + 2 zeta| <= 4.0e-09 over the "
                    "2 census attractors")
    assert certificates_line({"liouville_worst": math.nan, "orbits": 0}) is None
