"""The zarr store of a study: create it from the template, check it, write blocks, mark tasks,
write products, and the lock that keeps one client per store. Every write into a store and
every lock of hertzmap is here.

One client per store (``Lock``), many writers of blocks: the client writes the template once
with ``to_zarr(compute=False)`` (metadata, coordinates, an all-False ``task_done``); each task's
worker writes its own block (:func:`write_task_block`: a region write of whole chunks,
coordinates dropped, never ``mode="a"``; no two tasks share a chunk, so no lock is needed
between them) and returns a summary, and only then does the client set the task's
``task_done`` flag. A flag is therefore never set for a block that is not fully written; a
block written but not flagged (a worker or the client killed in between) is simply recomputed
on resume and rewritten with identical values. A worker writes only while the lock file holds
the very client that sent its task (:func:`check_writer`): a worker of a client that died
never writes into a store another client has taken over, and a worker that does not see the
client's file system is told so instead of writing elsewhere.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import shutil
import socket
import uuid
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
import zarr
# zarr's own bridge into its event loop (what Array.__setitem__ calls), to run the writes of
# all of a block's variables in one call
from zarr.core.sync import sync as zarr_sync

from hertzmap.scheduler.errors import StoreError
from hertzmap.study.schema import (FORMAT_ADVICE, PRODUCT_GROUP, SLOT_CHUNK, SLOT_DIMS,
                                   STORE_FORMAT, VARIABLES, StoreFormatError, array_slots,
                                   check_format,
                                   history_line, pad_slots, parse_attrs, stored_variables,
                                   study_from_attrs, template)
from hertzmap.study.spec import Study, StudyError

ALL_CHUNKS_ATTR = "hertzmap_all_chunks_written"
#: the most entries any point of the store holds along each slot dim so far (study.schema
#: SLOT_DIMS), kept by the client as blocks and atlas rounds are written: the length the dims
#: are cut to when the run ends (Store.settle_slots)
SLOTS_USED_ATTR = "hertzmap_slots_used"
LOCK_SUFFIX = ".lock"      # the lock of STORE is the file STORE.lock next to it


def lock_path(store_path: str | Path) -> Path:
    p = Path(store_path)
    return p.with_name(p.name + LOCK_SUFFIX)


@contextlib.contextmanager
def _quiet():
    # zarr warns that consolidated metadata is not part of the v3 spec; we use it on purpose
    # so that xr.open_zarr(path) opens the store quickly and silently.
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Cc]onsolidated metadata.*")
        # the traced curves' parts folder (CURVE_PARTS) and the stages' staging folders
        # (ATLAS_STAGE, SWEEP_STAGE) are not zarr nodes of the store
        warnings.filterwarnings("ignore", message=".*not recognized as a component of a Zarr")
        yield


def read_attrs(path: str | Path) -> dict[str, Any] | None:
    """Root attrs of a zarr store, or None when ``path`` is not a zarr (v3) group."""
    meta = Path(path) / "zarr.json"
    if not meta.is_file():
        return None
    try:
        doc = json.loads(meta.read_text())
    except (OSError, ValueError):
        return None
    if doc.get("node_type") != "group":
        return None
    return doc.get("attributes", {})


def store_attrs(path: str | Path) -> dict[str, Any]:
    """Root attrs of a store this version reads: StoreError when ``path`` is not a zarr store
    or holds another layout (study.schema.check_format's message: its format, what to do)."""
    attrs = read_attrs(path)
    if attrs is None:
        raise StoreError(f"{path} is not a zarr store")
    try:
        check_format(attrs, str(path))
    except StoreFormatError as exc:
        raise StoreError(str(exc)) from None
    return attrs


def read_done_flags(path: str | Path) -> np.ndarray:
    """The task_done flags of a store, read only (cheap: for a page or a client polling a store
    that another process writes)."""
    with _quiet():
        group = zarr.open_group(zarr.storage.LocalStore(Path(path), read_only=True), mode="r",
                                zarr_format=3, use_consolidated=False)
        return np.asarray(group["task_done"][...], bool)


class Store:
    """An existing hertzmap store (opened for writing by the single client)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        attrs = read_attrs(self.path)
        if attrs is None or "hertzmap_study_hash" not in attrs:
            raise StoreError(f"{self.path} is not a hertzmap store")
        self.attrs = attrs
        self.info = parse_attrs(attrs)
        self.study_hash: str = attrs["hertzmap_study_hash"]
        self.chunks = tuple(int(c) for c in attrs["hertzmap_chunk_shape"])
        self._group = zarr.open_group(zarr.storage.LocalStore(self.path), mode="r+",
                                      zarr_format=3, use_consolidated=False)
        self._done = self._group["task_done"]
        self._writer: BlockWriter | None = None

    # -- creation -------------------------------------------------------------------------
    @classmethod
    def create(cls, path: str | Path, study: Study, chunks: tuple[int, int, int],
               action: str) -> "Store":
        """Write the template of ``study`` at ``path`` (which must not exist)."""
        import dask.array  # the template is chunked lazily with Dask

        path = Path(path)
        ds = template(study, chunks, history=history_line(action))
        enc = {name: dict(ds[name].encoding) for name in ds.variables}
        # Each variable chunked as dask.array.full, not ds.chunk(): xarray's chunk() copies the
        # template's zero-copy broadcasts into memory (the whole store uncompressed: 2.7 GB per
        # 10^6 points of the default products, a 10^7-point store could not be created on a
        # 24 GB client); the written template is the same
        along = dict(zip(("omega", "sigma", "zeta"), ds.attrs["hertzmap_chunk_shape"]))
        lazy = ds.copy()
        for name, var in ds.data_vars.items():
            lazy[name] = var.copy(data=dask.array.full(
                var.shape, np.asarray(var.data).flat[0], dtype=var.dtype,
                chunks=tuple(min(along.get(d, n), n) for d, n in zip(var.dims, var.shape))))
        # task_done must be written now (not lazily): keep it numpy-backed
        lazy["task_done"] = ds["task_done"]
        # every block write stores all its chunks (even all-fill ones): a done task whose
        # chunk file is missing is then known to be damaged (see verify)
        lazy.attrs[ALL_CHUNKS_ATTR] = True
        for name in lazy.variables:
            lazy[name].encoding = enc[name]
        path.parent.mkdir(parents=True, exist_ok=True)
        # Written next to its place, then renamed into it (atomic on one file system): a reader
        # finds no store or a whole one with its consolidated metadata, never one half made,
        # and a creation cut short leaves nothing at ``path``.
        building = path.parent / f".{path.name}.creating"
        if building.exists():
            shutil.rmtree(building)         # left by a creation cut short
        with _quiet():
            lazy.to_zarr(zarr.storage.LocalStore(building), mode="w-", compute=False,
                         zarr_format=3, consolidated=True)
        os.rename(building, path)
        return cls(path)

    # -- checks ---------------------------------------------------------------------------
    def check(self, study: Study) -> None:
        """Raise StoreError unless this store holds ``study`` and is complete (template-wise)."""
        if self.study_hash != study.hash:
            raise StoreError(
                f"{self.path} holds another study ({self.info['hertzmap_study_name']!r}, "
                f"hash {self.study_hash[:12]}), not {study.name!r} (hash {study.hash[:12]}); "
                "use --overwrite to replace it, or --store to choose another path")
        found = self.attrs.get("hertzmap_store_format")
        if found != STORE_FORMAT:
            advice = FORMAT_ADVICE.get(found, "written by another version of hertzmap")
            raise StoreError(f"{self.path}: store format {found}, this hertzmap writes format "
                             f"{STORE_FORMAT}: {advice}")
        with _quiet():          # a stage's staging folder (atlas, sweeps) is no zarr node
            members = set(self._group.array_keys())
        missing = [n for n in stored_variables(study) if n not in members]
        if missing:
            raise StoreError(f"{self.path} is incomplete (missing {', '.join(missing)})")

    # -- task state -----------------------------------------------------------------------
    def done_mask(self) -> np.ndarray:
        """The task_done flags. A flag chunk that cannot be read (truncated file) counts as
        not done (the task is recomputed): see :meth:`unreadable_flags`."""
        try:
            return np.asarray(self._done[...], dtype=bool)
        except Exception:
            mask = np.zeros(self._done.shape, dtype=bool)
            for idx in np.ndindex(*self._done.shape):
                try:
                    mask[idx] = bool(self._done[idx])
                except Exception:
                    mask[idx] = False
            return mask

    def unreadable_flags(self) -> list[tuple[int, int, int]]:
        """Chunk indices whose task_done flag file exists but cannot be decoded."""
        bad = []
        try:
            self._done[...]
            return bad
        except Exception:
            pass
        for idx in np.ndindex(*self._done.shape):
            try:
                self._done[idx]
            except Exception:
                bad.append(tuple(int(i) for i in idx))
        return bad

    def mark_done(self, index: tuple[int, int, int]) -> None:
        self._done[index] = True

    def unmark(self, index: tuple[int, int, int]) -> None:
        self._done[index] = False

    def _chunk_file(self, name: str, index: tuple[int, ...]) -> Path:
        arr = self._group[name]
        extra = (0,) * (arr.ndim - len(index))
        return self.path / name / "c" / "/".join(str(int(i)) for i in (*index, *extra))

    def verify(self, tasks, names: tuple[str, ...]) -> dict[tuple[int, int, int], list[str]]:
        """Check the chunks of tasks flagged done: each stored variable's chunk must exist (in
        stores that write every chunk) and decode. Returns {task index: [problems]} for the
        damaged ones (empty when all is well). Reads every chunk of those tasks."""
        all_written = bool(self.attrs.get(ALL_CHUNKS_ATTR))
        damaged: dict[tuple[int, int, int], list[str]] = {}
        arrays = {n: self._group[n] for n in names}
        for t in tasks:
            problems = []
            for name, arr in arrays.items():
                f = self._chunk_file(name, t.index)
                if not f.is_file():
                    if all_written:
                        problems.append(f"{name}: chunk file missing")
                    continue
                block = tuple(t.index) + (0,) * (arr.ndim - 3)
                try:
                    arr.get_block_selection(block)
                except Exception as exc:
                    problems.append(f"{name}: chunk unreadable ({type(exc).__name__})")
            if problems:
                damaged[tuple(t.index)] = problems
        return damaged

    # -- data -----------------------------------------------------------------------------
    def write_block(self, slices: tuple[slice, slice, slice], arrays: dict[str, np.ndarray],
                    names: tuple[str, ...]) -> None:
        """Region write of one block (whole chunks) of every variable in ``names``
        (:class:`BlockWriter`), the store's slot dims grown first where the block holds more
        than they have room for: the grid's blocks that did not fit, the atlas's commits, and
        tests. The client's alone (it holds the store's lock)."""
        block = {n: arrays[n] for n in names}
        self.note_slots_used(slots_used(block))
        need = array_slots(block)
        have = self.slot_extents()
        if any(need[d] > have[d] for d in have):
            self.settle_slots({d: max(need[d], have[d]) for d in have})
        if self._writer is None:
            self._writer = BlockWriter(self._group, self.chunks, bool(self.attrs.get(ALL_CHUNKS_ATTR)))
        if not self._writer.write(slices, arrays, names):
            raise StoreError(f"{self.path}: a block holds more slots than its dims after they "
                             "grew (another process resized the store?)")

    # -- the slot dims (study.schema.SLOT_DIMS: sized by the data) ---------------------------
    def _slot_arrays(self) -> dict[str, list[str]]:
        """The stored arrays of each slot dim (its coordinate first)."""
        with _quiet():
            members = set(self._group.array_keys())
        out = {d: [d] if d in members else [] for d in SLOT_DIMS}
        for name in sorted(members):
            v = VARIABLES.get(name)
            if v is not None and v.slot_dim is not None:
                out[v.slot_dim].append(name)
        return out

    def slot_extents(self) -> dict[str, int]:
        """The length of each slot dim in the store (the longest of its arrays: a resize cut
        short may have left some shorter)."""
        out = {}
        for dim, names in self._slot_arrays().items():
            out[dim] = max((self._group[n].shape[3 if n != dim else 0] for n in names), default=0)
        return out

    def slots_used(self) -> dict[str, int]:
        """The most entries any point holds along each slot dim (SLOTS_USED_ATTR; 1 before
        any block is written)."""
        used = self.attrs.get(SLOTS_USED_ATTR) or {}
        return {d: max(1, int(used.get(d, 1))) for d in SLOT_DIMS}

    def note_slots_used(self, used: dict[str, int]) -> None:
        """Record that a block written (or about to be) holds ``used`` entries along the slot
        dims, where that is more than any before."""
        now = self.slots_used()
        if any(int(used.get(d, 0)) > now[d] for d in now):
            self.set_attrs(**{SLOTS_USED_ATTR: {d: max(now[d], int(used.get(d, 0)))
                                                for d in now}})

    def settle_slots(self, want: dict[str, int] | None = None) -> dict[str, int]:
        """Make every array of each slot dim, and the dim's coordinate, ``want[dim]`` long (by
        default: the most entries any point holds, SLOTS_USED_ATTR, the end of a run), never
        shorter than a point's entries. A resize is a metadata write (the chunks along the
        dims are SLOT_CHUNK long: the chunks written stay where they are; growing adds room,
        cutting removes only empty slots); a resize cut short by a kill is made whole by the
        next call (every run calls it when it starts and when it ends). Returns the lengths."""
        used = self.slots_used()
        target = {d: max(int((want or used)[d]), used[d]) for d in SLOT_DIMS}
        changed = False
        with _quiet():
            for dim, names in self._slot_arrays().items():
                for name in names:
                    arr = self._group[name]
                    axis = 0 if name == dim else 3
                    if arr.shape[axis] == target[dim]:
                        continue
                    shape = list(arr.shape)
                    shape[axis] = target[dim]
                    arr.resize(tuple(shape))
                    if name == dim:
                        arr[:] = np.arange(target[dim], dtype=arr.dtype)
                    changed = True
            if changed:
                zarr.consolidate_metadata(zarr.storage.LocalStore(self.path))
                self.attrs = read_attrs(self.path) or self.attrs
                self._writer = None
        return target

    def set_attrs(self, **attrs: Any) -> None:
        """Update root attrs in one atomic rewrite of the root zarr.json that keeps its
        consolidated metadata. Written through a handle opened without it, zarr.json lost
        the consolidated metadata until the next consolidate_metadata: a reader opening the
        store meanwhile (``xr.open_zarr`` during a run) fell back to listing the directory,
        with warnings, and met zarr's temporary ``.partial`` files."""
        store = zarr.storage.LocalStore(self.path)
        with _quiet():
            try:
                group = zarr.open_group(store, mode="r+", zarr_format=3, use_consolidated=True)
            except ValueError:      # no consolidated metadata (yet): write, then consolidate
                group = zarr.open_group(store, mode="r+", zarr_format=3, use_consolidated=False)
                group.attrs.update(attrs)
                zarr.consolidate_metadata(store)
            else:
                group.attrs.update(attrs)
        self.attrs = read_attrs(self.path) or self.attrs

    def add_history(self, action: str) -> None:
        hist = self.attrs.get("history", "")
        self.set_attrs(history=(hist + "\n" if hist else "") + history_line(action))


