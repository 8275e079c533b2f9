"""The line search of this tree against another revision's, line by line on one study's grid:
the periodic orbits found per class, the orbits one finds and the other misses, the census's
kinds, and the CPU of each (issue 16: "no orbit lost, census comparison by class, same grid,
before and after").

    .venv/bin/python benchmarks/search_ab.py --vs 2ec7ef9                  (default study, every 2nd line)
    .venv/bin/python benchmarks/search_ab.py --vs 2ec7ef9 --study scenes/fine_map.toml --every 5

B is the revision's study/solve/line.py (the line search: sweeps, fold turning, census and
the traces of what it finds), loaded as a module beside this tree's and used by this tree's
study.solve.block.solve_block in place of its own; everything else (kernels, seeds, census,
block) is this tree's. So it compares changes confined to line.py; for others, run
benchmarks/orbit_census.py in both trees. Every ``--every``-th sigma line (from ``--offset``)
is one block, solved by A then B, then B then A on the next line (a drift of the machine's
speed falls on both alike); CPU is this process's. Orbits come from the solver's own lists
(16 slots: none dropped), classed by study.orbit_rules and compared orbit by orbit with its identity
rule, as benchmarks/census_comparison.py reads them (its orbits_of).
"""
from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.census_comparison import SLOTS, orbits_of  # noqa: E402
from benchmarks.machine import load_average  # noqa: E402
from hertzmap.study.orbit_rules import CLASS_NAMES, class_codes, same_orbit  # noqa: E402
from hertzmap.study.solve import block as block_mod  # noqa: E402
from hertzmap.study.spec import load_study  # noqa: E402


def line_module(rev: str, folder: str):
    """The revision's study/solve/line.py, imported under another name."""
    src = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:study/solve/line.py"],
                         check=True, capture_output=True, text=True).stdout
    path = Path(folder) / f"line_{rev.replace('/', '_')}.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = mod            # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vs", required=True, help="the revision B (e.g. a commit)")
    ap.add_argument("--study", default=str(ROOT / "scenes" / "default.toml"))
    ap.add_argument("--every", type=int, default=2, help="every k-th sigma line (default 2)")
    ap.add_argument("--offset", type=int, default=0, help="the first sigma line")
    a = ap.parse_args()

    study = load_study(a.study)
    kw = dict(study.solver_kwargs(), max_solutions=SLOTS)
    omega, sigma, zeta = study.axis("omega"), study.axis("sigma"), study.axis("zeta")
    with tempfile.TemporaryDirectory() as tmp:
        searches = {"A": block_mod.LineSearch, "B": line_module(a.vs, tmp).LineSearch}
        print(f"{study.name}: every {a.every}-th sigma line from {a.offset}; A = this tree, "
              f"B = {a.vs}; load average {load_average()}")
        block_mod.solve_block(omega[:4], sigma[:1], zeta, **kw)       # compiled or loaded
        cpu = {"A": 0.0, "B": 0.0}
        size = max(CLASS_NAMES) + 1
        count = {w: np.zeros(size, int) for w in cpu}
        lost, gained, kinds = [], [], 0
        try:
            for n, j in enumerate(range(a.offset, sigma.size, a.every)):
                got = {}
                for w in ("AB" if n % 2 == 0 else "BA"):
                    block_mod.LineSearch = searches[w]
                    t0 = time.process_time()
                    got[w] = block_mod.solve_block(omega, sigma[j:j + 1], zeta, **kw)
                    cpu[w] += time.process_time() - t0
                    r = got[w]
                    ok = r["status"] == 0
                    codes = class_codes(ok, r["period"], r["stable"], r["loses_contact"])
                    count[w] += np.bincount(codes[ok].ravel(), minlength=size)
                oa, ob = orbits_of(got["A"]), orbits_of(got["B"])
                for i in range(omega.size):
                    lost += [(omega[i], sigma[j], o["period"], o["stable"]) for o in ob[i]
                             if not any(same_orbit(o, x) for x in oa[i])]
                    gained += [(omega[i], sigma[j], o["period"], o["stable"]) for o in oa[i]
                               if not any(same_orbit(o, x) for x in ob[i])]
                if "attractor_kind" in got["A"]:
                    kinds += int((got["A"]["attractor_kind"] != got["B"]["attractor_kind"])
                                 .any(axis=-1).sum())
        finally:
            block_mod.LineSearch = searches["A"]
    print(f"CPU: A {cpu['A']:.2f} s, B {cpu['B']:.2f} s, B / A {cpu['B'] / cpu['A']:.3f}")
    print(f"{'class':58s} {'A':>7s} {'B':>7s}")
    for c in sorted(CLASS_NAMES):
        if c and (count["A"][c] or count["B"][c]):
            print(f"{CLASS_NAMES[c]:58s} {count['A'][c]:7d} {count['B'][c]:7d}")
    print(f"{'all':58s} {count['A'][1:].sum():7d} {count['B'][1:].sum():7d}")

    def show(rows):
        return "; ".join(f"{p}T{' stable' if s else ''} at omega {w:.4f}, sigma {g:.4f}"
                         for w, g, p, s in rows[:8]) + (" ..." if len(rows) > 8 else "")
    print(f"in B, not in A (lost): {len(lost)}{': ' + show(lost) if lost else ''}")
    print(f"in A, not in B (gained): {len(gained)}{': ' + show(gained) if gained else ''}")
    print(f"points whose census kinds differ: {kinds}")
    print(f"load average at the end {load_average()}")


if __name__ == "__main__":
    main()
