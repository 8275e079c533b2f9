"""A real single-node Slurm (munged, slurmctld, slurmd) in a temporary folder, for tests.

Everything lives under one folder: the munge key and socket, slurm.conf, the state and spool
directories, the daemons' logs and pid files; the daemons listen on free ports. Nothing in
/etc is used or changed, so it can run next to another Slurm (or another copy of this
fixture) on the same machine. Slurm commands find the configuration through ``SLURM_CONF``
(:attr:`SlurmCluster.env`).

Needs the Debian packages slurm-wlm (slurmctld, slurmd, slurm-client) and munge, and root
(slurmd starts jobs as their user; here every job is root's). When something is missing or
a daemon does not come up, :func:`start_slurm` raises :class:`SlurmUnavailable` with the
reason, which the fixture turns into a skip message.

With slurmdbd and a MariaDB server (Debian: slurmdbd, mariadb-server-core) it also runs the
accounting database: a MariaDB of its own in the folder, slurmdbd, the account
:data:`ACCOUNT` for root, and ``AccountingStorageEnforce=associations``, so that Slurm
refuses a job of an account that does not exist, as a real cluster does. Without them,
:attr:`SlurmCluster.accounting` says why, and any account is accepted.

    python tests/end_to_end/slurm_cluster.py [FOLDER]   # bring one up by hand, Ctrl-C to stop
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

#: The test partition (the only one, and the default).
PARTITION = "hztest"
#: The account root's jobs are charged to, when there is an accounting database.
ACCOUNT = "hzproj"
#: Binaries the fixture needs (Debian: slurm-wlm, slurmctld, slurmd, slurm-client, munge).
BINARIES = ("munged", "slurmctld", "slurmd", "sbatch", "squeue", "scancel", "scontrol", "sinfo")
#: ... and for accounts (Debian: slurmdbd, mariadb-server-core, mariadb-client-core).
ACCOUNTING_BINARIES = ("slurmdbd", "sacctmgr", "mariadbd", "mariadb-install-db")


class SlurmUnavailable(Exception):
    """Slurm cannot run here; the message says why (a missing binary, not root, a daemon
    that did not start and the end of its log)."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _tail(path: Path, n: int = 12) -> str:
    try:
        lines = path.read_text(errors="replace").splitlines()[-n:]
    except OSError:
        return f"({path} not written)"
    return "\n".join("    " + line for line in lines)


def _node_resources() -> tuple[int, int]:
    """CPUs and memory (MB) as slurmd sees this machine (``slurmd -C``), so that the node's
    configuration is accepted; memory less a margin for the OS and the test's own processes."""
    out = subprocess.run(["slurmd", "-C"], capture_output=True, text=True, timeout=30).stdout
    fields = dict(tok.split("=", 1) for tok in out.split() if "=" in tok)
    try:
        cpus, mem = int(fields["CPUs"]), int(fields["RealMemory"])
    except (KeyError, ValueError):
        raise SlurmUnavailable(f"slurmd -C did not print CPUs and RealMemory: {out!r}") from None
    return cpus, max(1024, mem - 1024)


