"""End to end on Dask with the real block solver: an embedded LocalCluster, an existing
`dask scheduler` + two `dask worker` processes, a worker killed mid-study, the client killed
mid-study and rerun, failed tasks. Every run must give a store identical to the undisturbed
one."""
from __future__ import annotations

from pathlib import Path
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import xarray as xr

from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.cluster.clusters import ClusterSpec
from hertzmap.scheduler.run import RunOptions, run_study
from hertzmap.scheduler.store import Store, lock_path, staged_blocks
from hertzmap.study.schema import VARIABLES, pad_slots
from hertzmap.study.spec import parse_study
from tests.helpers import (assert_same_data, done_count, free_port, hertzmap_cmd,
                           kill_client_mid_study, subprocess_env, wait_until)


E2E_STUDY = """
[study]
name = "e2e"
[grid]
omega = {start = 0.6, stop = 2.4, num = 19}
sigma = [0.1, 0.4, 0.7, 1.0]
zeta = [0.01, 0.05]
[products]
outputs = ["orbits", "measures", "force_harmonics", "diagnostics"]
"""


pytestmark = pytest.mark.slow

# 8 tasks (one omega line each, ~0.2-0.5 s of solver time), 1T and 2T searches
TASK_SECONDS = "0.1"     # one (sigma, zeta) line per task


def open_data(path: Path) -> xr.Dataset:
    ds = xr.open_zarr(path).load()
    ds.attrs = {}
    return ds


def assert_same_store(a: Path, b: Path) -> None:
    da_, db_ = xr.open_zarr(a), xr.open_zarr(b)
    for key in ("hertzmap_study_hash", "hertzmap_study_toml", "hertzmap_chunk_shape"):
        assert da_.attrs[key] == db_.attrs[key], key
    assert_same_data(open_data(a), open_data(b))