class BlockWriter:
    """The arrays of a store's main group, each opened once, for region writes of whole blocks.

    Byte-for-byte what ``block_dataset(...).to_zarr(region=...)`` writes (the stored dtypes
    are the VARIABLES dtypes and no variable has a CF scale or offset; tested), at a third
    of its cost: xarray's region write re-opens and re-validates every array on each call,
    and zarr then runs one event-loop round trip per variable."""

    def __init__(self, group: zarr.Group, chunks: tuple[int, ...], all_chunks: bool):
        self._group = group
        self.chunks = tuple(int(c) for c in chunks)
        #: every chunk of a block is written, even all-fill ones, in stores that require it:
        #: a done task whose chunk file is missing is then known to be damaged (Store.verify)
        self.all_chunks = all_chunks
        self._arrays: dict[str, zarr.Array] = {}

    def _array(self, name: str) -> zarr.Array:
        arr = self._arrays.get(name)
        if arr is None:
            arr = self._arrays[name] = self._group[name].with_config(
                {"write_empty_chunks": self.all_chunks})
        return arr

    def _extent(self, name: str) -> int:
        """The length of a slot variable's slot dim in the store (its metadata read again
        when the cached array is shorter than asked: the client may have grown it since)."""
        return self._array(name).shape[3]

    def fits(self, arrays: dict[str, np.ndarray], names: tuple[str, ...]) -> bool:
        """The block's slots fit in the store's slot dims (re-read once if not: the client
        may have grown them since the arrays were opened)."""
        need = array_slots({n: arrays[n] for n in names})
        slot_names = [n for n in names if VARIABLES[n].slot_dim is not None]
        if all(need[VARIABLES[n].slot_dim] <= self._extent(n) for n in slot_names):
            return True
        for n in slot_names:
            self._arrays.pop(n, None)
            self._arrays.pop((n, "tail"), None)
        return all(need[VARIABLES[n].slot_dim] <= self._extent(n) for n in slot_names)

    def write(self, slices: tuple[slice, slice, slice], arrays: dict[str, np.ndarray],
              names: tuple[str, ...]) -> bool:
        """Every variable in ``names`` of one block, all in one call into zarr's event loop
        (its writes run concurrently). Per-block variables (dim ``omega_block``: the located
        bifurcation points) go to the block's own omega_block entry: one writer per chunk.
        Along a slot dim, every chunk of the block is written: its first (always stored, so a
        done block's missing chunk is known as damage) and the others up to the store's length
        (stored where they hold something, removed where empty: a chunk of an earlier write
        of the block is never left behind). Returns False, writing nothing, when the block
        holds more slots than the store's dims (the client grows them: Store.write_block)."""
        if not self.fits(arrays, names):
            return False
        ib = slices[0].start // self.chunks[0]
        jobs = []
        for name in names:
            v = VARIABLES[name]
            arr = self._array(name)
            lead = (slice(ib, ib + 1), slices[1], slices[2]) if v.layout == "line" else tuple(slices)
            data = np.asarray(arrays[name]).astype(v.dtype, copy=False)
            if v.slot_dim is not None:
                extent = arr.shape[3]
                data = pad_slots({name: data}, {v.slot_dim: extent})[name]
                first = min(SLOT_CHUNK, extent)
                head = lead + (slice(0, first),) + (slice(None),) * (arr.ndim - 4)
                jobs.append(arr.async_array.setitem(
                    head, np.ascontiguousarray(data[:, :, :, :first])))
                if extent > SLOT_CHUNK:
                    tail = self._tail(name)
                    sel = lead + (slice(SLOT_CHUNK, extent),) + (slice(None),) * (arr.ndim - 4)
                    jobs.append(tail.async_array.setitem(
                        sel, np.ascontiguousarray(data[:, :, :, SLOT_CHUNK:extent])))
                continue
            sel = lead + (slice(None),) * (arr.ndim - 3)
            jobs.append(arr.async_array.setitem(sel, np.ascontiguousarray(data)))

        async def write_all():
            await asyncio.gather(*jobs)

        zarr_sync(write_all())
        return True

    def _tail(self, name: str) -> zarr.Array:
        """The array for a slot variable's chunks beyond the first along its slot dim: empty
        ones are not stored (and removed if an earlier write stored them)."""
        arr = self._arrays.get((name, "tail"))
        if arr is None:
            arr = self._arrays[(name, "tail")] = self._group[name].with_config(
                {"write_empty_chunks": False})
        return arr


