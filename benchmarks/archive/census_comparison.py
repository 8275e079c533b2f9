# Answered (BENCHMARKS.md, Targets, issue 21, and section 9): the 1T/2T search costs 1.12x the sweeps' CPU and loses no orbit to discovery.
"""The default search against the one before fold turning and against discovery, on one grid:
the periodic orbits found per class, the orbits one finds and another misses, and the cost.

    .venv/bin/python benchmarks/archive/census_comparison.py                    # the default study's grid
    .venv/bin/python benchmarks/archive/census_comparison.py --sigma 0.2 0.5 0.8 --omega 0.25 2.5 181

Four searches of the periodic orbits (the census's transients are timed on their own by
``benchmarks/run_cost.py census``):

* ``before``: the seeded sweeps alone (the default search before fold turning);
* ``no-census``: the sweeps and fold turning (study.solve.line): the default's search of the
  1T and 2T orbits, without the attractor census;
* ``default``: the same and the attractor census (where no stable orbit was found, and at the
  probe points), whose orbits of every period are followed along the line (census.py,
  line.py): today's default;
* ``discover``: the sweeps and discovery (transients at 12 points and continuation of every
  branch across the line: ``[search] discover = true``).

Every omega line is one block, solved by the four in turn (A B C D, then D C B A on the next line,
so that a drift of the machine's speed falls on all four alike: one round of benchmarks/abba.py). Orbits are counted from the
solver's own lists (every orbit: none dropped), per class (study.orbit_rules), and compared orbit by
orbit with the identity rule.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.abba import abba  # noqa: E402
from benchmarks.search_ab import orbits_of  # noqa: E402
from hertzmap.study.orbit_rules import CLASS_NAMES, class_codes, same_orbit  # noqa: E402
from hertzmap.study.solve.block import solve_block  # noqa: E402
from hertzmap.study.spec import load_study  # noqa: E402

SEARCHES = {"before": dict(turn_folds=False, seed_strides=(1, 1)),
            "no-census": dict(turn_folds=True, attractors="never"),
            "default": dict(turn_folds=True, attractors="where-none-stable"),
            "discover": dict(turn_folds=False, discover=True, seed_strides=(1, 1))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study", default="scenes/default.toml")
    ap.add_argument("--omega", type=float, nargs=3, metavar=("START", "STOP", "NUM"))
    ap.add_argument("--sigma", type=float, nargs="+")
    ap.add_argument("--zeta", type=float, default=None)
    ap.add_argument("--lines", type=int, default=None, help="only every k-th sigma line")
    a = ap.parse_args(argv)
    s = load_study(a.study)
    omega = np.linspace(*a.omega[:2], int(a.omega[2])) if a.omega else s.axis("omega")
    sigmas = np.array(a.sigma) if a.sigma else s.axis("sigma")
    if a.lines:
        sigmas = sigmas[::a.lines]
    zeta = a.zeta if a.zeta is not None else float(s.axis("zeta")[0])
    kw = dict(periods=s.periods, exponent=s.exponent or 1.5, model=s.model, rtol=s.rtol,
              harmonics=False)
    names = list(SEARCHES)
    solve_block(omega[:3], sigmas[:1], [zeta], **kw)          # compile / warm the cache
    seconds = {n: 0.0 for n in names}
    counts = {n: np.zeros(len(CLASS_NAMES), int) for n in names}
    missing = {n: [] for n in names}
    found = {}

    def search(n):
        def solve(li):
            t0 = time.process_time()
            r = solve_block(omega, [sigmas[li]], [zeta], **kw, **SEARCHES[n])
            dt = time.process_time() - t0
            found[n] = orbits_of(r)
            ok = r["status"] == 0
            c = class_codes(ok, r["period"], r["stable"], r["loses_contact"])
            counts[n] += np.bincount(c[ok].ravel(), minlength=len(CLASS_NAMES))
            return {"CPU": dt}
        return solve

    def missed(run):
        """After a line's last search: the orbits discovery found that each search lacks."""
        if len(found) < len(names):
            return
        for n in names:
            for i, w in enumerate(omega):
                for orb in found["discover"][i]:
                    if not any(same_orbit(orb, o) for o in found[n][i]):
                        missing[n].append((float(w), float(sigmas[run.round]), orb["period"],
                                           orb["stable"]))
        found.clear()

    res = abba({n: search(n) for n in names}, len(sigmas), each=missed)
    for n in names:
        seconds[n] = sum(res.of(n, "CPU"))
    print(f"grid: {omega.size} omega ({omega.min():g}..{omega.max():g}) x {sigmas.size} sigma "
          f"({sigmas.min():g}..{sigmas.max():g}), zeta {zeta:g}, periods {list(s.periods)}")
    print(f"{'class':60s} " + " ".join(f"{n:>9s}" for n in names))
    for code in range(1, len(CLASS_NAMES)):
        print(f"{CLASS_NAMES[code]:60s} " + " ".join(f"{counts[n][code]:9d}" for n in names))
    print(f"{'all orbits':60s} " + " ".join(f"{counts[n][1:].sum():9d}" for n in names))
    print(f"{'solver CPU seconds (one process, lines interleaved)':60s} "
          + " ".join(f"{seconds[n]:9.2f}" for n in names))
    print(f"cost of the 1T/2T search (no census) / the search before: "
          f"{seconds['no-census'] / seconds['before']:.2f}x; with the census (default): "
          f"{seconds['default'] / seconds['before']:.2f}x;"
          f" discovery / sweeps: {seconds['discover'] / seconds['before']:.2f}x")
    for n in ("no-census", "default", "discover"):
        print(res.report(n, "before", "CPU", f"  {n} / before, line by line"))
    for n in ("before", "no-census", "default"):
        print(f"orbits discovery finds that {n} misses: {len(missing[n])}"
              + ("" if not missing[n] else "; first: " + ", ".join(
                  f"(omega {w:.4f}, sigma {sg:.4f}, period {p}, stable {st})"
                  for w, sg, p, st in missing[n][:5])))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
