"""``hertzmap upgrade STORE``: a store of format 2 (one file per chunk) rewritten in place in
the current format (every array of the main group sharded: layout.shard_shape), its values,
attrs, products groups and staged files kept, nothing recomputed.

The new store is built next to the old one (``.NAME.upgrading``) under the store's lock, then
swapped in by two renames (the old one kept as ``.NAME.format2`` until the new one is in place,
then removed): a kill leaves the old store whole at its path, or the new one."""
from __future__ import annotations

import itertools
import os
import shutil
from pathlib import Path
from typing import Any

import zarr

from hertzmap.scheduler.errors import StoreError
from hertzmap.scheduler.store.layout import (SHARD_BLOCKS_ATTR, is_sharded_variable, quiet,
                                             read_attrs, shard_blocks, shard_shape)
from hertzmap.scheduler.store.lock import Lock
from hertzmap.study.schema import SLOT_DIMS, STORE_FORMAT, history_line

#: the formats ``upgrade`` rewrites (format 1 dropped orbits: only a rerun restores them)
UPGRADES_FROM = (2,)


def _regions(shape: tuple[int, ...], shards: tuple[int, ...]):
    """The shard regions of an array, each a tuple of slices."""
    ranges = [range(0, n, s) for n, s in zip(shape, shards)]
    for start in itertools.product(*ranges):
        yield tuple(slice(a, min(a + s, n)) for a, s, n in zip(start, shards, shape))


def _copy_array(old: zarr.Array, new_group: zarr.Group, name: str,
                blocks: tuple[int, int, int]) -> None:
    dims = tuple(old.metadata.dimension_names)
    sharded = is_sharded_variable(name)
    shards = shard_shape(name, dims, old.shape, old.chunks, blocks) if sharded else None
    new = new_group.create_array(
        name, shape=old.shape, dtype=old.dtype, chunks=old.chunks, shards=shards,
        fill_value=old.fill_value, filters=old.filters, compressors=old.compressors,
        serializer=old.serializer if not sharded else "auto", attributes=dict(old.attrs),
        dimension_names=dims)
    # every chunk of the grid written (as a block write does: a done block's missing file is
    # damage), a slot dim's chunks beyond its first only where they hold something
    whole = new.with_config({"write_empty_chunks": True})
    sparse = new.with_config({"write_empty_chunks": False})
    # (a shard is one SLOT_CHUNK long along a slot dim: the first or a later one)
    slot_axis = next((a for a, d in enumerate(dims) if d in SLOT_DIMS), None)
    for region in _regions(old.shape, shards or old.shape):
        if slot_axis is None or name in SLOT_DIMS:
            whole[region] = old[region]
            continue
        (whole if region[slot_axis].start == 0 else sparse)[region] = old[region]


def upgrade_store(path: str | Path) -> dict[str, Any]:
    """Rewrite the store at ``path`` in STORE_FORMAT (module docstring). Returns {"from":
    format, "to": format, "files_before": n, "files_after": n} ("from" == "to": nothing to do).
    StoreError for a path that is no hertzmap store, a format it cannot rewrite, or a store
    another client holds."""
    path = Path(path)
    attrs = read_attrs(path)
    if attrs is None or "hertzmap_study_hash" not in attrs:
        raise StoreError(f"{path} is not a hertzmap store")
    found = attrs.get("hertzmap_store_format")
    files_before = sum(1 for p in path.rglob("*") if p.is_file())
    if found == STORE_FORMAT:
        return {"from": found, "to": STORE_FORMAT, "files_before": files_before,
                "files_after": files_before}
    if found not in UPGRADES_FROM:
        raise StoreError(f"{path} is in store format {found}: `hertzmap upgrade` rewrites "
                         f"format {', '.join(map(str, UPGRADES_FROM))} only; rerun its study "
                         "with `hertzmap run STUDY --overwrite`")
    building = path.parent / f".{path.name}.upgrading"
    kept = path.parent / f".{path.name}.format{found}"
    with Lock(path), quiet():
        shutil.rmtree(building, ignore_errors=True)     # left by an upgrade cut short
        old = zarr.open_group(zarr.storage.LocalStore(path, read_only=True), mode="r",
                              zarr_format=3, use_consolidated=False)
        chunks = tuple(int(c) for c in attrs["hertzmap_chunk_shape"])
        shape = tuple(int(old[d].shape[0]) for d in ("omega", "sigma", "zeta"))
        blocks = shard_blocks(shape, chunks)
        new_attrs = dict(attrs)
        new_attrs.update({"hertzmap_store_format": STORE_FORMAT, SHARD_BLOCKS_ATTR: list(blocks),
                          "history": (attrs.get("history", "") + "\n" + history_line(
                              f"hertzmap upgrade: format {found} -> {STORE_FORMAT}")).strip()})
        new = zarr.open_group(zarr.storage.LocalStore(building), mode="w-", zarr_format=3,
                              attributes=new_attrs)
        names = sorted(old.array_keys())
        for name in names:
            _copy_array(old[name], new, name, blocks)
        # what is not an array of the main group (products groups, staged files) as it is
        for p in sorted(path.iterdir()):
            if p.name in names or p.name == "zarr.json":
                continue
            (shutil.copytree if p.is_dir() else shutil.copy2)(p, building / p.name)
        zarr.consolidate_metadata(zarr.storage.LocalStore(building))
        shutil.rmtree(kept, ignore_errors=True)
        os.rename(path, kept)
        os.rename(building, path)
        shutil.rmtree(kept)
    files_after = sum(1 for p in path.rglob("*") if p.is_file())
    return {"from": found, "to": STORE_FORMAT, "files_before": files_before,
            "files_after": files_after}
