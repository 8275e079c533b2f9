"""Hardening, faults: Ctrl-C, a scheduler that disappears, two clients on one store, readers
during a write, damaged stores. Uses the placeholder solver (tests.helpers;
$HERTZMAP_PLACEHOLDER_DELAY slows it) so that timings are controlled; every disturbed run must
end in a store identical to the undisturbed one."""
from __future__ import annotations

from pathlib import Path
import os
import shlex
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import xarray as xr

from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.cluster.clusters import ClusterSpec
from hertzmap.scheduler.stages.plan import make_plan
from hertzmap.scheduler.run import RunOptions, run_study
from hertzmap.scheduler.store import Store, lock_path, staged_blocks
from hertzmap.study.schema import STORE_FORMAT
from hertzmap.study.spec import parse_study
from tests.helpers import (PLACEHOLDER, done_count, free_port, hertzmap_cmd, subprocess_env, trim_slots,
                           align_slots, wait_until)


FAULTS_STUDY = """
[study]
name = "faults"
[grid]
omega = {start = 0.5, stop = 2.5, num = 9}
sigma = [0.1, 0.3, 0.5, 0.7, 0.9, 1.1]
zeta = [0.01, 0.05]
[products]
outputs = ["orbits", "measures", "force_harmonics", "diagnostics"]
"""


pytestmark = pytest.mark.slow

# 12 tasks of one (sigma, zeta) line each
N_TASKS = 12
DELAY = "0.04"           # seconds per point: ~0.36 s per task


def base_args(path: Path, store: Path) -> list[str]:
    return ["run", str(path), "--store", str(store), "--solver", PLACEHOLDER,
            "--task-seconds", "0.001", "--error-sample", "0"]


def data(path: Path) -> xr.Dataset:
    ds = xr.open_zarr(path).load()
    ds.attrs = {}
    return ds


@pytest.fixture(scope="module")
def study_path(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("faults") / "faults.toml"
    p.write_text(FAULTS_STUDY)
    return p


@pytest.fixture(scope="module")
def reference(study_path, tmp_path_factory) -> Path:
    store = tmp_path_factory.mktemp("ref") / "ref.zarr"
    assert main(base_args(study_path, store) + ["--workers", "1"]) == 0
    assert Store(store).done_mask().sum() == N_TASKS
    return store


def _stop(procs):
    for p in reversed(procs):
        if p.poll() is None:
            p.terminate()
    for p in procs:
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            p.kill()


# -- Ctrl-C -------------------------------------------------------------------------------------

def test_ctrl_c_stops_cleanly_and_rerun_completes_identical(study_path, reference, tmp_path):
    store = tmp_path / "int.zarr"
    env = subprocess_env(HERTZMAP_PLACEHOLDER_DELAY=DELAY)
    cmd = hertzmap_cmd(*base_args(study_path, store), "--workers", "1")
    p = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_until(lambda: done_count(store) >= 2 or p.poll() is not None, 120, "two tasks")
        p.send_signal(signal.SIGINT)                       # Ctrl-C to the client only
        out, err = p.communicate(timeout=90)
    finally:
        _stop([p])
    assert p.returncode == 130, err
    # said once, with the exact command to run again (its --store included)
    resume = "to resume, run again: hertzmap " + shlex.join(cmd[3:])
    assert err.count("interrupted") == 1 and resume in err, err
    assert "Traceback" not in err
    done = done_count(store)
    assert 2 <= done < N_TASKS, f"the interrupt landed after the end ({done} done)"
    assert f"{done}/{N_TASKS} tasks are done and kept in" in err
    assert not lock_path(store).exists()                   # the lock is released
    assert "interrupted with" in xr.open_zarr(store).attrs["history"]
    # consistent: every flagged block holds exactly the reference data
    ref, got = data(reference), trim_slots(data(store))
    s = parse_study(FAULTS_STUDY, default_name="faults")
    for t in make_plan(s, Store(store).chunks).tasks:
        if got.task_done.values[t.index]:
            xr.testing.assert_identical(got.isel(omega=t.slices[0], sigma=t.slices[1],
                                                 zeta=t.slices[2]).drop_vars("task_done"),
                                        ref.isel(omega=t.slices[0], sigma=t.slices[1],
                                                 zeta=t.slices[2]).drop_vars("task_done"))
    # blocks staged after the flags were read (tasks in flight finish): packed on resume
    staged = len(staged_blocks(store))
    r = subprocess.run(cmd, env=subprocess_env(), capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert f"{done + staged}/{N_TASKS} tasks already done" in r.stdout
    xr.testing.assert_identical(data(store), data(reference))


# -- the scheduler disappears --------------------------------------------------------------------

def test_scheduler_killed_mid_study_leaves_a_resumable_store(study_path, reference, tmp_path):
    env = subprocess_env(HERTZMAP_PLACEHOLDER_DELAY=DELAY)

    def start_cluster():
        port = free_port()
        addr = f"tcp://127.0.0.1:{port}"
        sched = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
             "--port", str(port), "--no-dashboard"],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        worker = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", addr, "--nworkers", "1",
             "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1"],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        return addr, [sched, worker]

    store = tmp_path / "sched.zarr"
    addr, procs = start_cluster()
    try:
        cmd = hertzmap_cmd(*base_args(study_path, store), "--scheduler", addr)
        p = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
        procs.append(p)
        wait_until(lambda: done_count(store) >= 2 or p.poll() is not None, 120, "two tasks")
        procs[0].kill()                                    # the scheduler disappears
        out, err = p.communicate(timeout=180)
    finally:
        _stop(procs)
    done = done_count(store)
    assert 2 <= done < N_TASKS, f"the kill landed after the end ({done} done)"
    assert p.returncode == 1, (out, err)
    assert "lost the Dask scheduler" in err and "run again to resume: hertzmap run" in err, err
    assert "Traceback" not in err, err
    assert not lock_path(store).exists()
    # restart a scheduler and resume: identical to the undisturbed run (blocks staged but not
    # packed when the scheduler went are packed, not recomputed)
    staged = len(staged_blocks(store))
    addr, procs = start_cluster()
    try:
        r = subprocess.run(hertzmap_cmd(*base_args(study_path, store), "--scheduler", addr),
                           env=subprocess_env(), capture_output=True, text=True, timeout=180)
    finally:
        _stop(procs)
    assert r.returncode == 0, r.stderr
    assert f"{done + staged}/{N_TASKS} tasks already done" in r.stdout
    xr.testing.assert_identical(data(store), data(reference))


