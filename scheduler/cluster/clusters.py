"""Where a study runs: an embedded LocalCluster, an existing scheduler, or a dask-jobqueue
cluster (Slurm, PBS). Always one thread per worker process (numba kernels, no GIL sharing).
"""

from __future__ import annotations

import contextlib
import datetime
import importlib.util
import json
import logging
import os
import re
import shlex
import subprocess
import tomllib
from dataclasses import dataclass, field
from typing import Any


from hertzmap.scheduler.errors import ClusterError


#: A small study's cluster (scheduler.stages.plan.is_small_study): one worker thread in the client's
#: own process, no worker process to start
INPROCESS = "in-process"
#: the kinds whose workers run on the client's machine (its file system: the store is theirs)
LOCAL_KINDS = ("local", INPROCESS)

JOBQUEUE = {"slurm": "SLURMCluster", "pbs": "PBSCluster", "sge": "SGECluster",
            "lsf": "LSFCluster", "htcondor": "HTCondorCluster"}
#: The command each of them submits a worker job with.
JOBQUEUE_SUBMIT = {"slurm": "sbatch", "pbs": "qsub", "sge": "qsub", "lsf": "bsub",
                   "htcondor": "condor_submit"}


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
        if isinstance(value, (datetime.date, datetime.time)):
            value = raw     # walltime=02:00:00 is a TOML time of day, meant as a duration
        out[key] = value
    return out


def shown(value: Any) -> str:
    """A --cluster-option value as typed (lists and tables as JSON, which TOML also reads)."""
    return json.dumps(value) if isinstance(value, (list, dict)) else str(value)


@dataclass
class ClusterSpec:
    kind: str = "local"                 # local | in-process | address | slurm | pbs | sge | lsf | htcondor
    workers: int | None = None          # local: worker processes; jobqueue: worker processes to scale to
    address: str | None = None
    options: dict[str, Any] = field(default_factory=dict)

    def describe(self) -> str:
        if self.kind == INPROCESS:
            return "in-process: one worker thread in this process (a small study)"
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
#   1.04-1.06x slower with it (median of 40-block ABBA runs; benchmarks/archive/dask_profiler_ab.py). It
#   only feeds the dashboard's profile page: off.
# * every event loop ticks every 20 ms (to warn when it is blocked), the system monitor samples
#   every 0.5 s and the memory monitor every 0.1 s. An idle 2-worker LocalCluster burnt 12.1-14.4 %
#   of a core with Dask's defaults, 2.3-2.6 % with this config (benchmarks/archive/dask_idle_cpu.py; the
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
    """The embedded cluster's dashboard: a free port on the loopback (a bare ":0" binds every
    interface, whatever the scheduler's host)."""
    return "127.0.0.1:0" if importlib.util.find_spec("bokeh") is not None else None


# -- dask-jobqueue -----------------------------------------------------------------------------

#: Seconds to wait for the batch system to accept (or refuse) the first worker jobs.
SUBMIT_TIMEOUT = 120

#: What a refusal by the batch system's submit command is about, by the words of its message
#: (sbatch, qsub, bsub, condor_submit), and the cluster option that sets it.
SUBMIT_ERRORS = [
    ("account", "account"), ("project", "account"), ("time limit", "walltime"),
    ("walltime", "walltime"), ("partition", "queue"), ("queue", "queue"),
    ("memory", "memory"), ("processors", "cores"), ("cpus", "cores"),
    ("node configuration", "cores"), ("unrecognized option", "job_extra_directives"),
    ("invalid option", "job_extra_directives"), ("unknown option", "job_extra_directives"),
]


