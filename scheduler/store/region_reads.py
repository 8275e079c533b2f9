"""Reading a region of a store's main group, read only: what an atlas round's worker reads of
its tile and halo (and the client its snapshot), every variable in one call into zarr's event
loop."""
from __future__ import annotations

import asyncio
import os
from pathlib import Path

import numpy as np
import zarr
from zarr.core.sync import sync as zarr_sync

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
