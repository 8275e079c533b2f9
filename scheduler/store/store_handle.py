"""A hertzmap store opened for writing by its single client (``Store``): created from the
study's template, checked against the study, its attrs updated; and ``open_or_create``, the
store a run resumes or starts."""
from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import zarr

from hertzmap.scheduler.errors import StoreError
from hertzmap.scheduler.store.block_writes import BlockWriter
from hertzmap.scheduler.store.commit_flags import CommitFlags
from hertzmap.scheduler.store.layout import (ALL_CHUNKS_ATTR, SHARD_BLOCKS_ATTR, quiet, read_attrs,
                                             shard_blocks, shard_of, shard_shape)
from hertzmap.scheduler.store.slot_dims import SlotDims, slots_used
from hertzmap.study.schema import (FORMAT_ADVICE, STORE_FORMAT, VARIABLES, StoreFormatError,
                                   array_slots, chunk_slices,
                                   check_format, history_line, parse_attrs, stored_variables,
                                   template)
from hertzmap.study.spec import Study


class Store(CommitFlags, SlotDims):
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
        #: blocks per shard along (omega, sigma, zeta) (format 2 and older: one)
        self.shard_blocks = tuple(int(b) for b in attrs.get(SHARD_BLOCKS_ATTR, (1, 1, 1)))
        self._group = zarr.open_group(zarr.storage.LocalStore(self.path), mode="r+",
                                      zarr_format=3, use_consolidated=False)
        self._done = self._group["task_done"]
        self._writer: BlockWriter | None = None

    # -- creation -------------------------------------------------------------------------
    @classmethod
    def create(cls, path: str | Path, study: Study, chunks: tuple[int, int, int],
               action: str, sharded: bool = True) -> "Store":
        """Write the template of ``study`` at ``path`` (which must not exist). ``sharded``
        False: format 2's layout, one file per chunk (benchmarks/store_layout.py compares)."""
        import dask.array  # the template is chunked lazily with Dask

        path = Path(path)
        ds = template(study, chunks, history=history_line(action))
        enc = {name: dict(ds[name].encoding) for name in ds.variables}
        # Each variable chunked as dask.array.full, not ds.chunk(): xarray's chunk() copies the
        # template's zero-copy broadcasts into memory (the whole store uncompressed: 2.7 GB per
        # 10^6 points of the default products, a 10^7-point store could not be created on a
        # 24 GB client); the written template is the same
        # every array of the main group in shards of whole blocks (layout.shard_shape): few
        # files at any size, each shard written whole by the client (block_writes.pack_shard)
        chunks = tuple(int(c) for c in ds.attrs["hertzmap_chunk_shape"])
        blocks = shard_blocks(study.shape, chunks)
        ds.attrs[SHARD_BLOCKS_ATTR] = list(blocks)
        for name, var in ds.data_vars.items():
            enc[name]["shards"] = shard_shape(name, var.dims, var.shape, enc[name]["chunks"],
                                              blocks)
        if not sharded:
            ds.attrs.update({"hertzmap_store_format": 2, SHARD_BLOCKS_ATTR: [1, 1, 1]})
            for name in ds.data_vars:
                del enc[name]["shards"]
        lazy = ds.copy()
        for name, var in ds.data_vars.items():
            lazy[name] = var.copy(data=dask.array.full(
                var.shape, np.asarray(var.data).flat[0], dtype=var.dtype,
                chunks=enc[name].get("shards", enc[name]["chunks"])))
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
        with quiet():
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
        with quiet():          # a stage's staging folder (atlas, sweeps) is no zarr node
            members = set(self._group.array_keys())
        missing = [n for n in stored_variables(study) if n not in members]
        if missing:
            raise StoreError(f"{self.path} is incomplete (missing {', '.join(missing)})")

    def _chunk_file(self, name: str, index: tuple[int, ...]) -> Path:
        """The file that holds block ``index`` of array ``name``: its shard."""
        arr = self._group[name]
        extra = (0,) * (arr.ndim - len(index))
        where = shard_of(index, self.shard_blocks)
        return self.path / name / "c" / "/".join(str(int(i)) for i in (*where, *extra))

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
                r = chunk_slices(self.grid_shape, self.chunks, t.index)
                if VARIABLES[name].layout == "line":
                    r = (slice(t.index[0], t.index[0] + 1),) + tuple(r[1:])
                try:
                    arr[r]
                except Exception as exc:
                    problems.append(f"{name}: chunk unreadable ({type(exc).__name__})")
            if problems:
                damaged[tuple(t.index)] = problems
        return damaged

    # -- data -----------------------------------------------------------------------------
    def array(self, name: str) -> zarr.Array:
        """An array of the main group (read, or written by the client)."""
        return self._group[name]

    @property
    def grid_shape(self) -> tuple[int, int, int]:
        """The grid's (omega, sigma, zeta) lengths."""
        return tuple(int(self._group[d].shape[0]) for d in ("omega", "sigma", "zeta"))

    def prepare_slots(self, need: dict[str, int], used: dict[str, int]) -> None:
        """Before a region write whose arrays are ``need`` long along the slot dims and hold
        ``used`` entries at most: note what is used, grow the dims where they are shorter."""
        self.note_slots_used(used)
        have = self.slot_extents()
        if any(need[d] > have[d] for d in have):
            self.settle_slots({d: max(need[d], have[d]) for d in have})

    def block_writer(self) -> BlockWriter:
        """The writer of this store's main group (made again after the slot dims change)."""
        if self._writer is None:
            self._writer = BlockWriter(self._group, self.chunks,
                                       bool(self.attrs.get(ALL_CHUNKS_ATTR)), self.shard_blocks)
        return self._writer

    def write_block(self, slices: tuple[slice, slice, slice], arrays: dict[str, np.ndarray],
                    names: tuple[str, ...], need: dict[str, int] | None = None) -> None:
        """Region write of whole blocks (a shard packed, an atlas round's tiles) of every
        variable in ``names`` (:class:`BlockWriter`), the store's slot dims grown first where
        the region holds more than they have room for (``need``: its slot lengths, when the
        arrays given do not say them all). The client's alone (it holds the store's lock)."""
        block = {n: arrays[n] for n in names}
        self.prepare_slots(need or array_slots(block), slots_used(block))
        if not self.block_writer().write(slices, arrays, names):
            raise StoreError(f"{self.path}: a block holds more slots than its dims after they "
                             "grew (another process resized the store?)")

    def set_attrs(self, **attrs: Any) -> None:
        """Update root attrs in one atomic rewrite of the root zarr.json that keeps its
        consolidated metadata. Written through a handle opened without it, zarr.json lost
        the consolidated metadata until the next consolidate_metadata: a reader opening the
        store meanwhile (``xr.open_zarr`` during a run) fell back to listing the directory,
        with warnings, and met zarr's temporary ``.partial`` files."""
        store = zarr.storage.LocalStore(self.path)
        with quiet():
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
