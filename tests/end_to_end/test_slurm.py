"""`hertzmap run --cluster slurm` against a real Slurm on this machine (munged, slurmctld and
slurmd started by tests/end_to_end/slurm_cluster.py): the worker jobs are sbatch-submitted,
run by slurmd, and connect back to the client's scheduler.

* a study run through two worker jobs gives the same store as on the embedded LocalCluster;
* a worker job cancelled with scancel mid-study, and one ended by Slurm's time limit, lose
  nothing (the study finishes; an ended job is replaced);
* a partition, memory, core count, walltime or sbatch option that Slurm refuses, or an option
  dask-jobqueue does not take: a message naming the option, exit code 2, nothing written.

Skipped, with the reason, where Slurm is not installed or its daemons cannot start (not
root, ...); .ci/run installs it when it can.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
import xarray as xr

from tests.end_to_end.slurm_cluster import ACCOUNT, SlurmUnavailable, start_slurm
from tests.helpers import (REPO, assert_same_data, done_count, hertzmap_cmd, subprocess_env,
                           wait_until)
from hertzmap.scheduler.doors.cli import main

pytestmark = pytest.mark.slow

# 24 tasks (an omega line of 21 points each), 504 grid points, 1T and 2T orbits, the census at
# every point: 10-15 s on two workers, long enough to cancel a job between the first task and
# the last (the study is four times smaller than before issue 50: every Slurm test that runs
# the real solver runs it, and the reference once more)
STUDY = """
[study]
name = "slurm-e2e"
[grid]
omega = {start = 0.5, stop = 2.5, num = 21}
sigma = {start = 0.1, stop = 1.2, num = 12}
zeta = [0.01, 0.03]
[products]
outputs = ["orbits", "measures", "force_harmonics", "diagnostics"]
"""
TASK_SECONDS = "0.25"


def _task_count(text: str, task_seconds: float) -> int:
    """How many tasks hertzmap plans for a study (scheduler.stages.plan, as the run does)."""
    from hertzmap.scheduler.stages.plan import choose_chunks, make_plan
    from hertzmap.study.spec import parse_study

    study = parse_study(text, default_name="x")
    return len(make_plan(study, choose_chunks(study, task_seconds)).tasks)


N_TASKS = _task_count(STUDY, float(TASK_SECONDS))

# the placeholder solver (tests/helpers.py) sleeping 25 ms per grid point: 72 tasks of 1 s,
# 72 s of sleep and almost no CPU, about 45 s on two workers, one of them lost for a while:
# longer than Slurm's time-limit check takes to come (every 30 s) plus the lost job's
# replacement
SLOW = """
[study]
name = "slurm-slow"
[grid]
omega = {start = 0.5, stop = 2.5, num = 40}
sigma = {start = 0.1, stop = 1.2, num = 9}
zeta = {start = 0.01, stop = 0.08, num = 8}
"""
SLOW_TASKS = _task_count(SLOW, 0.01)
SLOW_DELAY = "0.025"
PLACEHOLDER = "tests.helpers:placeholder_solve_block"


@pytest.fixture(scope="module")
def slurm():
    try:
        import dask_jobqueue  # noqa: F401  (the test needs it installed)
    except ImportError:
        pytest.skip("Slurm test skipped: dask-jobqueue is not installed (pip install -e '.[test]')")
    try:
        cluster = start_slurm()
    except SlurmUnavailable as exc:
        pytest.skip(f"Slurm test skipped: {exc}")
    print(f"\nslurm: node {cluster.node} ({cluster.cpus} CPUs, {cluster.memory_mb} MB), "
          f"partition {cluster.partition}, accounts: "
          f"{cluster.accounting or 'enforced (slurmdbd)'}, SLURM_CONF={cluster.conf}", flush=True)
    try:
        yield cluster
    finally:
        cluster.stop()
        shutil.rmtree(cluster.root, ignore_errors=True)


@pytest.fixture(autouse=True)
def no_jobs_left(request):
    """Every test starts on an idle node and leaves no job behind (a failed test too)."""
    if "slurm" not in request.fixturenames:
        yield
        return
    cluster = request.getfixturevalue("slurm")
    cluster.cancel_all()
    cluster.wait_idle()
    yield
    left = cluster.jobs("PENDING,RUNNING,CONFIGURING,SUSPENDED")
    cluster.cancel_all()
    assert not left, f"hertzmap left worker jobs behind: {left}"


@pytest.fixture(scope="module")
def study_path(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("study") / "slurm-e2e.toml"
    p.write_text(STUDY)
    return p


@pytest.fixture(scope="module")
def reference(study_path, tmp_path_factory) -> Path:
    """The undisturbed run on the embedded LocalCluster (2 workers)."""
    store = tmp_path_factory.mktemp("ref") / "ref.zarr"
    r = subprocess.run(hertzmap_cmd("run", str(study_path), "--store", str(store),
                                    "--workers", "2", "--task-seconds", TASK_SECONDS),
                       env=subprocess_env(), capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return store


def open_data(path: Path) -> xr.Dataset:
    ds = xr.open_zarr(path).load()
    ds.attrs = {}          # history (timestamps, commands), error estimate, wall time
    return ds


def assert_same_store(a: Path, b: Path) -> None:
    da_, db_ = xr.open_zarr(a), xr.open_zarr(b)
    for key in ("hertzmap_study_hash", "hertzmap_study_toml", "hertzmap_chunk_shape",
                "hertzmap_code_hash"):
        assert da_.attrs[key] == db_.attrs[key], key
    assert_same_data(open_data(a), open_data(b))


def slurm_options(slurm, logs: Path, *extra: str) -> list[str]:
    """The options of docs/running.md's Slurm example, on this machine's partition. The
    jobs get none of the client's environment (--export=NONE): what they need comes from
    hertzmap's job script."""
    opts = [f"queue={slurm.partition}", f"account={ACCOUNT}", "walltime=00:10:00", "memory=2GB",
            f"log_directory={logs}", 'job_extra_directives=["--export=NONE"]',
            # the scheduler, its dashboard and the workers on the loopback only
            'scheduler_options={host = "127.0.0.1", dashboard_address = "127.0.0.1:0"}',
            'worker_extra_args=["--host", "127.0.0.1"]', *extra]
    return [arg for o in opts for arg in ("--cluster-option", o)]


