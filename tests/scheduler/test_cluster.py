"""scheduler.cluster: the embedded cluster runs with the trimmed Dask config, batch workers get
it as exports, dask-jobqueue clusters are made from the options (or refused clearly)."""
from __future__ import annotations

import sys

import pytest

from scheduler.cli import main
from scheduler.cluster import ClusterSpec
from scheduler.store import Store


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
    from scheduler.cluster import CLUSTER_CONFIG, make_client

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


def test_config_env_lines_reproduce_the_config():
    """The job-script lines for batch workers give Dask the same config (read from DASK_*)."""
    import dask
    import dask.config

    from scheduler.cluster import CLUSTER_CONFIG, config_env_lines

    env = dict(line.removeprefix("export ").split("=", 1)
               for line in config_env_lines(CLUSTER_CONFIG))
    collected = dask.config.collect_env(env)
    with dask.config.set(collected):
        assert {k: dask.config.get(k) for k in CLUSTER_CONFIG} == CLUSTER_CONFIG


def test_jobqueue_cluster_is_made_from_options(tmp_path, monkeypatch, capsys):
    """--cluster slurm with a stand-in for dask_jobqueue (no batch system here)."""
    import importlib.machinery
    import types
    from distributed import LocalCluster
    from tests.helpers import PLACEHOLDER

    made = {}

    class FakeSLURMCluster(LocalCluster):
        def __init__(self, **kwargs):
            made.update(kwargs)
            super().__init__(n_workers=0, threads_per_worker=1, processes=False,
                             dashboard_address=None)

    fake = types.ModuleType("dask_jobqueue")
    fake.__spec__ = importlib.machinery.ModuleSpec("dask_jobqueue", None)
    fake.SLURMCluster = FakeSLURMCluster
    monkeypatch.setitem(sys.modules, "dask_jobqueue", fake)
    p = tmp_path / "small.toml"
    p.write_text(SMALL)
    rc = main(["run", str(p), "--store", str(tmp_path / "j.zarr"), "--cluster", "slurm",
               "--workers", "2", "--cluster-option", "queue=normal", "--cluster-option", "cores=4",
               "--cluster-option", 'job_extra_directives=["--exclusive"]',
               "--solver", PLACEHOLDER, "--error-sample", "0"])
    assert rc == 0, capsys.readouterr().err
    assert made["queue"] == "normal" and made["cores"] == 4 and made["processes"] == 4
    assert made["job_extra_directives"] == ["--exclusive"] and made["memory"] == "8GB"
    # the job's workers get the trimmed Dask config (scheduler.cluster.CLUSTER_CONFIG)
    assert "export DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False" in made["job_script_prologue"]
    assert "export DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL=200ms" in made["job_script_prologue"]
    assert Store(tmp_path / "j.zarr").done_mask().all()


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
