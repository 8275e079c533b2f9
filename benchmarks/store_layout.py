"""The store's layout on disk, format 2 (one file per chunk, each task's worker writing its own
block) against the sharded format 3 (workers stage their blocks, the client packs each shard
once), in the same run: files, bytes, and write throughput per worker.

    .venv/bin/python benchmarks/store_layout.py [--points 1000000] [--workers 2] [--shards 2]

A study of ``--points`` grid points (a square omega x sigma grid, one zeta) with the default
scene's outputs and its tasks' size (161 omega points a block): synthetic blocks (random values
of each stored variable's dtype and shape, one chunk of slots) written through the store's own
write path into each layout: format 2's region writes (BlockWriter, as each worker wrote its
block), format 3's staging (stage_task_block, by each worker) and packing (pack_shard, by the
client). The blocks of the first ``--shards`` shards of format 3 are written into both (the
whole study's files and bytes scaled from them: a format-2 store's data files are one per
block and array, format 3's one per shard and array); the files of a 10^7-point study follow
from its layout in the same way.
"""
from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from hertzmap.scheduler.stages.plan import make_plan
from hertzmap.scheduler.store import Lock, Store, pack_shard, stage_task_block
from hertzmap.scheduler.store.block_writes import BlockWriter
from hertzmap.scheduler.store.layout import shard_blocks, shard_members, shard_of
from hertzmap.study.schema import VARIABLES, slot_counts, stored_variables
from hertzmap.study.spec import parse_study

#: the default scene's outputs (scenes/default.toml) and the omega points of its tasks
OUTPUTS = ["orbits", "measures", "attractors", "curves"]
BLOCK_OMEGA = 161


def study_text(points: int) -> str:
    n = max(2, int(round(math.sqrt(points))))
    return f"""
[study]
name = "layout"
[grid]
omega = {{ start = 0.5, stop = 2.5, num = {n} }}
sigma = {{ start = 0.05, stop = 1.0, num = {n} }}
zeta = 0.01
[products]
outputs = {OUTPUTS!r}
""".replace("'", '"')


def synthetic_block(names, shape, seed: int) -> dict[str, np.ndarray]:
    """Random values of each variable's dtype and shape (one chunk of slots): what a solved
    block holds, as far as the layout sees it."""
    rng = np.random.default_rng(seed)
    slots = slot_counts()
    out = {}
    for name in names:
        v = VARIABLES[name]
        s = v.block_shape(shape, slots)
        dt = np.dtype(v.dtype)
        if dt.kind == "f":
            a = rng.standard_normal(s).astype(dt)
        elif dt.kind == "c":
            a = (rng.standard_normal(s) + 1j * rng.standard_normal(s)).astype(dt)
        elif dt.kind == "b":
            a = rng.random(s) < 0.5
        else:
            a = rng.integers(-1, 3, size=s).astype(dt)
        out[name] = a
    return out


def files_and_bytes(path: Path) -> tuple[int, int]:
    files = [p for p in path.rglob("*") if p.is_file()]
    return len(files), sum(p.stat().st_size for p in files)


def _write_format2(job) -> tuple[int, float, float]:
    """A worker of format 2: region writes of its blocks (as scheduler.stages.worker wrote them)."""
    import zarr

    path, chunks, blocks, names, seed = job
    group = zarr.open_group(zarr.storage.LocalStore(path), mode="r+", zarr_format=3,
                            use_consolidated=False)
    writer = BlockWriter(group, chunks, True)
    spent, nbytes = 0.0, 0
    for k, (index, slices) in enumerate(blocks):
        shape = tuple(s.stop - s.start for s in slices)
        arrays = synthetic_block(names, shape, seed + k)
        t1 = time.perf_counter()
        writer.write(slices, arrays, names)
        spent += time.perf_counter() - t1
        nbytes += sum(a.nbytes for a in arrays.values())
    return len(blocks), nbytes, spent