def slots_used(arrays: dict[str, np.ndarray]) -> dict[str, int]:
    """The most entries any point of a block holds along each slot dim (filled from 0:
    orbits with a status, attractors with a kind)."""
    out = {}
    if "status" in arrays:
        out["solution"] = int((np.asarray(arrays["status"]) != -1).sum(axis=-1).max(initial=0))
    if "attractor_kind" in arrays:
        out["attractor"] = int((np.asarray(arrays["attractor_kind"]) > 0).sum(axis=-1)
                               .max(initial=0))
    return out


#: where a worker process writes: store path -> (its task_done metadata file's (inode, mtime),
#: the writer). A store made again (--overwrite) has new metadata files, so a writer of the
#: store it replaced is never used.
_WRITERS: dict[str, tuple[tuple[int, int], BlockWriter]] = {}


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


def _writer_for(path: str | Path) -> BlockWriter:
    path = Path(path)
    meta = os.stat(path / "task_done" / "zarr.json")
    stamp = (meta.st_ino, meta.st_mtime_ns)
    hit = _WRITERS.get(str(path))
    if hit is None or hit[0] != stamp:
        attrs = read_attrs(path) or {}
        group = zarr.open_group(zarr.storage.LocalStore(path), mode="r+", zarr_format=3,
                                use_consolidated=False)
        hit = _WRITERS[str(path)] = (stamp, BlockWriter(
            group, attrs["hertzmap_chunk_shape"], bool(attrs.get(ALL_CHUNKS_ATTR))))
    return hit[1]


