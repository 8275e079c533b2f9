"""Where a study runs: an embedded LocalCluster, an existing scheduler, or a dask-jobqueue
cluster (Slurm, PBS). Always one thread per worker process (numba kernels, no GIL sharing).
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import tomllib
from dataclasses import dataclass, field
from typing import Any


from scheduler.errors import ClusterError


JOBQUEUE = {"slurm": "SLURMCluster", "pbs": "PBSCluster", "sge": "SGECluster",
            "lsf": "LSFCluster", "htcondor": "HTCondorCluster"}


def default_workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover (not Linux)
        return max(1, os.cpu_count() or 1)


def max_local_workers() -> int:
    """Most worker processes an embedded LocalCluster may start (16 per core)."""
    return 16 * default_workers()


def parse_cluster_options(items: list[str]) -> dict[str, Any]:
    """``KEY=VALUE`` strings to kwargs; VALUE is read as a TOML value when it parses as one
    (numbers, booleans, quoted strings, [lists]), else kept as a plain string."""
    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, raw = item.partition("=")
        key = key.strip().replace("-", "_")
        if not sep or not key.isidentifier():
            raise ClusterError(f"--cluster-option {item!r}: expected KEY=VALUE")
        try:
            value = tomllib.loads(f"v = {raw}")["v"]
        except tomllib.TOMLDecodeError:
            value = raw
        out[key] = value
    return out


@dataclass
class ClusterSpec:
    kind: str = "local"                 # local | address | slurm | pbs | sge | lsf | htcondor
    workers: int | None = None          # local: worker processes; jobqueue: worker processes to scale to
    address: str | None = None
    options: dict[str, Any] = field(default_factory=dict)

    def describe(self) -> str:
        if self.kind == "local":
            n = self.workers or default_workers()
            return f"local cluster: {n} single-threaded worker process{'es' if n > 1 else ''}"
        if self.kind == "address":
            return f"existing Dask scheduler at {self.address}"
        opts = " ".join(f"{k}={v!r}" for k, v in sorted(self.options.items()))
        n = self.workers or 1
        return f"dask-jobqueue {JOBQUEUE[self.kind]} scaled to {n} worker process(es) {opts}".rstrip()

    def check(self) -> None:
        """Fail early (before anything is written) on a cluster that cannot be made."""
        if self.kind in JOBQUEUE and importlib.util.find_spec("dask_jobqueue") is None:
            raise ClusterError(f"--cluster {self.kind} needs dask-jobqueue: "
                               "pip install 'hertzmap[jobqueue]'")
        if self.workers is not None and self.workers < 1:
            raise ClusterError(f"--workers must be >= 1, got {self.workers}")
        if self.kind == "local" and self.workers is not None and self.workers > max_local_workers():
            raise ClusterError(f"--workers {self.workers} is more than a local cluster can run "
                               f"here (at most {max_local_workers()} processes: 16 per core); "
                               "use --scheduler or --cluster for more")
        if self.kind == "address" and self.address is not None and (
                not isinstance(self.address, str) or not self.address.strip()
                or any(c.isspace() for c in self.address)):
            raise ClusterError(f"--scheduler: expected an address such as tcp://host:8786, "
                               f"got {self.address!r}")


# Dask's housekeeping, trimmed for processes that share a few cores with the solvers:
# * the statistical profiler samples every worker's stack every 10 ms from a thread of its own,
#   taking the GIL from the block solver's Python parts: both workers busy, the same block ran
#   1.04-1.06x slower with it (median of 40-block ABBA runs; benchmarks/dask_profiler_ab.py). It
#   only feeds the dashboard's profile page: off.
# * every event loop ticks every 20 ms (to warn when it is blocked), the system monitor samples
#   every 0.5 s and the memory monitor every 0.1 s. An idle 2-worker LocalCluster burnt 12.1-14.4 %
#   of a core with Dask's defaults, 2.3-2.6 % with this config (benchmarks/dask_idle_cpu.py; the
#   profiler and the ticks are most of it): CPU the solvers do not get on a 2-core machine.
# The embedded cluster (scheduler, client, nannies, workers) runs with these; jobqueue workers
# get them through their job script's environment.
CLUSTER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "200ms",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
}


def config_env_lines(config: dict) -> list[str]:
    """``export DASK_...=value`` lines that give a Dask process started elsewhere (a batch job)
    the same config (Dask reads DASK_* variables, ``__`` for a dot, at import)."""
    lines = []
    for key, value in config.items():
        name = "DASK_" + key.upper().replace(".", "__").replace("-", "_")
        lines.append(f"export {name}={value}")
    return lines


def _dashboard_address() -> str | None:
    return ":0" if importlib.util.find_spec("bokeh") is not None else None


def make_client(spec: ClusterSpec):
    """Return (client, cluster or None). The caller closes both."""
    from distributed import Client, LocalCluster

    spec.check()
    if spec.kind == "address":
        try:
            client = Client(spec.address, timeout="30s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ClusterError(f"--scheduler {spec.address}: cannot connect to a Dask scheduler "
                               f"there ({type(exc).__name__}: {exc})") from None
        return client, None
    import dask

    if spec.kind == "local":
        # (the nannies hand the config to the worker processes they start)
        with dask.config.set(CLUSTER_CONFIG):
            cluster = LocalCluster(n_workers=spec.workers or default_workers(),
                                   threads_per_worker=1, processes=True,
                                   dashboard_address=_dashboard_address(),
                                   # tasks that fail reach the client as exceptions and are
                                   # reported there; the workers' own logs (heartbeats cut at
                                   # shutdown) are noise to a user
                                   silence_logs=logging.CRITICAL)
            return Client(cluster), cluster
    import dask_jobqueue

    cls = getattr(dask_jobqueue, JOBQUEUE[spec.kind])
    opts = dict(spec.options)
    # defaults only where neither the options nor the dask-jobqueue config
    # (~/.config/dask/jobqueue.yaml) say anything
    conf = dask.config.get(f"jobqueue.{spec.kind}", default={}) or {}
    if "cores" not in opts and conf.get("cores") is None:
        opts["cores"] = 1
    cores = int(opts.get("cores") or conf.get("cores"))
    if "processes" not in opts and conf.get("processes") is None:
        opts["processes"] = cores              # one single-threaded worker process per core
    if "memory" not in opts and conf.get("memory") is None:
        opts["memory"] = f"{2 * cores}GB"
    if "job_script_prologue" not in opts and conf.get("job-script-prologue") is None:
        opts["job_script_prologue"] = config_env_lines(CLUSTER_CONFIG)
    if _dashboard_address() is None and "scheduler_options" not in opts:
        opts["scheduler_options"] = {"dashboard_address": None}
    cluster = cls(**opts)
    cluster.scale(n=spec.workers or int(opts.get("processes") or conf.get("processes") or 1))
    return Client(cluster), cluster


@contextlib.contextmanager
def _quiet_logs():
    """No log record of this process printed for the duration (Dask's loggers set their own
    levels, e.g. distributed.client, so the parent logger's level is not enough)."""
    logging.disable(logging.CRITICAL)
    try:
        yield
    finally:
        logging.disable(logging.NOTSET)


def close_quietly(client, cluster=None) -> None:
    """Close the client, then the cluster hertzmap made, without printing Dask's shutdown noise.

    The loggers of this process are silenced while the connections close (the embedded
    cluster's worker processes log at CRITICAL only: see make_client). A loaded machine printed
    a CommClosedError traceback from a worker heartbeat at shutdown; a study's results are
    already in the store at this point, and nothing said then concerns them.
    """
    with _quiet_logs():
        with contextlib.suppress(Exception):
            client.close()
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close()


def worker_count(client) -> int:
    """Number of workers currently connected to the client's scheduler."""
    return len(client.scheduler_info(n_workers=-1)["workers"])
