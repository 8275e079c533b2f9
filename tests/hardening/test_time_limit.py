"""A runaway task is cut by its time budget and recorded; the study goes on (the command line
and hostile grids)."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import xarray as xr

from hertzmap.kernels import status
from hertzmap.study.solve.block import solve_block


def test_cli_task_timeout_records_time_limited_points(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text('[study]\nname = "cut"\n[grid]\nomega = {start = 0.5, stop = 2.5, num = 40}\n'
                     'sigma = [0.5]\nzeta = [0.01]\n')
    store = tmp_path / "cut.zarr"
    p = subprocess.run([sys.executable, "-m", "hertzmap.scheduler.doors.cli", "run", str(study), "--store",
                        str(store), "--workers", "1", "--task-timeout", "1e-6",
                        "--error-sample", "0"], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "time limit:" in p.stdout
    ds = xr.open_zarr(store)
    assert bool(ds.task_done.all())
    assert int((ds.status == status.TIME_LIMIT).sum()) > 0
    # bad values are refused up front (exit 2)
    q = subprocess.run([sys.executable, "-m", "hertzmap.scheduler.doors.cli", "run", str(study), "--store",
                        str(tmp_path / "x.zarr"), "--task-timeout", "-1"], capture_output=True,
                       text=True, timeout=120)
    assert q.returncode == 2 and "--task-timeout" in q.stderr


def test_hostile_grid_every_point_gets_a_status_in_bounded_time():
    """Corners of the parameter space through the block solver: a status for every point."""
    import time
    omega = np.array([0.05, 0.3, 1.0, 1.999, 2.0, 10.0])
    sigma = np.array([0.0, 1e-8, 3.0, 10.0])
    zeta = np.array([0.0, 1e-4, 10.0])
    t0 = time.perf_counter()
    r = solve_block(omega, sigma, zeta, time_budget=300.0)
    assert time.perf_counter() - t0 < 300.0
    slot0 = r["status"][..., 0]
    assert np.all(np.isin(slot0, list(status.NAMES))) and not np.any(slot0 == status.EMPTY)
    conv = r["status"] == status.CONVERGED
    # every converged slot is a genuine orbit: Liouville on its stored multipliers
    T = 2 * np.pi / omega[:, None, None, None] * r["period"]
    det = (r["multipliers"][..., 0] * r["multipliers"][..., 1]).real
    expected = np.exp(-2 * zeta[None, None, :, None] * T)
    # what a 2x2 determinant can resolve: products of entries of M, of size max|mu|^2
    scale = np.maximum(expected, np.abs(r["multipliers"]).max(axis=-1) ** 2)
    assert np.all(np.abs(det - expected)[conv] <= 1e-6 * scale[conv])