def write_task_block(path: str | Path, owner: dict[str, Any], slices: tuple[slice, slice, slice],
                     index: tuple[int, int, int], arrays: dict[str, np.ndarray],
                     names: tuple[str, ...]) -> bool:
    """A task's own block, written by the worker that solved it (scheduler.worker.run_task):
    whole chunks that no other task writes, so without a lock between workers; only while
    ``owner`` (the client's Lock.owner) holds the store (check_writer). A block that holds
    more slots than the store's slot dims (only the client resizes them) is staged instead,
    as one file (stage_file), for the client to grow the dims and write it
    (commit_grid_block). Returns True when written, False when staged. The client sets the
    task's flag once this has returned (and a staged block is written)."""
    check_writer(path, owner)
    if _writer_for(path).write(slices, arrays, names):
        return True
    stage_file(path, GRID_STAGE, _block_name(index), arrays)
    return False


#: the folder (in the store) of the grid's blocks that did not fit its slot dims
GRID_STAGE = "grid_stage"


def _block_name(index) -> str:
    return "-".join(str(int(i)) for i in index)


def commit_grid_block(store: "Store", slices: tuple[slice, slice, slice],
                      index: tuple[int, int, int], names: tuple[str, ...]) -> None:
    """Write a staged grid block (write_task_block) into the store, its slot dims grown, and
    remove its file. The client's, before it flags the task."""
    arrays = read_stage_file(store.path, GRID_STAGE, _block_name(index))
    store.write_block(slices, arrays, names)
    (Path(store.path) / GRID_STAGE / f"{_block_name(index)}.npz").unlink(missing_ok=True)


