"""What the contact does on a scene before and after the atlas, side by side: orbits by class and
period, points holding a stable orbit of each period, the census's attractors by kind (and why
the unsettled ones are), orbits the slots dropped, orbits the atlas added, and the cost.

    .venv/bin/python benchmarks/map_completeness.py --run scenes/default.toml [--workers 2] [--keep DIR]
    .venv/bin/python benchmarks/map_completeness.py BEFORE.zarr AFTER.zarr

``--run``: the scene twice in this process's session, one run after the other on the same
machine: "before" is the grid alone with the census's first pass only (no atlas, no longer
passes: ``max_transient_periods = transient_periods``; ``hertzmap run --skip-atlas``), "after"
the scene as it is; the costs are the two runs' summaries (task compute, atlas compute, wall); ``--keep DIR``
writes the two stores (before.zarr, after.zarr) and the runs' output there.
With two stores: their counts only (nothing recomputed).
"""
from __future__ import annotations

import re
import subprocess
import sys
import tempfile
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

from hertzmap.study import products as P
from hertzmap.study.orbit_rules import CLASS_LABELS


def counts(path: str) -> dict[str, int]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = xr.open_zarr(path, chunks=None).load()
    out: dict[str, int] = {"points": int(np.prod([ds.sizes[a] for a in ("omega", "sigma", "zeta")]))}
    ok = P.valid_orbits(ds).values
    cls = P.orbit_classes(ds).values
    for code, label in CLASS_LABELS.items():
        out[f"orbits: {label}"] = int(((cls == code) & ok).sum())
    period = ds["period"].values
    stable = ds["stable"].values & ok
    for m in np.unique(period[ok]):
        out[f"orbits of period {int(m)}"] = int(((period == m) & ok).sum())
        out[f"points with a stable {int(m)}T orbit"] = int(((period == m) & stable).any(-1).sum())
    if "attractor_kind" in ds:
        kind = ds["attractor_kind"].values
        for name, code in (("periodic", 1), ("non_periodic", 2), ("unsettled", 3), ("failed", 4)):
            out[f"points with a {name} attractor"] = int((kind == code).any(-1).sum())
        if "unsettled_reason" in ds:
            reason = ds["unsettled_reason"].values
            for name, code in (("period_limit", 1), ("work_budget", 2)):
                out[f"unsettled points: {name}"] = int(((kind == 3) & (reason == code)).any(-1).sum())
    if "orbits_dropped" in ds:
        out["orbits dropped (slots full)"] = int(np.clip(ds["orbits_dropped"].values, 0, None).sum())
    if "atlas_round" in ds:
        out["orbits added by the atlas"] = int(((ds["atlas_round"].values > 0) & ok).sum())
    return out


def _before_study(scene: Path, folder: Path) -> Path:
    """The scene's study file with no longer census passes (the first pass only)."""
    text = scene.read_text()
    study = tomllib.loads(text)
    search = study.get("search", {})
    if search.get("attractors", "never") != "never":
        lines = [ln for ln in text.splitlines()
                 if not ln.strip().startswith("max_transient_periods")]
        at = next(i for i, ln in enumerate(lines) if ln.strip() == "[search]")
        lines.insert(at + 1, f"max_transient_periods = {search.get('transient_periods', 500)}")
        text = "\n".join(lines) + "\n"
    out = folder / scene.name
    out.write_text(text)
    return out


def run_scene(study: Path, store: Path, extra: list[str], workers: int,
         env: dict | None = None) -> dict[str, float]:
    """hertzmap run; the costs its summary prints."""
    cmd = [str(Path(sys.executable).parent / "hertzmap"), "run", str(study),
           "--store", str(store), "--workers", str(workers), *extra]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env)
    store.with_suffix(".log").write_text(proc.stdout)
    cost = {"wall (s)": time.perf_counter() - t0}
    m = re.search(r"task compute ([0-9.]+) s", proc.stdout)
    cost["grid compute (s)"] = float(m.group(1)) if m else float("nan")
    m = re.search(r"^atlas: .* ([0-9.]+) s compute", proc.stdout, re.M)
    cost["atlas compute (s)"] = float(m.group(1)) if m else 0.0
    return cost


def print_table(a: dict, b: dict, labels: tuple[str, str] = ("before", "after")) -> None:
    width = max(len(k) for k in a | b)
    print(f"{'':{width}}  {labels[0]:>10}  {labels[1]:>10}")
    for key in list(a) + [k for k in b if k not in a]:
        x, y = a.get(key, "-"), b.get(key, "-")
        x, y = (f"{v:.1f}" if isinstance(v, float) else v for v in (x, y))
        print(f"{key:{width}}  {x:>10}  {y:>10}")


def main(argv: list[str]) -> int:
    if len(argv) >= 2 and argv[0] == "--run":
        scene = Path(argv[1])
        workers = int(argv[argv.index("--workers") + 1]) if "--workers" in argv else 2
        keep = argv[argv.index("--keep") + 1] if "--keep" in argv else None
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(keep or tmp)
            folder.mkdir(parents=True, exist_ok=True)
            before = run_scene(_before_study(scene, folder), folder / "before.zarr",
                          ["--skip-atlas"], workers)
            after = run_scene(scene, folder / "after.zarr", [], workers)
            print(f"{scene}: before = grid, census first pass only; after = the scene as is")
            print_table(counts(str(folder / "before.zarr")) | before,
                   counts(str(folder / "after.zarr")) | after)
        return 0
    if len(argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    print_table(counts(argv[0]), counts(argv[1]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