@dataclass
class SlurmCluster:
    root: Path
    node: str
    cpus: int
    memory_mb: int
    partition: str = PARTITION
    procs: dict[str, subprocess.Popen] = field(default_factory=dict)
    #: None when accounts are enforced (slurmdbd running), else why not
    accounting: str | None = "not started"

    @property
    def conf(self) -> Path:
        return self.root / "slurm.conf"

    @property
    def env(self) -> dict[str, str]:
        """Variables for Slurm commands (and for a process that runs them, e.g. dask-jobqueue)."""
        return {"SLURM_CONF": str(self.conf)}

    def command(self, *args: str, timeout: float = 30, check: bool = True) -> str:
        r = subprocess.run(list(args), env={**os.environ, **self.env}, capture_output=True,
                           text=True, timeout=timeout)
        if check and r.returncode != 0:
            raise RuntimeError(f"{' '.join(args)}: exit {r.returncode}: {r.stderr.strip()}")
        return r.stdout

    def jobs(self, states: str = "all") -> list[dict[str, str]]:
        """Jobs slurmctld knows (pending, running and recently ended): id, name, state,
        reason, elapsed seconds (``squeue``)."""
        out = self.command("squeue", "--noheader", "--states", states,
                           "--format", "%i|%j|%T|%r|%M")
        jobs = []
        for line in out.splitlines():
            if line.strip():
                job_id, name, state, reason, elapsed = line.strip().split("|")
                jobs.append({"id": job_id, "name": name, "state": state, "reason": reason,
                             "elapsed": elapsed})
        return jobs

    def job_state(self, job_id: str) -> str:
        """RUNNING, PENDING, COMPLETED, CANCELLED, TIMEOUT ... (``scontrol show job``), or
        UNKNOWN once slurmctld has forgotten the job."""
        r = subprocess.run(["scontrol", "--oneliner", "show", "job", job_id],
                           env={**os.environ, **self.env}, capture_output=True, text=True,
                           timeout=30)
        for tok in r.stdout.split():
            if tok.startswith("JobState="):
                return tok.split("=", 1)[1]
        return "UNKNOWN"

    def cancel_all(self) -> None:
        """Cancel every job and wait (up to 30 s) until none is left running."""
        subprocess.run(["scancel", "--full", "--user", "root"], env={**os.environ, **self.env},
                       capture_output=True, timeout=30)
        t0 = time.monotonic()
        while time.monotonic() - t0 < 30:
            try:
                if not self.jobs("PENDING,RUNNING,COMPLETING,CONFIGURING,SUSPENDED"):
                    return
            except (RuntimeError, subprocess.TimeoutExpired):
                return
            time.sleep(0.2)

    def wait_idle(self, timeout: float = 30) -> None:
        """Wait until the node accepts jobs again (idle, not completing)."""
        t0 = time.monotonic()
        state = "?"
        while time.monotonic() - t0 < timeout:
            state = self.command("sinfo", "--noheader", "--Node", "--format", "%T").strip()
            if state == "idle":
                return
            time.sleep(0.2)
        raise RuntimeError(f"slurm node {self.node} not idle after {timeout} s (state {state})")

    def stop(self) -> None:
        """Cancel the jobs, stop the daemons (SIGTERM, then SIGKILL), keep the folder."""
        if "slurmctld" in self.procs and self.procs["slurmctld"].poll() is None:
            try:
                self.cancel_all()
            except Exception:
                pass
        for name in ("slurmd", "slurmctld", "slurmdbd", "mariadbd", "munged"):
            p = self.procs.get(name)
            if p is None or p.poll() is not None:
                continue
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(timeout=15)
        self.procs.clear()
        self.kill_strays()

    def kill_strays(self) -> None:
        """SIGKILL what is left of this Slurm: processes whose environment names its
        slurm.conf (the daemons, slurmstepd and the jobs' processes, which slurmd starts with
        SLURM_CONF set, and clients started with :attr:`env`), e.g. a job step that outlived
        a slurmd killed first. Nothing of another Slurm or test is touched."""
        mark = f"SLURM_CONF={self.conf}".encode() + b"\0"
        for entry in Path("/proc").iterdir():
            if not entry.name.isdigit() or int(entry.name) == os.getpid():
                continue
            try:
                if mark in (entry / "environ").read_bytes():
                    os.kill(int(entry.name), signal.SIGKILL)
            except (OSError, ProcessLookupError):
                pass


def _check_prerequisites() -> None:
    missing = [b for b in BINARIES if shutil.which(b) is None]
    if missing:
        raise SlurmUnavailable(
            f"Slurm is not installed here (missing {', '.join(missing)}; Debian: apt-get "
            "install slurm-wlm slurmctld slurmd slurm-client munge)")
    if os.geteuid() != 0:
        raise SlurmUnavailable("the single-node Slurm test runs its daemons as root "
                               f"(uid {os.geteuid()} here)")