def remove_store(path: str | Path) -> None:
    """Delete a zarr store (refuses anything that is not a zarr group directory)."""
    path = Path(path)
    if read_attrs(path) is None:
        raise StoreError(f"{path} is not a zarr store; refusing to delete it")
    shutil.rmtree(path)


def open_or_create(path: str | Path, study: Study, chunks: tuple[int, int, int], *,
                   overwrite: bool, action: str) -> tuple[Store, bool]:
    """The store for ``study`` at ``path``: (store, resumed).

    An existing store of the same study is resumed; of another study: StoreError unless
    ``overwrite``. A path that exists but is not a zarr store is never touched.
    """
    path = Path(path)
    if path.exists():
        attrs = read_attrs(path)
        if attrs is None:
            if path.is_dir() and not any(path.iterdir()):
                path.rmdir()
            else:
                raise StoreError(f"{path} exists and is not a zarr store; "
                                 "choose another --store path")
        elif ("hertzmap_study_hash" in attrs and not overwrite
              and attrs.get("hertzmap_store_format") != STORE_FORMAT):
            try:
                check_format(attrs, str(path))
            except StoreFormatError as exc:
                raise StoreError(f"{exc}; or --store for another path") from None
        elif attrs.get("hertzmap_study_hash") == study.hash and not overwrite:
            try:
                store = Store(path)
                store.check(study)
                return store, True
            except (StoreError, KeyError) as exc:
                raise StoreError(f"{exc}; rerun with --overwrite to start it again") from None
        elif not overwrite:
            if "hertzmap_study_hash" in attrs:
                name = attrs.get("hertzmap_study_name")
                raise StoreError(
                    f"{path} holds another study ({name!r}, hash "
                    f"{attrs['hertzmap_study_hash'][:12]}), not {study.name!r} (hash "
                    f"{study.hash[:12]}); use --overwrite to replace it or --store for another path")
            raise StoreError(f"{path} is a zarr store not written by hertzmap; "
                             "use --overwrite to replace it or --store for another path")
        else:
            remove_store(path)
    return Store.create(path, study, chunks, action), False


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
        from hertzmap.scheduler.plan import make_plan

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


