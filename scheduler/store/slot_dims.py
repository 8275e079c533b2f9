"""The slot dims of a store (study.schema.SLOT_DIMS: a point's orbits and its census's
attractors), sized by the data: their length is the most entries any point holds, grown by the
client (alone: it holds the lock) before it writes a block that holds more, and cut to what is
used when a run ends. A resize is a metadata write (the chunks and shards along the dims are
SLOT_CHUNK long: what is written stays where it is)."""
from __future__ import annotations

import numpy as np
import zarr

from hertzmap.scheduler.store.layout import SLOTS_USED_ATTR, quiet, read_attrs
from hertzmap.study.schema import SLOT_DIMS, VARIABLES


class SlotDims:
    """The slot dims of a store opened for writing (a part of Store)."""

    def _slot_arrays(self) -> dict[str, list[str]]:
        """The stored arrays of each slot dim (its coordinate first)."""
        with quiet():
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
        with quiet():
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
