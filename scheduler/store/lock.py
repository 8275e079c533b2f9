"""The lock that keeps one client per store (STORE.lock next to it), and the check a worker
makes before it writes into a store: that the lock still holds the client that sent its task."""
from __future__ import annotations

import json
import os
import socket
import uuid
from pathlib import Path
from typing import Any

from hertzmap.scheduler.errors import StoreError
from hertzmap.scheduler.store.layout import read_attrs

LOCK_SUFFIX = ".lock"      # the lock of STORE is the file STORE.lock next to it


def lock_path(store_path: str | Path) -> Path:
    p = Path(store_path)
    return p.with_name(p.name + LOCK_SUFFIX)


class Lock:
    """A lock file next to the store (STORE.lock): one client per store. Stale locks (dead
    pid on this host) are taken over; a lock from another host must be removed by hand."""

    def __init__(self, store_path: str | Path):
        self.path = lock_path(store_path)
        self.held = False
        #: what the lock file holds while this client holds it (host, pid, token): the tasks
        #: carry it to their workers (check_writer)
        self.owner: dict[str, Any] | None = None

    def acquire(self) -> None:
        # the token tells this client's lock from a later one of the same host and pid: a
        # worker compares the whole record before writing (check_writer)
        me = {"host": socket.gethostname(), "pid": os.getpid(), "token": uuid.uuid4().hex}
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    other = json.loads(self.path.read_text())
                except (OSError, ValueError):
                    other = {}
                if other.get("host") == me["host"] and not _pid_alive(other.get("pid")):
                    self.path.unlink(missing_ok=True)      # stale: its client died
                    continue
                raise StoreError(
                    f"{self.path.with_suffix('')} is in use by another hertzmap client "
                    f"(host {other.get('host')}, pid {other.get('pid')}); if that client is "
                    f"dead, delete {self.path}") from None
            with os.fdopen(fd, "w") as f:
                json.dump(me, f)
            self.held = True
            self.owner = me
            return
        raise StoreError(f"cannot lock {self.path}")

    def release(self) -> None:
        if self.held:
            self.path.unlink(missing_ok=True)
            self.held = False

    def __enter__(self):
        self.acquire()
        return self

    def __exit__(self, *exc):
        self.release()


def _pid_alive(pid: Any) -> bool:
    if not isinstance(pid, int) or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def shared_store_hint(path: str | Path) -> str:
    return (f"hertzmap's workers write their blocks into the store themselves, so {path} must be "
            "on a file system that the workers share with the client, at the same path "
            "(docs/running.md, \"Workers write the store\")")


def check_writer(path: str | Path, owner: dict[str, Any]) -> None:
    """Raise StoreError unless the store's lock file holds ``owner``: the client that sent the
    task still holds the store. A worker that does not see the store (no shared file system)
    is told so; a worker of a client that died or ended never writes into a store that a
    later client holds."""
    path = Path(path)
    where = f"worker on {socket.gethostname()} (pid {os.getpid()})"
    try:
        held = json.loads(lock_path(path).read_text())
    except FileNotFoundError:
        if read_attrs(path) is None:
            raise StoreError(f"{where}: no hertzmap store at {path}: "
                             + shared_store_hint(path)) from None
        raise StoreError(f"{where}: {path} is not locked by the client that sent this task "
                         "(it has ended): not writing") from None
    except (OSError, ValueError) as exc:
        raise StoreError(f"{where}: cannot read the lock {lock_path(path)} "
                         f"({type(exc).__name__}: {exc}): not writing") from None
    if held != owner:
        raise StoreError(f"{where}: {path} is held by another client (host {held.get('host')}, "
                         f"pid {held.get('pid')}), not by the one that sent this task (host "
                         f"{owner.get('host')}, pid {owner.get('pid')}): not writing")