# -- products ----------------------------------------------------------------------------------

def write_product(store: str | Path, name: str, product: xr.Dataset, *, lock: bool = True) -> str:
    """Write a product (study.products) into the store as the zarr group
    ``products/<name>`` (replacing it). Returns the group path.

    Only that group is written: the main group's arrays and attrs are untouched (zarr's
    consolidated metadata at the root is refreshed to list the group). Takes the store's lock
    for the write, so it is refused while a ``hertzmap run`` holds it (``lock=False``: the
    caller is that run and holds it already).
    """
    store = Path(store)
    if not (store / "zarr.json").is_file():
        raise StoreError(f"{store} is not a zarr store")
    if not name or "/" in name or name.startswith("."):
        raise ValueError(f"invalid product name {name!r}")
    group = f"{PRODUCT_GROUP}/{name}"
    product = product.copy()
    product.attrs = {k: (json.dumps(v) if isinstance(v, (dict, list)) else v)
                     for k, v in product.attrs.items()}
    for v in product.variables.values():
        v.encoding = {}
    held = Lock(store)
    if lock:
        try:
            held.acquire()
        except StoreError:
            raise StoreError(f"{store} is locked by a running hertzmap run ({lock_path(store)}); "
                             "write products when it has finished") from None
    try:
        with _quiet():
            product.to_zarr(str(store), group=group, mode="w", consolidated=True)
    finally:
        held.release()
    return group


def write_products(store: str | Path, products: dict[str, xr.Dataset]) -> list[str]:
    """write_product for each product; returns the group paths."""
    return [write_product(store, name, prod) for name, prod in products.items()]


def make_products(store: Path, which: list[str], *, write: bool = True,
                  ds: xr.Dataset | None = None) -> dict[str, xr.Dataset]:
    """The products of ``hertzmap plot STORE --which ...``: every product the registry
    (study.products.catalog) says the store supports that the figures ``which`` need,
    computed from the store's main group (``ds``: it, opened already) and the products the run
    wrote; written into the store's products/ groups and read back from them unless ``write``
    is False. Returns them with the run's products."""
    from hertzmap.study import plots
    from hertzmap.study import products as P

    if not (Path(store) / "zarr.json").is_file():
        raise StoreError(f"{store} is not a zarr store")
    ds = P.open_store(store) if ds is None else ds
    stored = list_products(store)
    given = {name: read_product(store, name) for name in P.RUN_PRODUCTS if name in stored}
    prods = P.compute_products(ds, wanted=plots.products_for(which), given=given)
    if write:
        write_products(store, prods)
        prods = {name: read_product(store, name) for name in prods}
    return {**given, **prods}


def read_product(store: str | Path, name: str) -> xr.Dataset:
    """A stored product, in memory."""
    with _quiet():
        return xr.open_zarr(str(store), group=f"{PRODUCT_GROUP}/{name}", chunks=None).load()


def list_products(store: str | Path) -> list[str]:
    """Names of the products stored in a store."""
    root = Path(store) / PRODUCT_GROUP
    if not root.is_dir():
        return []
    return sorted(p.name for p in root.iterdir() if (p / "zarr.json").is_file())


# -- traced curves (products/traced_curves, written one curve at a time by hertzmap run) -------
#
# A study with the "curves" output traces its curves after the grid (scheduler.curve_tasks).
# Each finished curve is committed as its own small .npz file under CURVE_PARTS, built next to
# its place and renamed into it (a reader or a resumed run finds a whole part or none), in the
# order of the study's seeds. Once every seed is decided, the parts are combined into the
# product group products/traced_curves and removed: a run killed at any point resumes the
# missing curves and ends with the same product as an undisturbed one.

#: folder of the committed one-curve parts, under the store's products group
CURVE_PARTS = "traced_curves_parts"
TRACED_CURVES = "traced_curves"


def _parts_dir(store: str | Path) -> Path:
    return Path(store) / PRODUCT_GROUP / CURVE_PARTS


def _json_safe(value):
    """A part's attrs as JSON: numpy arrays and scalars as lists and numbers."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def write_curve_part(store: str | Path, index: int, part: xr.Dataset) -> Path:
    """Commit the traced curve of seed ``index`` (a one-curve products dataset) as one .npz
    file: its arrays, and their dims and attrs as JSON (no pickles). A zarr group per part took
    0.2-0.3 s (45 small arrays), a tenth of the default scene's curve stage over its 14 parts;
    this takes milliseconds. The caller holds the store's lock (hertzmap run)."""
    root = _parts_dir(store)
    root.mkdir(parents=True, exist_ok=True)
    final = root / f"{int(index):06d}.npz"
    building = root / f".{int(index):06d}.writing.npz"
    meta = {"attrs": {k: (json.dumps(v) if isinstance(v, (dict, list, tuple)) else _json_safe(v))
                      for k, v in part.attrs.items()},
            "variables": {name: {"dims": list(v.dims), "attrs": _json_safe(dict(v.attrs)),
                                 "coord": name in part.coords}
                          for name, v in part.variables.items()}}
    arrays = {f"v_{i}": np.asarray(v.values) for i, v in enumerate(part.variables.values())}
    with open(building, "wb") as f:
        np.savez(f, meta=np.array(json.dumps(meta)), **arrays)
        f.flush()
        os.fsync(f.fileno())
    os.replace(building, final)         # a reader or a resumed run finds a whole part or none
    return final


