"""The commit flags of a store: ``task_done``, one flag per block of the grid, set by the client
(which holds the lock) only once the block is in the store. A flag is therefore never set for a
block that is not fully written; a block written but not flagged (a worker or the client killed
in between) is recomputed, or packed from its staged file, on resume, with identical values."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import zarr

from hertzmap.scheduler.store.layout import quiet

def read_done_flags(path: str | Path) -> np.ndarray:
    """The task_done flags of a store, read only (cheap: for a page or a client polling a store
    that another process writes)."""
    with quiet():
        group = zarr.open_group(zarr.storage.LocalStore(Path(path), read_only=True), mode="r",
                                zarr_format=3, use_consolidated=False)
        return np.asarray(group["task_done"][...], bool)


class CommitFlags:
    """The task_done flags of a store opened for writing (a part of Store: ``self._done`` is
    its task_done array)."""

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

    def mark_done_many(self, indices) -> None:
        """Flag the blocks ``indices`` (those of one shard) done in one write of their flags'
        region (one file: a kill leaves them all set or none)."""
        indices = [tuple(int(a) for a in i) for i in indices]
        if not indices:
            return
        lo = [min(i[a] for i in indices) for a in range(3)]
        hi = [max(i[a] for i in indices) + 1 for a in range(3)]
        region = tuple(slice(a, b) for a, b in zip(lo, hi))
        flags = np.asarray(self._done[region], dtype=bool)
        for i in indices:
            flags[tuple(a - b for a, b in zip(i, lo))] = True
        self._done[region] = flags

    def unmark(self, index: tuple[int, int, int]) -> None:
        """Clear one block's flag: its shard of flags written whole from what can be read of
        it (a damaged flag file reads as not done), never read-modified from a damaged file."""
        blocks = self._done.shards or (1, 1, 1)
        region = tuple(slice(i // b * b, min((i // b + 1) * b, n))
                       for i, b, n in zip(index, blocks, self._done.shape))
        flags = self.done_mask()[region]
        flags[tuple(i - r.start for i, r in zip(index, region))] = False
        try:
            self._done[region] = flags
        except Exception:
            # zarr reads a shard before writing into it: a damaged one is removed first
            shard = "/".join(str(i // b) for i, b in zip(index, blocks))
            (Path(self.path) / "task_done" / "c" / shard).unlink(missing_ok=True)
            self._done[region] = flags