def _stage_format3(job) -> tuple[int, float, float]:
    """A worker of format 3: its blocks staged (scheduler.stages.worker.run_task's write)."""
    path, owner, blocks, names, seed = job
    spent, nbytes = 0.0, 0
    for k, (index, slices) in enumerate(blocks):
        shape = tuple(s.stop - s.start for s in slices)
        arrays = synthetic_block(names, shape, seed + k)
        t1 = time.perf_counter()
        stage_task_block(path, owner, index, arrays)
        spent += time.perf_counter() - t1
        nbytes += sum(a.nbytes for a in arrays.values())
    return len(blocks), nbytes, spent


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=float, default=1e6, help="grid points of the study")
    ap.add_argument("--workers", type=int, default=2, help="writer processes")
    ap.add_argument("--shards", type=int, default=2,
                    help="the shards of format 3 whose blocks are written into both layouts")
    ap.add_argument("--dir", type=Path, default=None, help="where to write (default: a temp dir)")
    a = ap.parse_args(argv)
    study = parse_study(study_text(int(a.points)), default_name="layout")
    names = stored_variables(study)
    chunks = (min(BLOCK_OMEGA, study.shape[0]), 1, 1)
    plan = make_plan(study, chunks)
    blocks = shard_blocks(study.shape, plan.chunks)
    counts = plan.counts
    shards = sorted({shard_of(t.index, blocks) for t in plan.tasks})
    chosen = shards[:a.shards]
    members = {m for sh in chosen for m in shard_members(sh, blocks, counts)}
    tasks = [t for t in plan.tasks if t.index in members]
    print(f"study: {study.size:,} points ({' x '.join(map(str, study.shape))}), {len(names)} "
          f"stored variables, {len(plan.tasks):,} tasks of {math.prod(plan.chunks)} points; "
          f"format 3: {len(shards)} shards of {' x '.join(map(str, blocks))} blocks; written: "
          f"the {len(tasks)} blocks of {len(chosen)} shards, {a.workers} writer processes")
    root = Path(a.dir or tempfile.mkdtemp(prefix="store_layout_"))
    root.mkdir(parents=True, exist_ok=True)
    jobs = [[(t.index, t.slices) for t in tasks[w::a.workers]] for w in range(a.workers)]
    with mp.get_context("spawn").Pool(a.workers) as pool:
        # format 2
        p2 = root / "format2.zarr"
        shutil.rmtree(p2, ignore_errors=True)
        s2 = Store.create(p2, study, plan.chunks, "benchmark", sharded=False)
        empty2 = files_and_bytes(p2)
        t0 = time.perf_counter()
        res2 = pool.map(_write_format2, [(str(p2), s2.chunks, j, names, 100 * w)
                                         for w, j in enumerate(jobs)])
        wall2 = time.perf_counter() - t0
        # format 3
        p3 = root / "format3.zarr"
        shutil.rmtree(p3, ignore_errors=True)
        s3 = Store.create(p3, study, plan.chunks, "benchmark")
        empty3 = files_and_bytes(p3)
        with Lock(p3) as lock:
            t0 = time.perf_counter()
            res3 = pool.map(_stage_format3, [(str(p3), lock.owner, j, names, 100 * w)
                                             for w, j in enumerate(jobs)])
            staged = time.perf_counter() - t0
            t1 = time.perf_counter()
            for sh in chosen:
                pack_shard(s3, sh, counts, names)
            packing = time.perf_counter() - t1
        wall3 = time.perf_counter() - t0
    out = {}
    points = sum(t.size for t in tasks)
    for label, path, empty, res, wall, n_units, n_total in (
            ("format 2", p2, empty2, res2, wall2, len(tasks), len(plan.tasks)),
            ("format 3", p3, empty3, res3, wall3, len(chosen), len(shards))):
        files, nbytes = files_and_bytes(path)
        # files: one a block (format 2) or a shard (format 3) and array; bytes: by the points
        full_files = empty[0] + (files - empty[0]) * n_total / n_units
        full_bytes = empty[1] + (nbytes - empty[1]) * study.size / points
        per_worker = [f"{b / s / 1e6:.0f} MB/s ({n / s:.1f} blocks/s)" for n, b, s in res]
        out[label] = (full_files, full_bytes)
        print(f"{label}: written {files:,} files, {nbytes / 1e6:.1f} MB; the whole study "
              f"{full_files:,.0f} files, {full_bytes / 1e9:.2f} GB; wall {wall:.1f} s; per "
              f"worker (uncompressed block bytes / its write seconds): {', '.join(per_worker)}")
    print(f"format 3's client packing: {len(chosen)} shards, {packing:.1f} s "
          f"({sum(r[1] for r in res3) / packing / 1e6:.0f} MB/s of blocks); its workers staged "
          f"in {staged:.1f} s")
    print(f"files, format 2 / format 3: {out['format 2'][0] / out['format 3'][0]:.0f}x; bytes "
          f"{out['format 2'][1] / out['format 3'][1]:.2f}x")
    # 10^7 points: format 3's data files per shard as measured, over that study's shards
    big = parse_study(study_text(10 ** 7), default_name="layout")
    big_plan = make_plan(big, (min(BLOCK_OMEGA, big.shape[0]), 1, 1))
    n_big = math.prod(-(-c // b) for c, b in zip(big_plan.counts,
                                                shard_blocks(big.shape, big_plan.chunks)))
    per_shard = (files_and_bytes(p3)[0] - empty3[0]) / len(chosen)
    print(f"a 10^7-point study ({' x '.join(map(str, big.shape))}): format 3 about "
          f"{empty3[0] + per_shard * n_big:,.0f} files ({n_big} shards), format 2 about "
          f"{empty2[0] + (files_and_bytes(p2)[0] - empty2[0]) / len(tasks) * len(big_plan.tasks):,.0f}")
    if a.dir is None:
        shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
