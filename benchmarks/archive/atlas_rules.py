# Answered (study/solve/atlas.py, STALL_RATIO and FAR_FROM_FOLD; BENCHMARKS.md section 10): the rules lose no orbit; both kept.
"""One rule of the atlas's shots off and on over the same grid (study.solve.atlas):

* ``half_steps``: a shot that fails from an orbit far from its fold is tried again in two half
  steps (FAR_FROM_FOLD);
* ``stall``: a continuation's Newton gives up once its residual creeps (STALL_RATIO).

    .venv/bin/python benchmarks/archive/atlas_rules.py RULE scenes/default.toml [--workers 2] [--keep DIR]

The scene's grid once (``hertzmap run --skip-atlas``), copied twice; then the rest of the run
(the atlas, its census rounds, the curves) on each copy, one after the other: "off" through
the run's developer hook for the atlas's tile function (the same tiles with the rule switched
off: OFF below), "on" as the scene runs. Prints the stores' counts
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

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks.map_completeness import counts, print_table, run_scene  # noqa: E402


#: each rule's module constant and its value when switched off
OFF = {"half_steps": ("FAR_FROM_FOLD", math.inf), "stall": ("STALL_RATIO", 1.0)}


def _tile_without(rule: str, *args, **kwargs):
    """study.solve.atlas.atlas_tile with ``rule`` switched off (in this worker)."""
    from hertzmap.study.solve import atlas

    name, value = OFF[rule]
    setattr(atlas, name, value)
    return atlas.atlas_tile(*args, **kwargs)


def tile_without_half_steps(*args, **kwargs):
    return _tile_without("half_steps", *args, **kwargs)


def tile_without_stall(*args, **kwargs):
    return _tile_without("stall", *args, **kwargs)


def _shots(store: Path) -> dict[str, int]:
    line = next((ln for ln in store.with_suffix(".log").read_text().splitlines()
                 if ln.startswith("atlas: ")), "")
    m = re.search(r"; (\d+) shots over", line)
    return {"atlas shots": int(m.group(1)) if m else -1}


def main(argv: list[str]) -> int:
    if len(argv) < 2 or argv[0] not in OFF:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    rule, scene = argv[0], Path(argv[1])
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
        off = run_scene(scene, stores["off"],
                        ["--atlas-tile", f"benchmarks.archive.atlas_rules:tile_without_{rule}"],
                        workers, env)
        on = run_scene(scene, stores["on"], [], workers, env)
        print(f"{scene}: the same grid; the atlas without (off) and with (on) the rule {rule}")
        print_table(counts(str(stores["off"])) | _shots(stores["off"]) | off,
               counts(str(stores["on"])) | _shots(stores["on"]) | on, ("off", "on"))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
