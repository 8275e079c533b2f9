"""A runaway block is cut by its time budget and recorded; the study goes on (issue 8)."""
import subprocess
import sys

import numpy as np
import xarray as xr

from kernels import status
from study.block import solve_block


def test_zero_budget_records_every_point_as_time_limited():
    r = solve_block(np.linspace(0.5, 2.0, 5), np.array([0.2, 0.4]), np.array([0.01]),
                    time_budget=0.0)
    assert np.all(r["status"][..., 0] == status.TIME_LIMIT)
    assert np.all(r["period"] == 0) and np.all(r["status"][..., 1:] == status.EMPTY)


def test_budget_cuts_a_block_part_way_and_keeps_what_was_solved():
    omega = np.linspace(0.5, 2.5, 400)
    r = solve_block(omega, np.array([0.5]), np.array([0.01]), time_budget=0.3)
    slot0 = r["status"][:, 0, 0, 0]
    cut = slot0 == status.TIME_LIMIT
    assert cut.any() and not cut.all()
    # the cut is a suffix of the upward sweep: everything solved before it is kept
    first_cut = np.argmax(cut)
    assert np.all(cut[first_cut:]) and np.all(slot0[:first_cut] == status.CONVERGED)


def test_generous_budget_changes_nothing():
    omega = np.linspace(1.5, 2.2, 8)
    a = solve_block(omega, np.array([0.5]), np.array([0.01]))
    b = solve_block(omega, np.array([0.5]), np.array([0.01]), time_budget=600.0)
    for name in a:
        np.testing.assert_array_equal(a[name], b[name])


def test_cli_task_timeout_records_time_limited_points(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text('[study]\nname = "cut"\n[grid]\nomega = {start = 0.5, stop = 2.5, num = 40}\n'
                     'sigma = [0.5]\nzeta = [0.01]\n')
    store = tmp_path / "cut.zarr"
    p = subprocess.run([sys.executable, "-m", "scheduler.cli", "run", str(study), "--store",
                        str(store), "--workers", "1", "--task-timeout", "1e-6",
                        "--error-sample", "0"], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "time limit:" in p.stdout
    ds = xr.open_zarr(store)
    assert bool(ds.task_done.all())
    assert int((ds.status == status.TIME_LIMIT).sum()) > 0
    # bad values are refused up front (exit 2)
    q = subprocess.run([sys.executable, "-m", "scheduler.cli", "run", str(study), "--store",
                        str(tmp_path / "x.zarr"), "--task-timeout", "-1"], capture_output=True,
                       text=True, timeout=120)
    assert q.returncode == 2 and "--task-timeout" in q.stderr