def _write_config(c: SlurmCluster, ctld_port: int, slurmd_port: int,
                  dbd_port: int | None) -> None:
    r = c.root
    if dbd_port is None:
        accounting = "AccountingStorageType=accounting_storage/none"
    else:
        accounting = (f"AccountingStorageType=accounting_storage/slurmdbd\n"
                      f"AccountingStorageHost=127.0.0.1\nAccountingStoragePort={dbd_port}\n"
                      f"# the munge socket for slurmdbd (AuthInfo is not used for it)\n"
                      f"AccountingStoragePass={r}/munge/munge.socket\n"
                      f"# a job must name an account its user has (or take the default one)\n"
                      f"AccountingStorageEnforce=associations")
    c.conf.write_text(f"""\
# written by tests/end_to_end/slurm_cluster.py: one node, one partition, no cgroups;
# every path is under {r}
ClusterName=hztest
SlurmctldHost={c.node}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={r}/munge/munge.socket
StateSaveLocation={r}/state
SlurmdSpoolDir={r}/spool
SlurmctldPidFile={r}/slurmctld.pid
SlurmdPidFile={r}/slurmd.pid
SlurmctldLogFile={r}/slurmctld.log
SlurmdLogFile={r}/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
{accounting}
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
# a job's processes get SIGTERM at its time limit or scancel, then SIGKILL 2 s later
KillWait=2
OverTimeLimit=0
MinJobAge=600
InactiveLimit=0
SlurmctldTimeout=30
SlurmdTimeout=60
MessageTimeout=20
# sbatch refuses at submission what the partition cannot give (time, nodes, memory)
EnforcePartLimits=ALL
NodeName={c.node} NodeAddr=127.0.0.1 CPUs={c.cpus} RealMemory={c.memory_mb} State=UNKNOWN
PartitionName={c.partition} Nodes={c.node} Default=YES MaxTime=60 State=UP
""")


def _start_accounting(c: SlurmCluster, timeout: float, dbd_port: int) -> None:
    """MariaDB (its own data folder and port), slurmdbd on ``dbd_port``, and the cluster,
    account and user in its database. Raises SlurmUnavailable when something does not
    start."""
    r = c.root
    db_port = _free_port()
    install_log = r / "mariadb-install.log"
    with open(install_log, "wb") as log:
        done = subprocess.run(["mariadb-install-db", "--no-defaults", f"--datadir={r}/db",
                               "--user=root", "--auth-root-authentication-method=normal",
                               "--skip-test-db"], stdout=log, stderr=subprocess.STDOUT,
                              timeout=120)
    if done.returncode != 0:
        raise SlurmUnavailable(f"mariadb-install-db failed:\n{_tail(install_log)}")
    db_log = r / "mariadbd.log"
    _start_daemon(c, "mariadbd", [
        "mariadbd", "--no-defaults", f"--datadir={r}/db", "--user=root",
        "--bind-address=127.0.0.1", f"--port={db_port}", f"--socket={r}/mariadbd.sock",
        f"--pid-file={r}/mariadbd.pid", f"--log-error={db_log}",
        "--innodb-buffer-pool-size=16M"], db_log)

    def db_up() -> bool:
        with socket.socket() as s:
            return s.connect_ex(("127.0.0.1", db_port)) == 0
    _wait(c, "mariadbd", db_up, timeout, db_log)
    dbd_conf = r / "slurmdbd.conf"
    dbd_conf.write_text(f"""\
AuthType=auth/munge
AuthInfo=socket={r}/munge/munge.socket
DbdHost={c.node}
DbdAddr=127.0.0.1
DbdPort={dbd_port}
SlurmUser=root
LogFile={r}/slurmdbd.log
PidFile={r}/slurmdbd.pid
StorageType=accounting_storage/mysql
StorageHost=127.0.0.1
StoragePort={db_port}
StorageUser=root
StorageLoc=hztest_accounting
""")
    os.chmod(dbd_conf, 0o600)      # slurmdbd refuses a config others can read
    dbd_log = r / "slurmdbd.log"
    # (slurmdbd reads slurmdbd.conf from the folder of SLURM_CONF)
    _start_daemon(c, "slurmdbd", ["slurmdbd", "-D"], dbd_log)
    _wait(c, "slurmdbd", lambda: c.command("sacctmgr", "--noheader", "show", "cluster",
                                           timeout=5) is not None, timeout, dbd_log)
    for args in (["add", "cluster", "hztest"], ["add", "account", ACCOUNT],
                 ["add", "user", "root", f"account={ACCOUNT}"]):
        c.command("sacctmgr", "--immediate", *args, timeout=30)


def _die_with_parent() -> None:
    """In the daemon, before exec: SIGTERM when the process that started it dies (a test
    run killed without its teardown leaves no Slurm behind)."""
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _start_daemon(c: SlurmCluster, name: str, args: list[str], log: Path) -> None:
    out = open(c.root / f"{name}.stdout", "wb")
    env = {**os.environ, **c.env}
    try:
        c.procs[name] = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT,
                                         stdin=subprocess.DEVNULL, env=env,
                                         start_new_session=True, preexec_fn=_die_with_parent)
    finally:
        out.close()


