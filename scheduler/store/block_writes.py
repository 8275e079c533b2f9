"""Block writes: a task's block of every stored variable, written into the store's main group
as whole chunks (``BlockWriter``), by the worker that solved it (``write_task_block``, only
while its client holds the lock) or by the client (a block that did not fit the slot dims,
``commit_grid_block``; an atlas round)."""
from __future__ import annotations

import asyncio
import os
from pathlib import Path
from typing import Any

import numpy as np
import zarr
# zarr's own bridge into its event loop (what Array.__setitem__ calls), to run the writes of
# all of a block's variables in one call
from zarr.core.sync import sync as zarr_sync

from hertzmap.scheduler.store.layout import ALL_CHUNKS_ATTR, block_name, read_attrs
from hertzmap.scheduler.store.lock import check_writer
from hertzmap.scheduler.store.staging import GRID_STAGE, read_stage_file, stage_file, unstage
from hertzmap.study.schema import SLOT_CHUNK, VARIABLES, array_slots, pad_slots

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


#: where a worker process writes: store path -> (its task_done metadata file's (inode, mtime),
#: the writer). A store made again (--overwrite) has new metadata files, so a writer of the
#: store it replaced is never used.
_WRITERS: dict[str, tuple[tuple[int, int], BlockWriter]] = {}


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
    stage_file(path, GRID_STAGE, block_name(index), arrays)
    return False


def commit_grid_block(store, slices: tuple[slice, slice, slice],
                      index: tuple[int, int, int], names: tuple[str, ...]) -> None:
    """Write a staged grid block (write_task_block) into the store, its slot dims grown, and
    remove its file. The client's, before it flags the task."""
    arrays = read_stage_file(store.path, GRID_STAGE, block_name(index))
    store.write_block(slices, arrays, names)
    unstage(store.path, GRID_STAGE, block_name(index))