def test_unreachable_scheduler_creates_nothing(study_path, tmp_path):
    store = tmp_path / "none.zarr"
    port = free_port()                  # nobody listens there
    r = subprocess.run(hertzmap_cmd(*base_args(study_path, store), "--scheduler",
                                    f"tcp://127.0.0.1:{port}"),
                       env=subprocess_env(DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT="3s"),
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    assert "--scheduler" in r.stderr and "cannot connect" in r.stderr
    assert sorted(os.listdir(tmp_path)) == []


# -- concurrency ---------------------------------------------------------------------------------

def test_second_client_on_the_same_store_is_refused(study_path, reference, tmp_path):
    """The first client holds its lock with one task done and the rest held at a gate (an
    event, not a delay: on a loaded machine a delay let it finish before the second started);
    the second is refused, then the gate opens and the first completes."""
    store = tmp_path / "two.zarr"
    gate = tmp_path / "gate"
    cmd = hertzmap_cmd(*base_args(study_path, store), "--workers", "1")
    first = subprocess.Popen(cmd, env=subprocess_env(HERTZMAP_PLACEHOLDER_HOLD=str(gate)),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_until(lambda: done_count(store) >= 1 or first.poll() is not None, 120, "a first task")
        assert first.poll() is None and lock_path(store).exists()
        before = done_count(store)
        second = subprocess.run(cmd, env=subprocess_env(), capture_output=True, text=True,
                                timeout=120)
        assert second.returncode == 2, second.stderr
        assert "in use by another hertzmap client" in second.stderr
        assert f"pid {first.pid}" in second.stderr
        assert done_count(store) == before
        gate.touch()
        out, err = first.communicate(timeout=120)
    finally:
        gate.touch()
        _stop([first])
    assert first.returncode == 0, err
    xr.testing.assert_identical(data(store), data(reference))


def test_readers_see_only_completed_tasks_as_done(reference, tmp_path):
    from distributed import Client, LocalCluster

    store = tmp_path / "read.zarr"
    s = parse_study(FAULTS_STUDY, default_name="faults")
    ref = data(reference)
    opts = RunOptions(store=store, solver=PLACEHOLDER, cluster=ClusterSpec(kind="address"),
                      task_seconds=0.001, error_sample=0)
    os.environ["HERTZMAP_PLACEHOLDER_DELAY"] = "0.02"
    try:
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                          dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as client:
            result: dict = {}
            th = threading.Thread(target=lambda: result.update(run_study(s, opts, client=client)))
            th.start()
            checks = partial = 0
            while th.is_alive() or not checks:
                if not store.exists() or not (store / "zarr.json").exists():
                    time.sleep(0.01)
                    continue
                try:
                    ds = xr.open_zarr(store)
                except Exception:          # the template is being written
                    ds = None
                if ds is None or "task_done" not in ds:
                    time.sleep(0.01)
                    continue
                flags = ds.task_done.values
                c = ds.attrs["hertzmap_chunk_shape"]
                for idx in zip(*np.nonzero(flags)):
                    sl = {d: slice(i * n, (i + 1) * n) for d, i, n in zip(("omega", "sigma", "zeta"), idx, c)}
                    block = ref.isel(sl).drop_vars("task_done").drop_attrs()
                    xr.testing.assert_identical(
                        align_slots(ds.isel(sl).drop_vars("task_done").load().drop_attrs(),
                                    block), block)
                checks += 1
                partial += 0 < flags.sum() < flags.size
                time.sleep(0.05)
            th.join()
    finally:
        del os.environ["HERTZMAP_PLACEHOLDER_DELAY"]
    assert result["complete"]
    assert partial >= 1, "never saw the store half written"
    xr.testing.assert_identical(data(store), ref)


# -- damaged stores ------------------------------------------------------------------------------

def test_damaged_chunks_are_detected_and_recomputed(study_path, reference, tmp_path, capsys):
    import shutil

    store = tmp_path / "dmg.zarr"
    shutil.copytree(reference, store)
    assert main(["status", str(store), "--check"]) == 0
    assert "0 damaged task(s): ok" in capsys.readouterr().out
    (store / "q0" / "c" / "0" / "0" / "0" / "0").unlink()                  # missing chunk
    f = store / "status" / "c" / "0" / "1" / "0" / "0"
    f.write_bytes(f.read_bytes()[: max(1, f.stat().st_size // 2)])        # truncated chunk
    g = store / "multipliers" / "c" / "0" / "2" / "1" / "0" / "0"
    g.write_bytes(b"garbage")                                              # corrupted chunk
    h = store / "task_done" / "c" / "0" / "3" / "0"
    h.write_bytes(h.read_bytes()[:1] if h.stat().st_size > 1 else b"")     # truncated flag
    assert main(["status", str(store), "--check"]) == 1
    out = capsys.readouterr().out
    assert "4 damaged task(s)" in out
    assert "0-0-0: q0: chunk file missing" in out and "status: chunk unreadable" in out
    # resume: the damaged tasks are re-queued, never mixed; the result is the reference
    assert main(base_args(study_path, store) + ["--workers", "1"]) == 0
    captured = capsys.readouterr()
    assert "4 task(s) flagged done have damaged chunks" in captured.err
    assert "4 tasks (" in captured.out                        # only those are recomputed
    xr.testing.assert_identical(data(store), data(reference))
    assert "damaged task(s) re-queued" in xr.open_zarr(store).attrs["history"]
    assert main(["status", str(store), "--check"]) == 0


def test_store_of_another_version_or_study_is_refused(study_path, reference, tmp_path, capsys):
    import json
    import shutil

    store = tmp_path / "ver.zarr"
    shutil.copytree(reference, store)
    meta = store / "zarr.json"
    doc = json.loads(meta.read_text())
    doc["attributes"]["hertzmap_store_format"] = 99
    meta.write_text(json.dumps(doc))
    before = sorted((p.name, p.stat().st_mtime_ns) for p in store.rglob("*"))
    assert main(base_args(study_path, store) + ["--workers", "1"]) == 2
    assert f"is in store format 99, this hertzmap reads format {STORE_FORMAT}" in capsys.readouterr().err
    # another study's store (edited file)
    doc["attributes"]["hertzmap_store_format"] = STORE_FORMAT
    meta.write_text(json.dumps(doc))
    before = sorted((p.name, p.stat().st_mtime_ns) for p in store.rglob("*"))
    other = tmp_path / "other.toml"
    other.write_text(FAULTS_STUDY.replace("num = 9", "num = 11"))
    assert main(base_args(other, store) + ["--workers", "1"]) == 2
    assert "holds another study" in capsys.readouterr().err
    assert sorted((p.name, p.stat().st_mtime_ns) for p in store.rglob("*")) == before
    # a store whose recorded study does not match its hash
    doc["attributes"]["hertzmap_study_toml"] = FAULTS_STUDY.replace("zeta = [0.01, 0.05]", "zeta = [0.02, 0.05]")
    meta.write_text(json.dumps(doc))
    assert main(["status", str(store), "--check"]) == 2
    assert "does not match its hash" in capsys.readouterr().err


def test_a_store_of_format_1_is_refused_everywhere_and_left_untouched(tmp_path, capsys):
    """A real store of format 1 (written by hertzmap before 2026-11-28, tests/data: at most
    solver.max_solutions orbits a point, orbits_dropped): run, plot, basins and the products'
    reader refuse it with its format and what to do; status says so; nothing in it changes."""
    import zipfile

    from hertzmap.study import products as P
    from hertzmap.study.schema import StoreFormatError

    data = Path(__file__).resolve().parent.parent / "data"
    with zipfile.ZipFile(data / "store_format1.zip") as z:
        z.extractall(tmp_path)
    store = tmp_path / "format1.zarr"
    study = tmp_path / "f1.toml"
    # the same study without the key format 2 refuses
    study.write_text((data / "store_format1.toml").read_text().replace("[solver]\nmax_solutions = 2\n", ""))
    before = sorted((str(p), p.stat().st_mtime_ns) for p in store.rglob("*"))
    for args in (["run", str(study), "--store", str(store), "--workers", "1"],
                 ["plot", str(store), "--out", str(tmp_path)],
                 ["basins", str(store), "--omega", "1.9", "--sigma", "0.5", "--grid", "4x4"]):
        assert main(args) == 2, args
        err = capsys.readouterr().err
        assert "store format 1" in err and "--overwrite" in err, (args, err)
        assert "Traceback" not in err
    with pytest.raises(StoreFormatError, match="format 1"):
        P.open_store(store)
    assert main(["status", str(store)]) == 0
    assert "format    " in capsys.readouterr().out
    assert sorted((str(p), p.stat().st_mtime_ns) for p in store.rglob("*")) == before
