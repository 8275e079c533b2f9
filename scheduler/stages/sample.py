"""The error estimate's sample: the converged orbits it re-solves, chosen pseudo-randomly by
their place in the grid, so that the sample does not depend on the order in which blocks finish
nor on which worker solved them (each worker proposes its block's candidates, the client keeps
the smallest keys)."""
from __future__ import annotations

import hashlib
from typing import Any

import numpy as np

from hertzmap.scheduler.stages.plan import Block
from hertzmap.study.spec import Study


def _mix64(x: np.ndarray) -> np.ndarray:
    """splitmix64 finaliser: a fixed pseudo-random key per integer."""
    x = x.astype(np.uint64)
    with np.errstate(over="ignore"):
        x ^= x >> np.uint64(30)
        x *= np.uint64(0xBF58476D1CE4E5B9)
        x ^= x >> np.uint64(27)
        x *= np.uint64(0x94D049BB133111EB)
        x ^= x >> np.uint64(31)
    return x


#: a slot's place in a point's key: its index times one, the point's times this (more than the
#: orbits any point holds; the key only needs to be a fixed function of the place)
SLOT_STRIDE = 1 << 16


class Sampler:
    """Keeps the ``n`` converged slots with the smallest pseudo-random keys: the sample does
    not depend on the order in which blocks finish. Each worker proposes its block's ``n``
    smallest (:func:`block_candidates`, with :meth:`task_spec`); the client keeps the ``n``
    smallest of all (:meth:`merge`)."""

    def __init__(self, study: Study, n: int):
        self.study = study
        self.n = n
        self.seed = np.uint64(int(hashlib.sha256(study.hash.encode()).hexdigest()[:15], 16))
        self.items: list[tuple[int, tuple]] = []

    def task_spec(self, task: Block) -> dict[str, Any]:
        """What a task's worker needs to propose its block's candidates."""
        return {"origin": tuple(s.start for s in task.slices), "shape": tuple(self.study.shape),
                "seed": int(self.seed), "n": self.n}

    def merge(self, candidates: list[tuple[int, tuple]]) -> None:
        if self.n <= 0 or not candidates:
            return
        self.items.extend(candidates)
        self.items.sort(key=lambda t: t[0])
        del self.items[self.n:]

    @property
    def samples(self) -> list[tuple]:
        return [v for _, v in self.items]


def block_candidates(arrays: dict[str, np.ndarray], axes: tuple[np.ndarray, ...],
                     spec: dict[str, Any]) -> list[tuple[int, tuple]]:
    """The block's ``n`` converged slots with the smallest keys, as (key, (omega, sigma, zeta,
    period, q0, v0)); ``axes``: the block's omega, sigma, zeta values; ``spec``:
    Sampler.task_spec. The key of a slot is a function of its place in the whole grid only."""
    n = int(spec["n"])
    if n <= 0:
        return []
    st = arrays["status"]
    idx = np.argwhere(st == 0)
    if idx.size == 0:
        return []
    o0, s0, z0 = spec["origin"]
    _, n_s, n_z = spec["shape"]
    flat = ((((idx[:, 0] + o0) * n_s + idx[:, 1] + s0) * n_z + idx[:, 2] + z0) * SLOT_STRIDE
            + idx[:, 3])
    keys = _mix64(flat.astype(np.uint64) ^ np.uint64(spec["seed"]))
    om, sg, zt = axes
    out = []
    for r in np.argsort(keys)[:n]:
        i, j, k, s = idx[r]
        out.append((int(keys[r]), (
            float(om[i]), float(sg[j]), float(zt[k]), int(arrays["period"][i, j, k, s]),
            float(arrays["q0"][i, j, k, s]), float(arrays["v0"][i, j, k, s]))))
    return out
