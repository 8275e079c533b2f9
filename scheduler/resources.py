"""What a run needs (disk, inodes, the client's memory), checked before anything is written."""
from __future__ import annotations

import math
import os
import shutil
from pathlib import Path

from hertzmap.scheduler.errors import RunError
from hertzmap.scheduler.stages.plan import Plan
from hertzmap.scheduler.doors.report import fmt_bytes
from hertzmap.study.schema import SLOT_CHUNK, bytes_per_point, stored_variables
from hertzmap.study.spec import Study

#: Bytes the client holds per task while a study runs (plan, spec, future, bookkeeping).
CLIENT_BYTES_PER_TASK = 8_000
#: Refuse when the store's estimate exceeds this fraction of the free disk space / inodes.
DISK_MARGIN = 0.95
#: Set to 1 to skip the disk-space check (e.g. the store compresses far below its
#: uncompressed estimate, or a file system that misreports its free space).
SKIP_SPACE_ENV = "HERTZMAP_SKIP_SPACE_CHECK"


def _existing_parent(path: Path) -> Path:
    p = Path(path).absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _available_memory() -> int | None:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def resource_estimate(study: Study, plan: Plan) -> dict[str, int]:
    """Bytes and files a run needs: the store (uncompressed), its chunk files, the client's
    memory, one block in a worker's memory."""
    bpp = bytes_per_point(study)
    n_tasks = len(plan.tasks)
    block_points = math.prod(plan.chunks)
    return {
        "store_bytes": study.size * bpp + n_tasks * 64,
        "store_files": n_tasks * (len(stored_variables(study)) + 1) + 64,
        "client_bytes": n_tasks * CLIENT_BYTES_PER_TASK + 4 * block_points * bpp
        + 64 * sum(study.shape),
        "block_bytes": 4 * block_points * bpp,
    }


def check_resources(study: Study, plan: Plan, store_path: Path, *, new_store: bool) -> dict[str, int]:
    """Refuse (RunError naming ``grid``) a study whose store cannot fit on the disk of
    ``store_path`` or whose bookkeeping cannot fit in this machine's memory. Reads only."""
    est = resource_estimate(study, plan)
    where = _existing_parent(store_path)
    shape = " x ".join(str(n) for n in study.shape)
    if new_store and os.environ.get(SKIP_SPACE_ENV, "") not in ("1", "true", "yes"):
        try:
            free = shutil.disk_usage(where).free
            vfs = os.statvfs(where)
            free_files = vfs.f_favail if vfs.f_files else None
        except OSError:
            free, free_files = None, None
        if free is not None and est["store_bytes"] > DISK_MARGIN * free:
            raise RunError(
                f"grid: {shape} points need a store of about "
                f"{fmt_bytes(est['store_bytes'])} (uncompressed, {SLOT_CHUNK} orbits a point), "
                f"more than the {fmt_bytes(free)} free at {where}; split the study, store "
                f"fewer products, or --store on a larger disk "
                f"({SKIP_SPACE_ENV}=1 to skip this check)")
        if free_files is not None and est["store_files"] > DISK_MARGIN * free_files:
            raise RunError(
                f"grid: the store needs about {est['store_files']} files (one per chunk and "
                f"variable), more than the {free_files} free inodes at {where}; raise "
                f"--task-seconds (fewer, larger chunks) or split the study")
    mem = _available_memory()
    if mem is not None and est["client_bytes"] > mem:
        raise RunError(
            f"grid: {shape} points in {len(plan.tasks)} tasks need about "
            f"{fmt_bytes(est['client_bytes'])} of memory in the client, more than the "
            f"{fmt_bytes(mem)} available; raise --task-seconds or split the study")
    return est
