"""scheduler.cluster.clusters: the embedded cluster runs with the trimmed Dask config, batch workers get
it as exports, dask-jobqueue clusters are made from the options (or refused clearly)."""
from __future__ import annotations

import os
import sys

import pytest

from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.cluster.clusters import ClusterSpec


pytestmark = pytest.mark.slow

# -- without the real solver (placeholder with the same contract) ------------------------------

SMALL = """
[study]
name = "small"
[grid]
omega = {start = 0.5, stop = 2.5, num = 9}
sigma = [0.2, 0.5, 0.9]
zeta = 0.02
"""


def test_local_cluster_runs_with_the_trimmed_dask_config():
    """make_client's LocalCluster hands CLUSTER_CONFIG to its worker processes (no 'profile'
    periodic callback, ticks every 200 ms): Dask's housekeeping costs the solvers on few cores."""
    from hertzmap.scheduler.cluster.clusters import CLUSTER_CONFIG, make_client

    client, cluster = make_client(ClusterSpec(kind="local", workers=1))
    try:
        callbacks = client.run(lambda dask_worker: sorted(dask_worker.periodic_callbacks))
        seen = client.run(lambda: {k: __import__("dask").config.get(k) for k in CLUSTER_CONFIG})
    finally:
        client.close()
        cluster.close()
    assert list(seen.values()) == [CLUSTER_CONFIG]
    (names,) = callbacks.values()
    assert "profile" not in names and "heartbeat" in names


def test_the_embedded_cluster_listens_on_the_loopback_and_serves_its_dashboard():
    """Out of the box: the dashboard a run prints answers (bokeh is a dependency), and the
    scheduler, its workers and the dashboard listen on 127.0.0.1 only."""
    import urllib.request

    from hertzmap.scheduler.cluster.clusters import make_client

    client, cluster = make_client(ClusterSpec(kind="local", workers=1))
    try:
        link = client.dashboard_link
        workers = list(client.scheduler_info()["workers"])
        with urllib.request.urlopen(link, timeout=30) as page:
            status = page.status
        bound = {sock.getsockname()[0] for sock in cluster.scheduler.http_server._sockets.values()}
    finally:
        client.close()
        cluster.close()
    assert link.startswith("http://127.0.0.1:"), link
    assert status == 200
    assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
    assert workers and all(w.startswith("tcp://127.0.0.1:") for w in workers), workers
    assert bound == {"127.0.0.1"}, bound


def test_config_env_lines_reproduce_the_config():
    """The job-script lines for batch workers give Dask the same config (read from DASK_*)."""
    import dask
    import dask.config

    from hertzmap.scheduler.cluster.clusters import CLUSTER_CONFIG, config_env_lines

    env = dict(line.removeprefix("export ").split("=", 1)
               for line in config_env_lines(CLUSTER_CONFIG))
    collected = dask.config.collect_env(env)
    with dask.config.set(collected):
        assert {k: dask.config.get(k) for k in CLUSTER_CONFIG} == CLUSTER_CONFIG


def test_jobqueue_job_script_is_made_from_options():
    """The job script dask-jobqueue's SLURMCluster writes from hertzmap's keyword arguments
    (no batch system needed; tests/end_to_end/test_slurm.py submits it to a real Slurm):
    the options given, hertzmap's defaults, and its prologue before the user's."""
    pytest.importorskip("dask_jobqueue", reason="dask-jobqueue not installed")
    import dask_jobqueue

    from hertzmap import kernels
    from hertzmap.scheduler.cluster.clusters import jobqueue_options, parse_cluster_options

    options = parse_cluster_options([
        "queue=normal", "cores=4", "walltime=02:00:00", 'job_extra_directives=["--exclusive"]',
        'job_script_prologue=["module load gcc"]'])
    assert options["walltime"] == "02:00:00"          # text, not a TOML time of day
    opts, defaults = jobqueue_options(ClusterSpec(kind="slurm", workers=8, options=options))
    assert defaults == {"processes": 4, "memory": "8GB"}
    cluster = dask_jobqueue.SLURMCluster(**opts)
    try:
        script = cluster.job_script()
    finally:
        cluster.close()
    lines = script.splitlines()
    for line in ("#SBATCH -p normal", "#SBATCH --cpus-per-task=4", "#SBATCH -t 02:00:00",
                 "#SBATCH --exclusive", "#SBATCH --mem=8G"):
        assert line in lines, line
    # the trimmed Dask config, the client's numba cache, no import from the job's cwd; then
    # the user's prologue
    prologue = ["export DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False",
                "export DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL=200ms",
                f"export NUMBA_CACHE_DIR={os.path.dirname(kernels.CACHE_DIR)}",
                "export PYTHONSAFEPATH=1", "module load gcc"]
    at = [lines.index(line) for line in prologue]
    assert at == sorted(at)
    worker = next(line for line in lines if "distributed.cli.dask_worker" in line)
    assert worker.startswith(f"{sys.executable} -m distributed.cli.dask_worker")
    assert "--nthreads 1" in worker and "--nworkers 4" in worker


def test_jobqueue_missing_is_a_usage_error(tmp_path, monkeypatch, capsys):
    import importlib.util
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "dask_jobqueue" else real(name, *a))
    p = tmp_path / "small.toml"
    p.write_text(SMALL)
    assert main(["run", str(p), "--store", str(tmp_path / "x.zarr"), "--cluster", "pbs"]) == 2
    assert "hertzmap[jobqueue]" in capsys.readouterr().err
    assert not (tmp_path / "x.zarr").exists()
