"""What a store costs on disk and to write: bytes, files per task, write time per block, for two
versions of hertzmap in the same run (each scene run by each version in turn, ABAB).

    .venv/bin/python benchmarks/store_cost.py --vs OTHER/.venv/bin/python [--scene default --scene fine_map --scene vibro_impact] [--pairs 1] [--workers 2] [--keep DIR]

``--vs``: the Python of another checkout's venv (e.g. a `git worktree add ../base REV` with its
own `bash scripts/install.sh`): version B; version A is this checkout's (.venv/bin/python).
Each run is ``run_study`` (the command line's path) on an embedded LocalCluster of
``--workers`` workers into a new store; printed per scene and version: the store's bytes on
disk (its files' sizes, products excluded: the run's own groups), its files and files per
grid task, the run's block writes (the workers' write time, summed, per task), the grid's
task compute and wall, and the atlas's compute; then B / A ratios pair by pair.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

#: what each run executes in the version's own Python: the run, then its summary as JSON
RUN = r"""
import json, sys
from pathlib import Path
from hertzmap.scheduler.cluster import ClusterSpec
from hertzmap.scheduler.run import RunOptions, run_study
from hertzmap.study.scenes import study_path
from hertzmap.study.spec import load_study
import io
study = load_study(study_path(sys.argv[1]))
opts = RunOptions(store=Path(sys.argv[2]), cluster=ClusterSpec(kind="local", workers=int(sys.argv[3])),
                  error_sample=0)
s = run_study(study, opts, out=io.StringIO(), err=io.StringIO())
atlas = s.get("atlas") or {}
print(json.dumps({"tasks": s["tasks_run"], "block_writes": s.get("block_writes"),
                  "compute": s.get("compute"), "wall": s.get("wall"),
                  "atlas": atlas.get("compute")}))
"""


def disk(store: Path) -> tuple[int, int]:
    """(bytes, files) of a store, its products/ groups left out."""
    size = files = 0
    for p in store.rglob("*"):
        if p.is_file() and "products" not in p.relative_to(store).parts:
            size += p.stat().st_size
            files += 1
    return size, files


def run(python: str, scene: str, store: Path, workers: int) -> dict:
    r = subprocess.run([python, "-c", RUN, scene, str(store), str(workers)],
                       capture_output=True, text=True, cwd=REPO)
    if r.returncode != 0:
        raise SystemExit(f"{python} {scene}: {r.stderr[-2000:]}")
    out = json.loads(r.stdout.strip().splitlines()[-1])
    out["bytes"], out["files"] = disk(store)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vs", required=True, help="the other version's Python (its venv)")
    ap.add_argument("--scene", action="append", help="a shipped scene (repeatable)")
    ap.add_argument("--pairs", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--keep", type=Path, default=None, help="keep the stores in this folder")
    a = ap.parse_args(argv)
    versions = {"A": str(REPO / ".venv" / "bin" / "python"), "B": a.vs}
    scenes = a.scene or ["default", "fine_map", "vibro_impact"]
    where = a.keep or Path(tempfile.mkdtemp(prefix="hertzmap-store-cost-"))
    where.mkdir(parents=True, exist_ok=True)
    print(f"A: {versions['A']}\nB: {versions['B']}\nstores in {where}")
    for scene in scenes:
        rows = {"A": [], "B": []}
        for pair in range(a.pairs):
            for v in ("A", "B") if pair % 2 == 0 else ("B", "A"):
                store = where / f"{scene}-{v}-{pair}.zarr"
                rows[v].append(run(versions[v], scene, store, a.workers))
                r = rows[v][-1]
                print(f"{scene} {v}: {r['bytes'] / 1e6:.1f} MB in {r['files']} files, "
                      f"{r['files'] / r['tasks']:.1f} files per task ({r['tasks']} tasks), "
                      f"block writes {1000 * r['block_writes'] / r['tasks']:.1f} ms per task, "
                      f"grid compute {r['compute']:.1f} s, wall {r['wall']:.1f} s, atlas "
                      f"{(r['atlas'] or 0):.1f} s", flush=True)
                if a.keep is None:
                    subprocess.run(["rm", "-rf", str(store)])
        for key, what in (("bytes", "bytes"), ("files", "files"),
                          ("block_writes", "write time per task")):
            ratios = [(b[key] / b["tasks"]) / (x[key] / x["tasks"]) if key == "block_writes"
                      else b[key] / x[key] for x, b in zip(rows["A"], rows["B"])]
            print(f"{scene}: {what} B / A pair by pair: "
                  + ", ".join(f"{q:.2f}x" for q in ratios))
    return 0


if __name__ == "__main__":
    sys.exit(main())