@pytest.fixture(scope="module")
def study_path(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("study") / "e2e.toml"
    p.write_text(E2E_STUDY)
    return p


@pytest.fixture(scope="module")
def reference(study_path, tmp_path_factory) -> Path:
    """The undisturbed run: `hertzmap run` on an embedded LocalCluster with 2 workers."""
    store = tmp_path_factory.mktemp("ref") / "ref.zarr"
    t0 = time.perf_counter()
    rc = main(["run", str(study_path), "--store", str(store), "--workers", "2",
               "--task-seconds", TASK_SECONDS])
    assert rc == 0
    # budget: < 60 s on an idle 2-core machine; generous bound for busy CI machines and cold
    # numba caches (each new worker process compiles the kernels when their sources changed)
    assert time.perf_counter() - t0 < 180
    return store


# -- without the real solver (placeholder with the same contract) ------------------------------

SMALL = """
[study]
name = "small"
[grid]
omega = {start = 0.5, stop = 2.5, num = 9}
sigma = [0.2, 0.5, 0.9]
zeta = 0.02
"""


def test_local_cluster_end_to_end(reference):
    ds = xr.open_zarr(reference)
    assert bool(ds.task_done.all()) and ds.task_done.size == 8
    status = ds.status.values
    converged = status == 0
    assert converged[..., 0].mean() > 0.9           # slot 0: the 1T orbit, nearly everywhere
    assert (ds.period.values[converged] > 0).all()
    assert (ds.period.values == 2).any()            # some 2T orbits
    assert np.isfinite(ds.q0.values[converged]).all()
    empty = status == -1
    assert np.isnan(ds.q0.values[empty]).all() and not ds.stable.values[empty].any()
    # what the store says matches what the solver returns for one line, solved here
    from hertzmap.study.solve.block import solve_block
    study = parse_study(E2E_STUDY, default_name="e2e")
    line = solve_block(study.axis("omega"), study.axis("sigma")[1:2], study.axis("zeta")[:1],
                       **study.solver_kwargs())
    # the line's slots in whole chunks, the store's as many as the point that holds most
    line = pad_slots(line, {"solution": ds.sizes["solution"], "attractor": ds.sizes["attractor"]})
    for name in ("period", "status", "q0", "v0", "multipliers", "force_harmonics", "residual"):
        got = ds[name].values[:, 1:2, :1]
        np.testing.assert_array_equal(got, line[name][:, :, :, :got.shape[3]], err_msg=name)
        rest = line[name][:, :, :, got.shape[3]:]
        assert (rest == VARIABLES[name].fill).all() or np.isnan(rest).all(), name


def test_existing_scheduler_two_workers(study_path, reference, tmp_path):
    """`dask scheduler` and two `dask worker` processes started here, the workers with the
    environment docs/running.md gives them (the trimmed Dask config); the store identical to
    the LocalCluster run's."""
    from hertzmap.scheduler.cluster.clusters import CLUSTER_CONFIG, config_env_lines

    port = free_port()
    env = subprocess_env()
    worker_env = subprocess_env(**dict(line.removeprefix("export ").split("=", 1)
                                       for line in config_env_lines(CLUSTER_CONFIG)))
    procs = []
    try:
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
             "--port", str(port), "--no-dashboard"],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        addr = f"tcp://127.0.0.1:{port}"
        for i in range(2):
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", addr, "--nworkers", "1",
                 "--nthreads", "1", "--no-dashboard", "--name", f"w{i}", "--host", "127.0.0.1"],
                env=worker_env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client
        with Client(addr, timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
        store = tmp_path / "sched.zarr"
        r = subprocess.run(hertzmap_cmd("run", str(study_path), "--store", str(store),
                                        "--scheduler", addr, "--task-seconds", TASK_SECONDS),
                           env=env, capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        assert "on 2 workers" in r.stdout and "dask overhead" in r.stdout
        assert "Traceback" not in r.stdout + r.stderr
        assert_same_store(store, reference)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def test_worker_killed_mid_study(study_path, reference, tmp_path):
    from distributed import Client, LocalCluster

    store = tmp_path / "killed-worker.zarr"
    study = parse_study(E2E_STUDY, default_name="e2e")
    opts = RunOptions(store=store, cluster=ClusterSpec(kind="address"), task_seconds=0.1,
                      error_sample=0)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as client:
        result: dict = {}
        th = threading.Thread(target=lambda: result.update(run_study(study, opts, client=client)))
        th.start()
        wait_until(lambda: done_count(store) >= 1, 60, "a first task")
        victim = sorted(client.scheduler_info()["workers"])[0]
        killed_at = done_count(store)
        client.run(os._exit, 1, workers=[victim], on_error="ignore")
        th.join(120)
        assert not th.is_alive()
    assert killed_at < 8, "the study finished before the worker was killed"
    assert result["complete"] and not result["failed"]
    # the summary says what the kill cost: the lost worker and its task(s), run again
    grid = result["stages"]["grid"]
    assert grid["workers_lost"] == 1 and grid["reruns"] >= 1
    assert_same_store(store, reference)


def test_client_killed_mid_study_then_rerun(study_path, reference, tmp_path):
    store = tmp_path / "killed-client.zarr"
    cmd = hertzmap_cmd("run", str(study_path), "--store", str(store), "--workers", "2",
                       "--task-seconds", TASK_SECONDS, "--error-sample", "0")
    env = subprocess_env()
    done = kill_client_mid_study(cmd, env, store, 2)
    assert 2 <= done < 8, f"kill landed after the end ({done} tasks done)"
    assert lock_path(store).exists()            # stale lock of the dead client
    staged = len(staged_blocks(store))          # staged, not packed: packed by the rerun
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert f"{done + staged}/8 tasks already done" in r.stdout
    assert_same_store(store, reference)
    assert "resumed" in xr.open_zarr(store).attrs["history"]


def test_failed_tasks_exit_1_then_rerun_completes(tmp_path, capsys):
    from tests.helpers import PLACEHOLDER
    p = tmp_path / "small.toml"
    p.write_text(SMALL)
    store = tmp_path / "small.zarr"
    args = ["run", str(p), "--store", str(store), "--workers", "1", "--task-seconds", "0.01",
            "--error-sample", "0"]
    assert main(args + ["--solver", "tests.helpers:failing_solve_block"]) == 1
    out = capsys.readouterr().out
    assert "FAILED tasks: 1" in out and "FloatingPointError" in out
    done = Store(store).done_mask()
    assert done.sum() == done.size - 1
    assert main(args + ["--solver", PLACEHOLDER]) == 0
    assert "2/3 tasks already done" in capsys.readouterr().out
    assert Store(store).done_mask().all()


ONE_POINT = """
[study]
name = "one"
[grid]
omega = 1.9
sigma = 0.5
zeta = 0.01
[products]
outputs = ["orbits", "measures"]
"""


def test_a_small_study_runs_in_process_and_stores_what_a_cluster_run_stores(tmp_path, capsys):
    """A one-point study with nothing said of where to run: no worker process is started
    (said on the first line and in the summary's), and the store (grid, census, atlas, error
    estimate's sample) is the one a process cluster writes, as scripts/compare_stores.py
    compares them; --workers, --cluster local and --scheduler still choose."""
    p = tmp_path / "one.toml"
    p.write_text(ONE_POINT)
    small, cluster = tmp_path / "small.zarr", tmp_path / "cluster.zarr"
    env = subprocess_env()
    r = subprocess.run(hertzmap_cmd("run", str(p), "--store", str(small)), env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].startswith("running 1 tasks (1 points) in-process"), r.stdout
    assert next(ln for ln in lines if ln.startswith("done:")).startswith(
        "done: 1 tasks, 1 points in "), r.stdout
    assert "in-process" in next(ln for ln in lines if ln.startswith("done:"))
    assert "Traceback" not in r.stdout + r.stderr
    r = subprocess.run(hertzmap_cmd("run", str(p), "--store", str(cluster), "--workers", "1"),
                       env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "on 1 workers" in r.stdout.splitlines()[0] and "in-process" not in r.stdout
    same = subprocess.run([sys.executable, str(Path(__file__).parents[2] / "scripts" /
                                               "compare_stores.py"), str(small), str(cluster)],
                          env=env, capture_output=True, text=True, timeout=120)
    assert same.returncode == 0 and "identical:" in same.stdout, same.stdout + same.stderr
    for where, expected in ((["--cluster", "local"], "local cluster"),
                            (["--workers", "2"], "local cluster: 2"),
                            ([], "in-process")):
        assert main(["run", str(p), "--store", str(tmp_path / "dry.zarr"), "--dry-run",
                     *where]) == 0
        assert f"runs on      {expected}" in capsys.readouterr().out, where
