"""Block writes: the grid's blocks reach the store's main group in whole shards, each written
once by the client, so that no two processes ever write one shard (zarr's sharding codec
rewrites a whole shard file on any write into it: two writers of one shard lose data).

A task's worker stages its block (``stage_task_block``: one file, whole or not at all, only
while its client holds the lock) and returns; the client, when every block of a shard is
staged, packs them into the shard (``pack_shard``: one region write per variable, the slot
dims grown first), then sets their ``task_done`` flags in one write, then removes the staged
files. A kill anywhere leaves either staged files (packed on resume, the same values) or a
packed shard whose flags are set.

``HERTZMAP_SHARD_LOG`` (tests only): a file each region write appends one line to (the
writer's pid, the shards it wrote, its start and end times), to check that writers never
overlap on a shard.
"""
from __future__ import annotations

import asyncio
import contextlib
import json
import os
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np
import zarr
# zarr's own bridge into its event loop (what Array.__setitem__ calls), to run the writes of
# all of a block's variables in one call
from zarr.core.sync import sync as zarr_sync

from hertzmap.scheduler.errors import StoreError
from hertzmap.scheduler.store.layout import PACK_PAUSE_ENV, block_name, shard_members, hold_for_test
from hertzmap.scheduler.store.lock import check_writer
from hertzmap.scheduler.store.slot_dims import slots_used
from hertzmap.scheduler.store.staging import GRID_STAGE, stage_file, staged_names, unstage
from hertzmap.study.schema import (SLOT_CHUNK, SLOT_DIMS, VARIABLES, array_slots, chunk_slices,
                                   pad_slots)

#: the bytes of a shard the client assembles before it writes them (several variables at once)
PACK_BYTES = 64 * 2 ** 20
#: the test-only log of region writes (module docstring)
SHARD_LOG_ENV = "HERTZMAP_SHARD_LOG"