def read_curve_parts(store: str | Path) -> dict[int, xr.Dataset]:
    """The committed one-curve parts, by seed index (in memory)."""
    root = _parts_dir(store)
    out: dict[int, xr.Dataset] = {}
    if not root.is_dir():
        return out
    for p in sorted(root.iterdir()):
        if p.name.startswith(".") or p.suffix != ".npz":
            continue
        with np.load(p, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            data, coords = {}, {}
            for i, (name, v) in enumerate(meta["variables"].items()):
                var = xr.Variable(tuple(v["dims"]), z[f"v_{i}"], v["attrs"])
                (coords if v["coord"] else data)[name] = var
        out[int(p.stem)] = xr.Dataset(data, coords=coords, attrs=meta["attrs"])
    return out


def has_run_product(store: str | Path, name: str, study_hash: str) -> bool:
    """True when the store holds the product ``name`` that a stage of a run of this study
    wrote whole (products/traced_curves, products/thresholds)."""
    meta = Path(store) / PRODUCT_GROUP / name / "zarr.json"
    if not meta.is_file():
        return False
    try:
        attrs = json.loads(meta.read_text()).get("attributes", {})
    except (OSError, ValueError):
        return False
    return attrs.get("hertzmap_study_hash") == study_hash


def finish_traced_curves(store: str | Path, product: xr.Dataset) -> str:
    """Write the combined product ``products/traced_curves`` (the caller, hertzmap run, holds
    the store's lock), then remove the parts it was combined from."""
    group = write_product(store, TRACED_CURVES, product, lock=False)
    shutil.rmtree(_parts_dir(store), ignore_errors=True)
    return group


# -- the atlas's rounds (scheduler.atlas_tasks) ---------------------------------------------------
ATLAS_ATTR = "hertzmap_atlas"
ATLAS_STAGE = "atlas_stage"


#: (store path, variable) -> (the array's metadata file's (inode, mtime), the opened array):
#: a worker reading tile after tile of one store opens each variable once (opening one parses
#: its metadata: as long as reading a tile of it); a store made again (--overwrite) has new
#: metadata files, so a stale array is never read
_OPENED: dict[tuple[str, str], tuple[tuple[int, int], zarr.Array]] = {}


def _open_read_only(path: str | Path, names) -> dict[str, zarr.Array]:
    out, group = {}, None
    for n in names:
        meta = os.stat(Path(path) / n / "zarr.json")
        stamp = (meta.st_ino, meta.st_mtime_ns)
        hit = _OPENED.get((str(path), n))
        if hit is None or hit[0] != stamp:
            if group is None:
                group = zarr.open_group(zarr.storage.LocalStore(path), mode="r", zarr_format=3,
                                        use_consolidated=False)
            hit = _OPENED[(str(path), n)] = (stamp, group[n])
        out[n] = hit[1]
    return out


def read_region(path: str | Path, where: dict[str, tuple[slice, ...]]) -> dict[str, np.ndarray]:
    """{name: array[where[name]]} of a store's main group, every read in one call into zarr's
    event loop (one round trip per variable cost more than the reads). Read only: a worker's."""
    arrays = _open_read_only(path, where)

    async def read_all():
        return await asyncio.gather(*(arrays[n].async_array.getitem(
            tuple(where[n]) + (slice(None),) * (arrays[n].ndim - len(where[n]))) for n in where))

    return dict(zip(where, zarr_sync(read_all())))


def _stage_dir(store: str | Path, round_: int) -> Path:
    return Path(store) / ATLAS_STAGE / f"round_{int(round_):04d}"


def stage_file(store: str | Path, folder: str | Path, name: str,
               arrays: dict[str, np.ndarray] | None) -> Path:
    """Stage arrays as one .npz file ``folder/name.npz`` of the store, written whole or not
    at all (built next to its place, then renamed into it): an atlas round's tile, a grid
    block that did not fit. The caller holds the store's lock, or is a worker of the client
    that holds it."""
    root = Path(store) / folder
    root.mkdir(parents=True, exist_ok=True)
    final = root / f"{name}.npz"
    building = root / f".{name}.writing.npz"
    with open(building, "wb") as f:
        np.savez(f, **(arrays or {}))
        f.flush()
        os.fsync(f.fileno())
    os.replace(building, final)
    return final


def read_stage_file(store: str | Path, folder: str | Path, name: str) -> dict[str, np.ndarray]:
    """A staged file's arrays ({} when it holds none)."""
    with np.load(Path(store) / folder / f"{name}.npz", allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def write_atlas_tile(store: str | Path, round_: int, index: tuple[int, int, int],
                     arrays: dict[str, np.ndarray] | None) -> Path:
    """Stage one tile's result of an atlas round (its arrays, or None when the round added
    nothing there) as one .npz file (stage_file): a killed round keeps the tiles staged so
    far, and the main group is written only when the round commits."""
    return stage_file(store, _stage_dir(store, round_).relative_to(Path(store)),
                      _block_name(index), arrays)


def stage_atlas_tile(store: str | Path, owner: dict[str, Any], round_: int,
                     index: tuple[int, int, int], arrays: dict[str, np.ndarray] | None) -> Path:
    """write_atlas_tile by the worker that computed the tile, only while ``owner`` (the
    client's Lock.owner) holds the store (check_writer)."""
    check_writer(store, owner)
    return write_atlas_tile(store, round_, index, arrays)


def staged_atlas_tiles(store: str | Path, round_: int) -> set[tuple[int, int, int]]:
    """The tiles of ``round_`` staged so far."""
    root = _stage_dir(store, round_)
    if not root.is_dir():
        return set()
    return {tuple(int(i) for i in p.stem.split("-")) for p in root.iterdir()
            if p.suffix == ".npz" and not p.name.startswith(".")}


def read_atlas_tile(store: str | Path, round_: int, index: tuple[int, int, int]
                    ) -> dict[str, np.ndarray]:
    """A staged tile's arrays ({} when the round added nothing there)."""
    return read_stage_file(store, _stage_dir(store, round_).relative_to(Path(store)),
                           _block_name(index))


def remove_stage(store: str | Path, folder: str) -> None:
    """Remove a folder of staged files (once what they held is written)."""
    shutil.rmtree(Path(store) / folder, ignore_errors=True)


def remove_atlas_stage(store: str | Path) -> None:
    """Remove every staged round (after its commit)."""
    shutil.rmtree(Path(store) / ATLAS_STAGE, ignore_errors=True)


# -- the stepped sweeps' stage (scheduler.sweep_tasks) ----------------------------------------
#
# Each finished sweep is staged as one .npz file (stage_file: whole or not at all) under
# SWEEP_STAGE, named after its line and direction; once every sweep is staged the client
# writes the product products/sweeps from them and removes the folder: a run killed at any
# point resumes the sweeps not staged and ends with the same product.

#: folder of the staged sweeps, at the store's root
SWEEP_STAGE = "sweeps_stage"


def sweep_name(line: int, direction: str) -> str:
    """The staged file's name of a sweep: ``<line>-<direction>``."""
    return f"{int(line):06d}-{direction}"


def stage_sweep(store: str | Path, line: int, direction: str,
                arrays: dict[str, np.ndarray]) -> Path:
    """Stage one finished sweep's arrays (the client, holding the store's lock, commits it)."""
    return stage_file(store, SWEEP_STAGE, sweep_name(line, direction), arrays)


def staged_files(store: str | Path, folder: str) -> dict[str, dict[str, np.ndarray]]:
    """The files staged whole so far in ``folder`` of the store (stage_file; not one being
    written, not its subfolders), by name."""
    root = Path(store) / folder
    if not root.is_dir():
        return {}
    return {p.stem: read_stage_file(store, folder, p.stem) for p in sorted(root.iterdir())
            if p.suffix == ".npz" and not p.name.startswith(".")}


def staged_sweeps(store: str | Path) -> dict[tuple[int, str], dict[str, np.ndarray]]:
    """The sweeps staged so far, by (line, direction)."""
    return {(int(name.partition("-")[0]), name.partition("-")[2]): arrays
            for name, arrays in staged_files(store, SWEEP_STAGE).items()}


#: the staged swept-sine runs: a subfolder of the stepped sweeps' staging folder (removed with
#: it; staged_sweeps reads only the files at its top)
SWEPT_STAGE = f"{SWEEP_STAGE}/swept"


def swept_name(line: int, direction: str, rate_index: int) -> str:
    """The staged file's name of a swept run: ``<line>-<direction>-<rate index>``."""
    return f"{int(line):06d}-{direction}-{int(rate_index):03d}"


def stage_swept(store: str | Path, line: int, direction: str, rate_index: int,
                arrays: dict[str, np.ndarray]) -> Path:
    """Stage one finished swept run's arrays (the client, holding the store's lock, commits
    them with the sweeps)."""
    return stage_file(store, SWEPT_STAGE, swept_name(line, direction, rate_index), arrays)


def staged_swept(store: str | Path) -> dict[tuple[int, str, int], dict[str, np.ndarray]]:
    """The swept runs staged so far, by (line, direction, rate index)."""
    out = {}
    for name, arrays in staged_files(store, SWEPT_STAGE).items():
        line, direction, k = name.split("-")
        out[(int(line), direction, int(k))] = arrays
    return out
