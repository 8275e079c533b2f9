"""What ``hertzmap status`` says of a store: its study, tasks, dims, variables, what it holds,
its lock, and (``--check``) the damaged blocks of the tasks flagged done."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from hertzmap.scheduler.errors import StoreError
from hertzmap.scheduler.store.lock import lock_path
from hertzmap.scheduler.store.store_handle import Store
from hertzmap.study.schema import (VARIABLES, StoreFormatError, check_format, stored_variables,
                                   study_from_attrs)
from hertzmap.study.spec import StudyError

def store_status(path: str | Path, check: bool = False) -> dict[str, Any]:
    """Summary of a store for ``hertzmap status``. ``check``: also verify every chunk of the
    tasks flagged done (``damaged``: {"i-j-k": [problems]})."""
    store = Store(path)
    done = store.done_mask()
    info = dict(store.info)
    info.update(path=str(store.path), tasks_total=int(done.size), tasks_done=int(done.sum()),
                chunk_shape=list(store.chunks))
    try:
        check_format(store.attrs, str(store.path))
        info["format_note"] = None
    except StoreFormatError as exc:
        info["format_note"] = str(exc)
    ds = xr.open_zarr(store.path, consolidated=True)
    info["dims"] = {k: int(v) for k, v in ds.sizes.items()}
    info["variables"] = [n for n in ds.data_vars if n in VARIABLES]
    if info["format_note"] is None:
        try:
            info["contents"] = store_contents(ds)
        except Exception:       # a damaged chunk (--check names it): no counts, not a crash
            info["contents"] = None
    lock = lock_path(store.path)
    try:
        info["locked_by"] = json.loads(lock.read_text()) if lock.exists() else None
    except (OSError, ValueError):
        info["locked_by"] = {"host": "?", "pid": "? (unreadable lock file)"}
    if check:
        from hertzmap.scheduler.stages.plan import make_plan

        try:
            study = study_from_attrs(store.attrs)
        except StudyError as exc:
            raise StoreError(f"{store.path}: the study recorded in the store is invalid ({exc})") from None
        plan = make_plan(study, store.chunks)
        flagged = [t for t in plan.tasks if done[t.index]]
        damaged = store.verify(flagged, stored_variables(study))
        for idx in store.unreadable_flags():
            damaged.setdefault(idx, []).append("task_done: flag unreadable")
        info["damaged"] = {"-".join(map(str, k)): v for k, v in sorted(damaged.items())}
    return info


def store_contents(ds: xr.Dataset) -> dict[str, Any]:
    """What a store holds, counted (``hertzmap status``): converged orbits, stable ones, the
    most at a point; the census's attractors by kind and the most at a point."""
    from hertzmap.kernels.records import ATTRACTOR_KINDS

    status = np.asarray(ds["status"].values)
    ok = status == 0
    out: dict[str, Any] = {"orbits": int(ok.sum()),
                           "most_orbits_at_a_point": int((status != -1).sum(-1).max(initial=0))}
    if "stable" in ds:
        out["stable_orbits"] = int((ok & np.asarray(ds["stable"].values)).sum())
    if "attractor_kind" in ds:
        kinds = np.asarray(ds["attractor_kind"].values)
        out["attractors"] = {k: int((kinds == c).sum()) for k, c in ATTRACTOR_KINDS.items()}
        out["most_attractors_at_a_point"] = int((kinds > 0).sum(-1).max(initial=0))
    return out