def worker_job_prologue() -> list[str]:
    """Lines at the top of every worker job script (before the worker starts): what the
    workers need from this client, whatever environment the batch system gives the job
    (sbatch --export=NONE, qsub without -V):
    * the trimmed Dask config (CLUSTER_CONFIG) as DASK_* variables;
    * NUMBA_CACHE_DIR: the client's numba cache folder (absolute), so that workers load the
      kernels it compiled instead of compiling them again in every job (when that folder is
      on a file system the nodes share; elsewhere each node compiles once into it);
    * PYTHONSAFEPATH=1: ``python -m distributed.cli.dask_worker`` would otherwise put the
      job's start directory (the submitting shell's cwd, for Slurm) first on sys.path, and
      a checkout of another hertzmap version there would be imported instead of the
      environment's."""
    from hertzmap import kernels  # its CACHE_DIR is <root>/numba-<hash of the kernels' sources>

    root = os.path.dirname(os.path.abspath(kernels.CACHE_DIR))
    return config_env_lines(CLUSTER_CONFIG) + [
        f"export NUMBA_CACHE_DIR={shlex.quote(root)}",
        "export PYTHONSAFEPATH=1",
    ]


def jobqueue_options(spec: ClusterSpec) -> tuple[dict[str, Any], dict[str, Any]]:
    """The keyword arguments of the dask-jobqueue cluster class, and the defaults among them
    that hertzmap chose (applied only where neither the options nor the dask-jobqueue config,
    ~/.config/dask/jobqueue.yaml, say anything)."""
    import dask

    opts = dict(spec.options)
    conf = dask.config.get(f"jobqueue.{spec.kind}", default={}) or {}
    defaults: dict[str, Any] = {}
    for key in ("cores", "processes"):
        if key in opts and (isinstance(opts[key], bool) or not isinstance(opts[key], int)
                            or opts[key] < 1):
            raise ClusterError(f"--cluster-option {key}={opts[key]!r}: expected a whole "
                               "number >= 1")
    if "cores" not in opts and conf.get("cores") is None:
        defaults["cores"] = 1
    cores = int(opts.get("cores") or conf.get("cores") or defaults["cores"])
    if "processes" not in opts and conf.get("processes") is None:
        defaults["processes"] = cores             # one single-threaded worker process per core
    if "memory" not in opts and conf.get("memory") is None:
        defaults["memory"] = f"{2 * cores}GB"
    # hertzmap's lines first: a prologue of the options or the config adds to them (and may
    # override them: it runs after)
    user_prologue = opts.get("job_script_prologue", conf.get("job-script-prologue")) or []
    if isinstance(user_prologue, str):
        user_prologue = [user_prologue]
    opts["job_script_prologue"] = worker_job_prologue() + list(user_prologue)
    # a free port for the scheduler's HTTP server (the dashboard, with bokeh): it starts one
    # even without bokeh, on 8787 by default, often taken on a shared login node (the
    # option replaces the config's scheduler-options: those are kept)
    opts["scheduler_options"] = {"dashboard_address": ":0",
                                 **(conf.get("scheduler-options") or {}),
                                 **(opts.get("scheduler_options") or {})}
    opts.update(defaults)
    return opts, defaults