@contextlib.contextmanager
def log_shard_write(slices, chunks, shard_blocks):
    """Append (pid, shards, start, end) of the write inside to SHARD_LOG_ENV's file, if set."""
    path = os.environ.get(SHARD_LOG_ENV)
    if not path:
        yield
        return
    per = [c * b for c, b in zip(chunks, shard_blocks)]
    ranges = [range(s.start // p, (s.stop - 1) // p + 1) for s, p in zip(slices, per)]
    shards = [[i, j, k] for i in ranges[0] for j in ranges[1] for k in ranges[2]]
    t0 = time.time()
    yield
    line = json.dumps({"pid": os.getpid(), "shards": shards, "start": t0, "end": time.time()})
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, (line + "\n").encode())
    finally:
        os.close(fd)


class BlockWriter:
    """The arrays of a store's main group, each opened once, for region writes of whole blocks
(a shard packed, an atlas round's tiles): the client's alone.

    Byte-for-byte what ``block_dataset(...).to_zarr(region=...)`` writes (the stored dtypes
    are the VARIABLES dtypes and no variable has a CF scale or offset; tested), at a third
    of its cost: xarray's region write re-opens and re-validates every array on each call,
    and zarr then runs one event-loop round trip per variable."""

    def __init__(self, group: zarr.Group, chunks: tuple[int, ...], all_chunks: bool,
                 shard_blocks: tuple[int, int, int] = (1, 1, 1)):
        self._group = group
        self.chunks = tuple(int(c) for c in chunks)
        self.shard_blocks = tuple(int(b) for b in shard_blocks)
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

    def slot_extent(self, name: str) -> int:
        """The length of a slot variable's slot dim in the store (its metadata read again
        when the cached array is shorter than asked: the client may have grown it since)."""
        return self._array(name).shape[3]

    def fits(self, arrays: dict[str, np.ndarray], names: tuple[str, ...]) -> bool:
        """The block's slots fit in the store's slot dims (re-read once if not: the client
        may have grown them since the arrays were opened)."""
        need = array_slots({n: arrays[n] for n in names})
        slot_names = [n for n in names if VARIABLES[n].slot_dim is not None]
        if all(need[VARIABLES[n].slot_dim] <= self.slot_extent(n) for n in slot_names):
            return True
        for n in slot_names:
            self._arrays.pop(n, None)
            self._arrays.pop((n, "tail"), None)
        return all(need[VARIABLES[n].slot_dim] <= self.slot_extent(n) for n in slot_names)

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
        c0 = self.chunks[0]
        blocks = slice(slices[0].start // c0, -(-slices[0].stop // c0))
        jobs = []
        for name in names:
            v = VARIABLES[name]
            arr = self._array(name)
            lead = (blocks, slices[1], slices[2]) if v.layout == "line" else tuple(slices)
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

        with log_shard_write(slices, self.chunks, self.shard_blocks):
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



def stage_task_block(path: str | Path, owner: dict[str, Any], index: tuple[int, int, int],
                     arrays: dict[str, np.ndarray]) -> Path:
    """A task's block, staged by the worker that solved it (scheduler.stages.worker.run_task) as one
    file (staging.stage_file), only while ``owner`` (the client's Lock.owner) holds the store
    (check_writer). The client packs it into its shard (pack_shard)."""
    check_writer(path, owner)
    return stage_file(path, GRID_STAGE, block_name(index), arrays)


def staged_blocks(path: str | Path) -> set[tuple[int, int, int]]:
    """The grid's blocks staged and not packed yet."""
    return {tuple(int(i) for i in n.split("-")) for n in staged_names(path, GRID_STAGE)}


def pack_shard(store, shard: tuple[int, int, int], counts: tuple[int, int, int],
               names: tuple[str, ...]) -> list[tuple[int, int, int]]:
    """Write every block of ``shard`` from its staged file into the store (its blocks
    not flagged done must all be staged), one variable at a time (the client holds one
    variable's shard in memory), the slot dims grown first; then flag them done in one write
    and remove their files. The client's (it holds the lock). Returns the blocks packed."""
    members = shard_members(shard, store.shard_blocks, counts)
    done = store.done_mask()
    todo = [m for m in members if not done[m]]
    if not todo:
        return []
    shape = store.grid_shape
    files = {m: np.load(Path(store.path) / GRID_STAGE / f"{block_name(m)}.npz",
                        allow_pickle=False) for m in todo}
    try:
        region = [chunk_slices(shape, store.chunks, m) for m in members]
        lo = [min(r[a].start for r in region) for a in range(3)]
        hi = [max(r[a].stop for r in region) for a in range(3)]
        where = tuple(slice(a, b) for a, b in zip(lo, hi))
        # the slots the shard needs along each dim: the longest of its blocks (and the store's)
        need = {d: 1 for d in SLOT_DIMS}
        used = {}
        for f in files.values():
            counted = {n: f[n] for n in ("status", "attractor_kind") if n in names}
            have = array_slots(counted)
            need = {d: max(need[d], have[d]) for d in SLOT_DIMS}
            for d, k in slots_used(counted).items():
                used[d] = max(used.get(d, 0), k)
        writer = store.block_writer()
        slot_names = {d: [n for n in names if VARIABLES[n].slot_dim == d] for d in SLOT_DIMS}
        if any(writer.slot_extent(n) < need[d] for d, ns in slot_names.items() for n in ns):
            store.prepare_slots(need, used)         # grown (a metadata write)
            writer = store.block_writer()
        else:
            store.note_slots_used(used)
        if len(todo) == len(members):
            # zarr reads a shard before it writes into it, even whole: the shard's old files
            # (a damaged shard's, or a pack cut short) hold nothing kept, and go first
            for name in names:
                old = Path(store.path) / name / "c" / "/".join(map(str, shard))
                if old.is_dir():
                    shutil.rmtree(old)
                else:
                    old.unlink(missing_ok=True)
        batch: dict[str, np.ndarray] = {}
        for name in names:
            v = VARIABLES[name]
            extent = writer.slot_extent(name) if v.slot_dim else None
            if v.layout == "line":
                c0 = store.chunks[0]
                lead = (-(-hi[0] // c0) - lo[0] // c0, hi[1] - lo[1], hi[2] - lo[2])
            else:
                lead = tuple(b - a for a, b in zip(lo, hi))
            if len(todo) < len(members):
                # blocks of the shard already packed (a damaged block recomputed): kept as read
                c0 = store.chunks[0]
                sel = ((slice(lo[0] // c0, -(-hi[0] // c0)),) + where[1:]
                       if v.layout == "line" else where)
                full = np.array(store.array(name)[sel], dtype=v.dtype)
            else:
                first = np.asarray(files[todo[0]][name])
                tail = first.shape[4:] if v.slot_dim else first.shape[3:]
                full = np.full(lead + ((extent,) if v.slot_dim else ()) + tail, v.fill, v.dtype)
            for m in todo:
                r = chunk_slices(shape, store.chunks, m)
                a = np.asarray(files[m][name])
                if v.slot_dim:
                    a = pad_slots({name: a}, {v.slot_dim: extent})[name]
                if v.layout == "line":
                    i0 = r[0].start // store.chunks[0] - lo[0] // store.chunks[0]
                    at = (slice(i0, i0 + 1),)
                else:
                    at = (slice(r[0].start - lo[0], r[0].stop - lo[0]),)
                at += (slice(r[1].start - lo[1], r[1].stop - lo[1]),
                       slice(r[2].start - lo[2], r[2].stop - lo[2]))
                full[at] = a
            batch[name] = full
            # written a few variables at a time, in one call into zarr's event loop: the
            # client holds at most PACK_BYTES of a shard in memory
            if sum(a.nbytes for a in batch.values()) >= PACK_BYTES or name == names[-1]:
                if not writer.write(where, batch, tuple(batch)):
                    raise StoreError(f"{store.path}: a shard holds more slots than its dims "
                                     "after they grew (another process resized the store?)")
                batch = {}
                hold_for_test(PACK_PAUSE_ENV)
    finally:
        for f in files.values():
            f.close()
    store.mark_done_many(todo)
    for m in todo:
        unstage(store.path, GRID_STAGE, block_name(m))
    return todo
