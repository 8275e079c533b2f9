"""The atlas's fold-aware step on and off over the same grid: a shot that fails from an orbit
far from its fold is tried again in two half steps (study.solve.atlas.FAR_FROM_FOLD).

    .venv/bin/python benchmarks/atlas_fold_step.py studies/default.toml [--workers 2] [--keep DIR]

The scene's grid once (``hertzmap run --skip-atlas``), copied twice; then the rest of the run
(the atlas, its census rounds, the curves) on each copy, one after the other: "off" through
the run's developer hook for the atlas's tile function (tile_without_half_steps below: the
same tiles with FAR_FROM_FOLD infinite), "on" as the scene runs. Prints the stores' counts
(benchmarks/map_completeness.py) and the atlas's compute beside its shots.
"""
from __future__ import annotations

import math
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.map_completeness import counts, print_table, run_scene  # noqa: E402


def tile_without_half_steps(*args, **kwargs):
    """study.solve.atlas.atlas_tile with the half steps switched off (in this worker)."""
    from hertzmap.study.solve import atlas

    atlas.FAR_FROM_FOLD = math.inf
    return atlas.atlas_tile(*args, **kwargs)


def _shots(store: Path) -> dict[str, int]:
    line = next((ln for ln in store.with_suffix(".log").read_text().splitlines()
                 if ln.startswith("atlas: ")), "")
    m = re.search(r"; (\d+) shots over", line)
    return {"atlas shots": int(m.group(1)) if m else -1}


def main(argv: list[str]) -> int:
    if not argv or argv[0].startswith("-"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    scene = Path(argv[0])
    workers = int(argv[argv.index("--workers") + 1]) if "--workers" in argv else 2
    keep = argv[argv.index("--keep") + 1] if "--keep" in argv else None
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(keep or tmp)
        folder.mkdir(parents=True, exist_ok=True)
        grid = folder / "grid.zarr"
        run_scene(scene, grid, ["--skip-atlas"], workers)
        stores = {}
        for name in ("off", "on"):
            stores[name] = folder / f"{name}.zarr"
            shutil.rmtree(stores[name], ignore_errors=True)
            shutil.copytree(grid, stores[name])
        off = run_scene(scene, stores["off"], ["--atlas-tile",
                                          "benchmarks.atlas_fold_step:tile_without_half_steps"],
                   workers, env)
        on = run_scene(scene, stores["on"], [], workers, env)
        print(f"{scene}: the same grid; the atlas without (off) and with (on) the half steps")
        print_table(counts(str(stores["off"])) | _shots(stores["off"]) | off,
               counts(str(stores["on"])) | _shots(stores["on"]) | on, ("off", "on"))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
