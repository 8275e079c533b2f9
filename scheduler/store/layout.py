"""The store's layout on disk, declared once: the attrs that say how it was written, the
folders beside its arrays, and the reading of its root attrs (what every other module of the
store derives its paths and checks from). The variables, their dims and chunks are
study.schema's (VARIABLES, template); this module says how they are laid out in files."""
from __future__ import annotations

import contextlib
import itertools
import json
import math
import os
import time
import warnings
from pathlib import Path
from typing import Any

from hertzmap.scheduler.errors import StoreError
from hertzmap.study.schema import (CHUNK_DIMS, SLOT_CHUNK, SLOT_DIMS, VARIABLES, StoreFormatError,
                                   check_format, chunk_counts)

ALL_CHUNKS_ATTR = "hertzmap_all_chunks_written"
#: the atlas's progress (its round and phase: scheduler.stages.atlas_tasks)
ATLAS_ATTR = "hertzmap_atlas"
#: the most entries any point of the store holds along each slot dim so far (study.schema
#: SLOT_DIMS), kept by the client as blocks and atlas rounds are written: the length the dims
#: are cut to when the run ends (Store.settle_slots)
SLOTS_USED_ATTR = "hertzmap_slots_used"
#: the blocks (tasks) of the grid one shard holds along (omega, sigma, zeta): shard_blocks
SHARD_BLOCKS_ATTR = "hertzmap_shard_blocks"

#: Grid points one shard of a variable holds, at most (fewer at the grid's edges). Every array
#: of the main group has one file per shard (and per SLOT_CHUNK of its slot dim beyond the
#: first, where points hold more): a 10^6-point study of the default scene's kind has 8 shards
#: a variable, 431 files, a 10^7-point one 70, about 3,300 (benchmarks/store_layout.py). A
#: shard is written whole, once, by the client when every block of it is staged
#: (block_writes.pack_shard): it holds at most PACK_BYTES of one in memory.
SHARD_POINTS = 2 ** 18
#: Shards a grid has at least (fewer only where it has fewer blocks): a small study's blocks are
#: packed, and flagged done, as the run goes, not all at its end.
MIN_SHARDS = 8


def shard_blocks(shape: tuple[int, int, int], chunks: tuple[int, int, int],
                 points: int = SHARD_POINTS) -> tuple[int, int, int]:
    """Blocks per shard along (omega, sigma, zeta): doubled, along the axis with the most
    shards left, while a shard holds fewer than ``points`` grid points and the grid keeps
    MIN_SHARDS shards."""
    counts = chunk_counts(shape, chunks)
    blocks = [1, 1, 1]
    while True:
        size = math.prod(min(c * b, n) for c, b, n in zip(chunks, blocks, shape))
        left = [-(-n // b) for n, b in zip(counts, blocks)]
        axis = max(range(3), key=lambda a: left[a])
        if size * 2 > points or left[axis] == 1:
            return tuple(blocks)
        grown = list(blocks)
        grown[axis] = min(blocks[axis] * 2, counts[axis])
        if math.prod(-(-n // b) for n, b in zip(counts, grown)) < min(MIN_SHARDS, math.prod(counts)):
            return tuple(blocks)
        blocks = grown


def shard_shape(name: str, dims: tuple[str, ...], shape: tuple[int, ...],
                chunks: tuple[int, ...], blocks: tuple[int, int, int]) -> tuple[int, ...]:
    """The shard shape of an array of the main group: ``blocks`` of its chunks along the grid
    dims (and along omega_block, a line variable's one entry per omega block), one chunk along
    a slot dim (SLOT_CHUNK: the dim grows and is cut by whole shards), the whole array along
    the others (the harmonics, the strobe); the ``task_done`` flags (one per block) in shards
    of the grid's shards, so that a shard's blocks are flagged in one file write and a damaged
    flag file loses the flags of one shard."""
    if dims == CHUNK_DIMS:
        return tuple(int(b) for b in blocks)
    along = {"omega": blocks[0], "omega_block": blocks[0], "sigma": blocks[1], "zeta": blocks[2]}
    out = []
    for d, n, c in zip(dims, shape, chunks):
        if d in along:
            out.append(c * along[d])        # whole chunks (zarr's rule): the edge shards partial
        elif d in SLOT_DIMS:
            out.append(SLOT_CHUNK)
        else:
            out.append(n)
    return tuple(out)


def shard_of(index: tuple[int, int, int], blocks: tuple[int, int, int]) -> tuple[int, int, int]:
    """The shard that holds the block (task) ``index``."""
    return tuple(int(i) // int(b) for i, b in zip(index, blocks))


def shard_members(shard: tuple[int, int, int], blocks: tuple[int, int, int],
                  counts: tuple[int, int, int]) -> list[tuple[int, int, int]]:
    """The blocks (task indices) of ``shard``, in C order."""
    ranges = [range(s * b, min((s + 1) * b, n)) for s, b, n in zip(shard, blocks, counts)]
    return [tuple(i) for i in itertools.product(*ranges)]


def is_sharded_variable(name: str) -> bool:
    """A stored variable of the schema (its arrays are sharded), not a coordinate."""
    return name in VARIABLES or name == "task_done"


@contextlib.contextmanager
def quiet():
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


#: test-only pauses (seconds) that hold a write open so that a test can kill the writer in it:
#: a staged file built but not renamed into place (staging.stage_file), a shard's pack between
#: two of its variables (block_writes.pack_shard)
STAGE_PAUSE_ENV = "HERTZMAP_STAGE_PAUSE"
PACK_PAUSE_ENV = "HERTZMAP_PACK_PAUSE"


def hold_for_test(env: str) -> None:
    """Sleep for $``env`` seconds when a test sets it (never otherwise)."""
    seconds = os.environ.get(env)
    if seconds:
        time.sleep(float(seconds))


def block_name(index) -> str:
    """The name of a block's (or a tile's) staged file: its index, ``i-j-k``."""
    return "-".join(str(int(i)) for i in index)