def _wait(c: SlurmCluster, name: str, ready, timeout: float, log: Path) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        p = c.procs[name]
        if p.poll() is not None:
            raise SlurmUnavailable(f"{name} exited with code {p.returncode} at start; its "
                                   f"log ({log}):\n{_tail(log)}\n{_tail(c.root / (name + '.stdout'))}")
        try:
            if ready():
                return
        except (RuntimeError, subprocess.TimeoutExpired, OSError):
            pass
        time.sleep(0.1)
    raise SlurmUnavailable(f"{name} not ready after {timeout:.0f} s; its log ({log}):\n{_tail(log)}")


def start_slurm(root: Path | None = None, *, timeout: float = 60) -> SlurmCluster:
    """Start munged, the accounting database (MariaDB, slurmdbd) when it is installed,
    slurmctld and slurmd under ``root`` (a new temporary folder by default, removed again if
    the start fails) and wait until the node is idle. Raises SlurmUnavailable (everything
    started is stopped)."""
    _check_prerequisites()
    made_root = root is None
    root = Path(root or tempfile.mkdtemp(prefix="hzslurm-"))
    for sub in ("munge", "state", "spool"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    os.chmod(root / "munge", 0o700)
    cpus, memory_mb = _node_resources()
    c = SlurmCluster(root=root, node=socket.gethostname().split(".")[0], cpus=cpus,
                     memory_mb=memory_mb)
    try:
        key = root / "munge" / "munge.key"
        if not key.exists():
            key.write_bytes(os.urandom(1024))
        os.chmod(key, 0o400)
        munge_log = root / "munged.log"
        # --force: munged refuses to run as root otherwise
        munged_args = [
            "munged", "--foreground", "--force", f"--socket={root}/munge/munge.socket",
            f"--key-file={key}", f"--pid-file={root}/munge/munged.pid",
            f"--log-file={munge_log}", f"--seed-file={root}/munge/munged.seed",
            "--num-threads=4"]
        _start_daemon(c, "munged", munged_args, munge_log)
        _wait(c, "munged", lambda: (root / "munge" / "munge.socket").exists(), 15, munge_log)

        missing = [b for b in ACCOUNTING_BINARIES if shutil.which(b) is None]
        dbd_port = None if missing else _free_port()
        if missing:
            c.accounting = (f"no accounting database (missing {', '.join(missing)}; Debian: "
                            "apt-get install slurmdbd mariadb-server-core)")
        # (sacctmgr and slurmdbd find each other through slurm.conf)
        ports = _free_port(), _free_port()
        _write_config(c, *ports, dbd_port)
        if dbd_port is not None:
            try:
                _start_accounting(c, timeout, dbd_port)
                c.accounting = None
            except (SlurmUnavailable, RuntimeError, subprocess.TimeoutExpired) as exc:
                # the rest of Slurm is still worth testing: without accounts
                c.accounting = f"the accounting database did not start: {exc}"
                c.stop()
                _write_config(c, *ports, None)
                _start_daemon(c, "munged", munged_args, munge_log)
                _wait(c, "munged", lambda: (root / "munge" / "munge.socket").exists(), 15,
                      munge_log)
        ctld_log = root / "slurmctld.log"
        # -i: ignore state files of an earlier start in this folder; -D: foreground
        _start_daemon(c, "slurmctld", ["slurmctld", "-D", "-i", "-f", str(c.conf)], ctld_log)
        _wait(c, "slurmctld", lambda: "UP" in c.command("scontrol", "ping", timeout=5),
              timeout, ctld_log)
        slurmd_log = root / "slurmd.log"
        _start_daemon(c, "slurmd", ["slurmd", "-D", "-f", str(c.conf)], slurmd_log)
        _wait(c, "slurmd", lambda: c.command("sinfo", "--noheader", "--Node", "--format",
                                             "%T", timeout=5).strip() == "idle",
              timeout, slurmd_log)
    except BaseException:
        c.stop()
        if made_root:
            shutil.rmtree(root, ignore_errors=True)
        raise
    return c


if __name__ == "__main__":  # pragma: no cover (by hand)
    import sys
    cluster = start_slurm(Path(sys.argv[1]) if len(sys.argv) > 1 else None)
    print(f"export SLURM_CONF={cluster.conf}   # node {cluster.node}: {cluster.cpus} CPUs, "
          f"{cluster.memory_mb} MB; partition {cluster.partition}", flush=True)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    try:
        signal.pause()
    except KeyboardInterrupt:
        pass
    finally:
        cluster.stop()