def _jobs_per_spec(spec: ClusterSpec, opts: dict[str, Any]) -> tuple[int, int]:
    """(jobs, worker processes per job) for --workers."""
    import dask

    conf = dask.config.get(f"jobqueue.{spec.kind}", default={}) or {}
    per_job = int(opts.get("processes") or conf.get("processes") or 1)
    workers = spec.workers or per_job
    return -(-workers // per_job), per_job


NOT_RUN = "cannot run"


def _submit_output(exc: BaseException) -> str:
    """The submit command's own words from dask-jobqueue's error ("Command exited with
    non-zero exit code ... stderr: ..."), on one line; or why it could not be run."""
    if isinstance(exc, OSError):
        return f"{NOT_RUN} {exc.filename or 'the submit command'}: {exc.strerror or exc}"
    text = str(exc)
    stderr = text.split("stderr:", 1)[1] if "stderr:" in text else text
    lines = [ln.strip() for ln in stderr.strip().splitlines() if ln.strip()]
    return "; ".join(lines[:4]) or f"{type(exc).__name__}: {text.strip()}"


def _submit_refusal(spec: ClusterSpec, defaults: dict[str, Any], said: str) -> ClusterError:
    """A ClusterError naming the option behind the batch system's refusal of a worker job
    (``said``: the submit command's message)."""
    command = JOBQUEUE_SUBMIT.get(spec.kind, "the submit command")
    low = said.lower()
    key = next((k for words, k in SUBMIT_ERRORS if words in low), None)
    if key is not None and key in spec.options:
        where = f"--cluster-option {key}={shown(spec.options[key])}"
    elif key is not None and key in defaults:
        where = f"--cluster-option {key} (hertzmap's default {defaults[key]!r})"
    elif key is not None:
        where = f"--cluster-option {key} (from the dask-jobqueue configuration)"
    else:
        given = " ".join(f"{k}={shown(v)}" for k, v in sorted(spec.options.items()))
        where = f"--cluster {spec.kind}" + (f" with --cluster-option {given}" if given else "")
    return ClusterError(f"{where}: {command} refused the worker job: {said}")


def _recording_job_class(base, submitted: list, refused: list, report):
    """The cluster's Job class, recording each submission (its job id) or refusal, so that
    make_client can wait for the first ones and report a refusal, and so that a job
    resubmitted during the run (after one ended) is reported."""

    from distributed.core import Status

    class RecordingJob(base):
        async def start(self):
            try:
                await super().start()
            except Exception as exc:
                said = _submit_output(exc)
                refused.append(said)
                if report is not None:
                    report(f"hertzmap: warning: a worker job could not be submitted, the "
                           f"study goes on with the workers it has: {said}")
                # not raised: Dask would log it with a traceback; the job stays in the
                # cluster's books without a job id (nothing to cancel), never resubmitted
                self.status = Status.running
                return
            submitted.append(self.job_id)
            if report is not None:
                report(f"hertzmap: worker job {self.job_id} submitted")

        async def close(self):
            await super().close()
            # (dask-jobqueue leaves it 'running', and SpecCluster.close asserts on the
            # status of every job object still alive)
            self.status = Status.closed

    RecordingJob.__name__ = RecordingJob.__qualname__ = base.__name__
    return RecordingJob


def make_jobqueue_cluster(spec: ClusterSpec, report=None):
    """A dask-jobqueue cluster whose first worker jobs the batch system has accepted.

    Raises ClusterError (naming the option) for an option the cluster class does not take or
    a job the batch system refuses (no such partition or account, more memory or cores or
    time than it gives): before anything is written. Keeps the jobs at the number asked for
    (``adapt(minimum_jobs=n, maximum_jobs=n)``, and :func:`_watch_for_ended_jobs`): a job
    that ends (scancel, walltime, a node lost) is resubmitted once its workers have been gone
    for distributed.deploy.lost-worker-timeout (15 s); ``scale`` alone never resubmits.
    ``report(line)`` is called for each job submitted after the first ones."""
    import time

    import dask_jobqueue

    cls = getattr(dask_jobqueue, JOBQUEUE[spec.kind])
    opts, defaults = jobqueue_options(spec)
    submitted: list = []
    refused: list = []
    reporting = {"on": False}

    def late_report(line: str) -> None:
        if reporting["on"] and report is not None:
            report(line)

    job_cls = _recording_job_class(cls.job_cls, submitted, refused, late_report)
    try:
        cluster = cls(job_cls=job_cls, **opts)
    except (TypeError, ValueError) as exc:
        found = re.search(r"unexpected keyword argument '?\w+'?", str(exc))
        msg = found.group(0) if found else (str(exc).splitlines() or [type(exc).__name__])[0]
        bad = next((k for k in spec.options if f"'{k}'" in str(exc)), None)
        where = (f"--cluster-option {bad}={shown(spec.options[bad])}" if bad
                 else f"--cluster {spec.kind} (--cluster-option ...)")
        raise ClusterError(f"{where}: not accepted by dask_jobqueue.{cls.__name__} ({msg})") from None
    jobs, _ = _jobs_per_spec(spec, opts)
    try:
        cluster.scale(jobs=jobs)
        t0 = time.monotonic()
        while not refused and len(submitted) < jobs:
            if time.monotonic() - t0 > SUBMIT_TIMEOUT:
                raise ClusterError(f"--cluster {spec.kind}: {JOBQUEUE_SUBMIT[spec.kind]} did "
                                   f"not accept {jobs} worker job(s) within {SUBMIT_TIMEOUT} s")
            time.sleep(0.05)
        if refused and refused[0].startswith(NOT_RUN):
            raise ClusterError(f"--cluster {spec.kind}: {refused[0]} (is this a machine "
                               f"that submits to the batch system?)")
        if refused:
            raise _submit_refusal(spec, defaults, refused[0])
        cluster.adapt(minimum_jobs=jobs, maximum_jobs=jobs)
        _watch_for_ended_jobs(cluster)
    except BaseException:
        with contextlib.suppress(Exception):
            cluster.close()
        raise
    reporting["on"] = True
    if report is not None:
        report(f"hertzmap: worker job(s) {', '.join(map(str, submitted))} submitted (a job "
               f"whose worker is lost is replaced)")
    return cluster


def _watch_for_ended_jobs(cluster, every: float = 0.5) -> None:
    """Give up a job whose worker processes have all been gone for Dask's
    lost-worker-timeout (distributed.deploy.lost-worker-timeout, 15 s by default): cancel
    it and drop it from the cluster's jobs, which the adaptive cluster then resubmits.

    SpecCluster does this itself for a job of one worker process only: it looks its lost
    worker up by name, and the workers of a job of several processes are named
    ``<job>-0``, ``<job>-1``... (measured: a job of two processes cancelled with scancel was
    never replaced, the study left with no worker)."""
    import asyncio
    import time
    import weakref

    import dask
    from dask.utils import parse_timedelta
    from tornado.ioloop import PeriodicCallback

    grace = parse_timedelta(dask.config.get("distributed.deploy.lost-worker-timeout"))
    seen: weakref.WeakSet = weakref.WeakSet()        # jobs whose workers have connected
    gone_since: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
    closing: set = set()

    def check() -> None:
        alive = {str(w.get("name")) for w in cluster.scheduler_info.get("workers", {}).values()}
        now = time.monotonic()
        for name, job in list(cluster.workers.items()):
            spec = cluster.worker_spec.get(name)
            if spec is None:
                continue
            names = {f"{name}{suffix}" for suffix in spec.get("group", [""])}
            if names & alive:
                seen.add(job)
                gone_since.pop(job, None)
            elif job in seen and now - gone_since.setdefault(job, now) >= grace:
                if cluster.workers.get(name) is job:
                    del cluster.workers[name]
                task = asyncio.ensure_future(job.close())    # scancel (the job may be over)
                closing.add(task)
                task.add_done_callback(closing.discard)

    def install() -> None:
        pc = PeriodicCallback(check, every * 1000)
        cluster.periodic_callbacks["hertzmap-ended-jobs"] = pc
        pc.start()

    cluster.loop.add_callback(install)


class WorkerJobsEnded(Exception):
    """Every worker job submitted so far ended before a worker connected (the job script
    failed on the node: python or hertzmap not there, ...). The store exists by then: the
    run stops with exit code 1 and the message, and resumes on rerun."""


#: Slurm job states from which a job may still start its worker.
SLURM_ACTIVE = {"PENDING", "CONFIGURING", "RUNNING", "REQUEUED", "REQUEUE_HOLD",
                "REQUEUE_FED", "RESIZING", "SUSPENDED", "SIGNALING", "STAGE_OUT"}


def batch_job_states(kind: str, job_ids: list[str]) -> dict[str, tuple[str, str]] | None:
    """{job id: (state, reason)} from the batch system (Slurm: squeue), a job it no longer
    knows left out; None where hertzmap cannot ask (other batch systems) or the query
    failed."""
    if kind != "slurm" or not job_ids:
        return None
    try:
        r = subprocess.run(["squeue", "--noheader", "--states=all", "--jobs", ",".join(job_ids),
                            "--format=%i|%T|%r"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return None
    if r.returncode != 0:
        # every id purged from slurmctld's memory (MinJobAge): none of them is known
        return {} if "Invalid job id" in r.stderr else None
    states = {}
    for line in r.stdout.splitlines():
        parts = line.strip().split("|")
        if len(parts) == 3:
            states[parts[0]] = (parts[1], parts[2])
    return states


def wait_for_first_worker(client, cluster, spec: ClusterSpec, report, *, poll: float = 5.0,
                          note_every: float = 60.0) -> None:
    """Wait until a worker of the batch cluster connects. Every ``note_every`` s, report the
    jobs' states (Slurm: squeue's state and reason, e.g. PENDING (Priority)); raise
    WorkerJobsEnded when the batch system says that every job submitted so far has ended."""
    import time

    t0 = last = time.monotonic()
    while True:
        try:
            client.wait_for_workers(1, timeout=poll)
            return
        except TimeoutError:
            pass
        ids = sorted((str(w.job_id) for w in list(cluster.workers.values())
                      if getattr(w, "job_id", None)), key=lambda i: (len(i), i))
        states = batch_job_states(spec.kind, ids)
        if states is not None and ids and not any(
                states.get(i, ("ENDED", ""))[0] in SLURM_ACTIVE for i in ids):
            ended = ", ".join(f"{i} {states.get(i, ('ended', ''))[0]}" for i in ids)
            logs = spec.options.get("log_directory")
            where = (f"{logs}/dask-worker-JOBID.err" if logs
                     else "slurm-JOBID.out in the folder hertzmap was started from")
            raise WorkerJobsEnded(
                f"the worker jobs ended before any worker connected ({ended}): the job script "
                f"failed on the node; its output is in {where}")
        now = time.monotonic()
        if report is not None and now - last >= note_every:
            last = now
            seen = ", ".join(f"{i} {states[i][0]} ({states[i][1]})" if states and i in states
                             else i for i in ids)
            report(f"hertzmap: still waiting for a worker after {now - t0:.0f} s; jobs: {seen}")


def make_client(spec: ClusterSpec, report=None):
    """Return (client, cluster or None). The caller closes both. ``report``: see
    make_jobqueue_cluster."""
    from distributed import Client, LocalCluster

    import dask

    spec.check()
    if spec.kind == "address":
        try:
            # Dask's connect timeout (30 s unless DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT or
            # the Dask config says otherwise): how long an unreachable scheduler is waited for
            client = Client(spec.address,
                            timeout=dask.config.get("distributed.comm.timeouts.connect"))
        except (OSError, TimeoutError, ValueError) as exc:
            raise ClusterError(f"--scheduler {spec.address}: cannot connect to a Dask scheduler "
                               f"there ({type(exc).__name__}: {exc})") from None
        return client, None
    if spec.kind == INPROCESS:
        # a small study: the scheduler and one single-threaded worker in this process (about
        # a second to start where a process cluster took 10-12 s with its workers loading the
        # kernels; docs/running.md, "Small studies")
        with dask.config.set(CLUSTER_CONFIG):
            # no dashboard (bokeh's import alone is a second), its HTTP server on a free
            # port of the loopback (8787, Dask's default, may be taken)
            cluster = LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                   dashboard_address="127.0.0.1:0",
                                   scheduler_kwargs={"dashboard": False},
                                   silence_logs=logging.CRITICAL)
            return Client(cluster), cluster
    if spec.kind == "local":
        # (the nannies hand the config to the worker processes they start)
        with dask.config.set(CLUSTER_CONFIG):
            # on the loopback only (the scheduler, the workers and the dashboard): nothing of
            # an embedded cluster is reachable from another machine
            cluster = LocalCluster(n_workers=spec.workers or default_workers(),
                                   threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=_dashboard_address(),
                                   # tasks that fail reach the client as exceptions and are
                                   # reported there; the workers' own logs (heartbeats cut at
                                   # shutdown) are noise to a user
                                   silence_logs=logging.CRITICAL)
            return Client(cluster), cluster
    cluster = make_jobqueue_cluster(spec, report=report)
    try:
        return Client(cluster), cluster
    except BaseException:
        cluster.close()
        raise


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


def where_line(spec: ClusterSpec, n_workers: int) -> str:
    """Where a run's tasks ran, as its first line and its summary say it."""
    if spec.kind == INPROCESS:
        return "in-process (a small study: one worker thread, no worker process started)"
    return f"on {n_workers} workers"


def worker_count(client) -> int:
    """Number of workers currently connected to the client's scheduler."""
    return len(client.scheduler_info(n_workers=-1)["workers"])