def run_on_slurm(slurm, study: Path, store: Path, cwd: Path, *args: str,
                 **env: str) -> subprocess.Popen:
    """`hertzmap run STUDY --cluster slurm --workers 2 ARGS` in the folder ``cwd``."""
    cwd.mkdir(exist_ok=True)
    cmd = hertzmap_cmd("run", str(study), "--store", str(store), "--cluster", "slurm",
                       "--workers", "2", *args)
    return subprocess.Popen(cmd, env=subprocess_env(**slurm.env, **env), cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def finish(p: subprocess.Popen, timeout: float = 240) -> tuple[int, str, str]:
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        p.kill()
        out, err = p.communicate()
        raise AssertionError(f"hertzmap run did not end within {timeout} s:\n{out}\n{err}")
    return p.returncode, out, err


def submitted_jobs(out: str) -> list[str]:
    """Job ids from the run's 'hertzmap: worker job(s) N, M submitted' lines, in order."""
    found = re.findall(r"^hertzmap: worker job(?:\(s\))? ([\d, ]+) submitted", out, re.M)
    return [job for group in found for job in re.findall(r"\d+", group)]


def test_study_through_slurm_jobs_is_identical_to_local(slurm, study_path, reference, tmp_path):
    store = tmp_path / "slurm.zarr"
    logs = tmp_path / "job-logs"
    cwd = tmp_path / "client-cwd"
    t0 = time.perf_counter()
    code, out, err = finish(run_on_slurm(slurm, study_path, store, cwd,
                                         "--task-seconds", TASK_SECONDS,
                                         *slurm_options(slurm, logs)))
    wall = time.perf_counter() - t0
    assert code == 0, f"{out}\n{err}"
    assert "Traceback" not in out + err
    # (the run starts with the first worker that connects; the other job's joins when up)
    assert re.search(rf"^running {N_TASKS} tasks .* on [12] workers", out, re.M), out
    assert_same_store(store, reference)
    jobs = submitted_jobs(out)
    assert len(jobs) == 2, out
    # the two jobs ran on slurmd and ended when the client closed the cluster
    for job in jobs:
        assert slurm.job_state(job) in ("CANCELLED", "COMPLETED"), slurm.job_state(job)
    # what the jobs got from hertzmap (their script as Slurm stored it): the environment's
    # python, the trimmed Dask config, the client's numba cache, nothing from the cwd
    script = slurm.command("scontrol", "write", "batch_script", jobs[0], "-")
    from hertzmap import kernels
    assert f"{sys.executable} -m distributed.cli.dask_worker" in script
    assert "export DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False" in script
    assert f"export NUMBA_CACHE_DIR={Path(kernels.CACHE_DIR).parent}" in script
    assert "export PYTHONSAFEPATH=1" in script
    assert f"#SBATCH -p {slurm.partition}" in script and "#SBATCH -t 00:10:00" in script
    assert "#SBATCH --export=NONE" in script
    # Slurm wrote the jobs' logs where log_directory says, nothing into the client's cwd
    assert sorted(p.name for p in logs.iterdir()) == sorted(
        f"dask-worker-{j}.{ext}" for j in jobs for ext in ("err", "out"))
    assert list(cwd.iterdir()) == []
    assert any("Registered to:" in (logs / f"dask-worker-{j}.err").read_text() for j in jobs)
    print(f"\nslurm run: {wall:.1f} s for the whole command; {out.splitlines()[-6]}")


def test_scancel_of_the_worker_job_mid_study_loses_nothing(slurm, study_path, reference, tmp_path):
    """One job of two worker processes (cores=2), cancelled with scancel after the first
    task: no worker left; the job is replaced once its workers have been gone for Dask's
    lost-worker-timeout (3 s here, 15 s by default) and the study finishes on the new one."""
    store = tmp_path / "scancel.zarr"
    t0 = time.perf_counter()
    p = run_on_slurm(slurm, study_path, store, tmp_path / "cwd", "--task-seconds", TASK_SECONDS,
                     *slurm_options(slurm, tmp_path / "logs", "cores=2"),
                     DASK_DISTRIBUTED__DEPLOY__LOST_WORKER_TIMEOUT="3s")
    try:
        wait_until(lambda: done_count(store) >= 1 or p.poll() is not None, 120, "a first task")
        running = [j["id"] for j in slurm.jobs("RUNNING")]
        cancelled_at = done_count(store)
        assert running, "no running worker job"
        slurm.command("scancel", running[0])
        cancelled_after = time.perf_counter() - t0
    finally:
        code, out, err = finish(p)
    jobs = submitted_jobs(out)
    print(f"\nscancel: job {running[0]} (2 workers) cancelled {cancelled_after:.0f} s into the "
          f"run with {cancelled_at}/{N_TASKS} tasks done; run {time.perf_counter() - t0:.0f} s; jobs "
          f"submitted: {', '.join(jobs)}")
    assert cancelled_at < N_TASKS, "the study finished before the job was cancelled"
    assert code == 0, f"{out}\n{err}"
    assert "Traceback" not in out + err
    assert slurm.job_state(running[0]) == "CANCELLED"
    assert jobs[0] == running[0] and len(jobs) == 2, out     # the job, then its replacement
    assert_same_store(store, reference)


def test_job_ended_by_its_time_limit_is_replaced_and_loses_nothing(slurm, tmp_path):
    """Slurm's own time limit: a running job's limit is cut to 0 (scontrol update), and
    slurmctld ends it at its next time-limit check (every 30 s) as at the end of its
    walltime: SIGTERM, SIGKILL after KillWait, state TIMEOUT. The study goes on; the job is
    replaced by a new one once Dask gives its worker up (lost-worker-timeout: 15 s by
    default, 3 s here to keep the test short)."""
    study = tmp_path / "slow.toml"
    study.write_text(SLOW)
    # the undisturbed run (no delay: the placeholder's results do not depend on it), at the
    # same time as the Slurm one: it needs little CPU
    reference = tmp_path / "slow-ref.zarr"
    ref = subprocess.Popen(hertzmap_cmd("run", str(study), "--store", str(reference),
                                        "--workers", "1", "--solver", PLACEHOLDER,
                                        "--error-sample", "0", "--task-seconds", "0.01"),
                           env=subprocess_env(), stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    store = tmp_path / "slow.zarr"
    # with --export=NONE the jobs need the placeholder's folder and delay from the prologue
    prologue = json.dumps([f"export PYTHONPATH={REPO}",
                           f"export HERTZMAP_PLACEHOLDER_DELAY={SLOW_DELAY}"])
    t0 = time.perf_counter()
    p = run_on_slurm(slurm, study, store, tmp_path / "cwd", "--solver", PLACEHOLDER,
                     "--error-sample", "0", "--task-seconds", "0.01",
                     *slurm_options(slurm, tmp_path / "logs", f"job_script_prologue={prologue}"),
                     DASK_DISTRIBUTED__DEPLOY__LOST_WORKER_TIMEOUT="3s")
    try:
        wait_until(lambda: done_count(store) >= 1 or p.poll() is not None, 120, "a first task")
        victim = slurm.jobs("RUNNING")[0]["id"]
        slurm.command("scontrol", "update", f"JobId={victim}", "TimeLimit=0")
        wait_until(lambda: slurm.job_state(victim) != "RUNNING" or p.poll() is not None, 60,
                   "the time limit")
        ended_after, ended_at = time.perf_counter() - t0, done_count(store)
    finally:
        code, out, err = finish(p)
        ref_code, _, ref_err = finish(ref)
    print(f"\ntime limit: job {victim} ended {ended_after:.0f} s into the run with {ended_at}/"
          f"{SLOW_TASKS} tasks done; run {time.perf_counter() - t0:.0f} s")
    assert ref_code == 0, ref_err
    assert slurm.job_state(victim) == "TIMEOUT"
    assert ended_at < SLOW_TASKS, "the study finished before the job hit its time limit"
    assert code == 0, f"{out}\n{err}"
    assert "Traceback" not in out + err
    jobs = submitted_jobs(out)
    assert len(jobs) == 3 and victim in jobs[:2], out      # two, then one replacing the victim
    assert_same_store(store, reference)


def test_worker_jobs_failing_on_the_node_stop_the_run_with_a_message(slurm, study_path,
                                                                    tmp_path):
    """Jobs that Slurm accepts but whose script fails on the node (here: a python that is
    not there, as when the environment is on a disk the nodes do not see): the run stops
    (exit code 1) naming the jobs and where their output is, instead of waiting forever;
    the store exists with no task done."""
    store = tmp_path / "no-python.zarr"
    logs = tmp_path / "logs"
    p = run_on_slurm(slurm, study_path, store, tmp_path / "cwd",
                     *slurm_options(slurm, logs, "python=/nonexistent/bin/python"))
    code, out, err = finish(p, timeout=120)
    assert code == 1, f"{out}\n{err}"
    assert "Traceback" not in out + err
    jobs = submitted_jobs(out)
    assert len(jobs) == 2
    first, second = sorted(jobs, key=lambda j: (len(j), j))     # the message lists them by id
    assert (f"hertzmap: error: the worker jobs ended before any worker connected "
            f"({first} FAILED, {second} FAILED)") in err, err
    assert f"its output is in {logs}/dask-worker-JOBID.err" in err
    assert "/nonexistent/bin/python: No such file" in (logs / f"dask-worker-{jobs[0]}.err").read_text()
    assert done_count(store) == 0
    assert "stopped, no worker job started" in xr.open_zarr(store).attrs["history"]


# -- refused options: exit 2, nothing written ---------------------------------------------

REFUSED = [
    # (option, words of the message after the option)
    ("queue=nosuch", "sbatch refused the worker job: sbatch: error: invalid partition specified: nosuch"),
    ("memory=100000GB", "sbatch refused the worker job: sbatch: error: Memory specification can not be satisfied"),
    ("cores=64", "sbatch refused the worker job"),
    ("walltime=02:00:00", "Requested time limit is invalid"),
    ('job_extra_directives=["--no-such-sbatch-option"]', "sbatch refused the worker job"),
    ("no_such_option=1", "not accepted by dask_jobqueue.SLURMCluster"),
]


@pytest.mark.parametrize("option,words", REFUSED, ids=[o.split("=")[0] for o, _ in REFUSED])
def test_refused_option_is_a_usage_error_and_writes_nothing(slurm, study_path, tmp_path,
                                                            monkeypatch, capsys, option, words):
    assert_refused(slurm, study_path, tmp_path, monkeypatch, capsys, option, words)


def test_account_that_does_not_exist_is_a_usage_error(slurm, study_path, tmp_path,
                                                     monkeypatch, capsys):
    if slurm.accounting is not None:
        pytest.skip(f"Slurm account test skipped: {slurm.accounting}")
    assert_refused(slurm, study_path, tmp_path, monkeypatch, capsys, "account=nosuch",
                   "sbatch refused the worker job: sbatch: error: Batch job submission "
                   "failed: Invalid account or account/partition combination specified")


def assert_refused(slurm, study_path, tmp_path, monkeypatch, capsys, option, words) -> None:
    """`hertzmap run ... --cluster-option OPTION` exits with code 2, its first line of
    stderr names the option and has ``words``, no store, no job. In this process (the
    command's main(), as the console script calls it): a client process per case would
    spend most of its time importing."""
    monkeypatch.setenv("SLURM_CONF", str(slurm.conf))
    monkeypatch.chdir(tmp_path)
    store = tmp_path / "refused.zarr"
    key = option.split("=")[0]
    # the option under test replaces the example's own value for that key
    base = slurm_options(slurm, tmp_path / "logs")
    args = [arg for i in range(0, len(base), 2) if base[i + 1].split("=")[0] != key
            for arg in base[i:i + 2]]
    code = main(["run", str(study_path), "--store", str(store), "--cluster", "slurm",
                 "--workers", "2", "--cluster-option", option, *args])
    out, err = capsys.readouterr()
    assert code == 2, f"{out}\n{err}"
    assert "Traceback" not in out + err
    first = err.strip().splitlines()[0]
    assert first.startswith(f"hertzmap: error: --cluster-option {option}: "), err
    assert words in first, err
    assert not store.exists() and not Path(f"{store}.lock").exists()
    assert not slurm.jobs("PENDING,RUNNING,CONFIGURING"), "a job was left in the queue"


def test_refused_option_leaves_an_existing_store_untouched(slurm, study_path, reference,
                                                          tmp_path, monkeypatch, capsys):
    """A partial store (one task not done) and a rerun with a partition that does not
    exist: exit 2, the store byte for byte as it was."""
    from hertzmap.scheduler.store import Store
    monkeypatch.setenv("SLURM_CONF", str(slurm.conf))
    store = tmp_path / "partial.zarr"
    shutil.copytree(reference, store)
    Store(store).unmark((0, 0, 0))
    before = {p.relative_to(store): p.read_bytes() for p in store.rglob("*") if p.is_file()}
    code = main(["run", str(study_path), "--store", str(store), "--cluster", "slurm",
                 "--workers", "2", "--cluster-option", "queue=nosuch"])
    out, err = capsys.readouterr()
    assert code == 2 and "--cluster-option queue=nosuch" in err, f"{out}\n{err}"
    after = {p.relative_to(store): p.read_bytes() for p in store.rglob("*") if p.is_file()}
    assert after == before
    assert not Path(f"{store}.lock").exists()
