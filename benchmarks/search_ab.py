"""The search of this tree against another version's: no orbit lost (issue 16: "no orbit lost,
census comparison by class, same grid, before and after").

    .venv/bin/python benchmarks/search_ab.py --vs 2ec7ef9                  (default study, every 2nd line)
    .venv/bin/python benchmarks/search_ab.py --vs 2ec7ef9 --study scenes/fine_map.toml --every 5
    .venv/bin/python benchmarks/search_ab.py --save results/census_new.npz [--against old.npz]

**--vs REV**: B is the revision's study/solve/line.py (the line search: sweeps, fold turning,
census and the traces of what it finds), loaded as a module beside this tree's and used by this
tree's study.solve.block.solve_block in place of its own; everything else (kernels, seeds,
census, block) is this tree's. So it compares changes confined to line.py; for others, use
``--save`` in both trees. Every ``--every``-th sigma line (from ``--offset``) is one ABBA round
of benchmarks/abba.py: solved by A then B, then B then A on the next line (a drift of the
machine's speed falls on both alike); CPU is this process's, B / A line by line and in all.
Orbits come from the solver's own lists (every orbit a point has: none dropped), classed by study.orbit_rules
and compared orbit by orbit with its identity rule (``orbits_of``).

**--save FILE** (any change, kernels included: run it in each tree, ``git stash`` or ``git
worktree add``, then ``--against`` the other's file): the orbits the block solver finds on
fixed grid lines, four sets, about 3,400 grid points, 1T and 2T seeds, rtol 1e-10: the default
study's window (zeta 0.01, 9 sigma lines), a wider window at light and stronger damping (zeta
0.005 and 0.05), the linear impact oscillator (n = 1), and the band where the isola meets the
1T contact-loss region (sigma 0.2625..0.35). Prints, per set, the converged slots by period and
the wall time; with ``--against``, the points whose sets of orbits (period, peak-to-peak q to
1e-6) differ, listed with both sets (the first 10 of each set of lines).
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

from benchmarks.abba import abba, load_average  # noqa: E402


def orbits_of(r) -> list[list[dict]]:
    """Per omega point of a one-line block: each orbit's period, stable, min_q, max_q, ptp and
    trace of M, trace_m (what the identity rule study.orbit_rules.same_orbit reads)."""
    ok = r["status"][:, 0, 0, :] == 0
    out = []
    for i in range(ok.shape[0]):
        out.append([dict(period=int(r["period"][i, 0, 0, s]), stable=bool(r["stable"][i, 0, 0, s]),
                         min_q=float(r["min_q"][i, 0, 0, s]), max_q=float(r["max_q"][i, 0, 0, s]),
                         ptp=float(r["ptp"][i, 0, 0, s]),
                         trace_m=float(r["multipliers"][i, 0, 0, s].sum().real))
                    for s in np.nonzero(ok[i])[0]])
    return out


# -- --vs REV: line.py of a revision, in this process ----------------------------------------

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


def versus(a) -> None:
    from hertzmap.study.orbit_rules import CLASS_NAMES, class_codes, same_orbit
    from hertzmap.study.solve import block as block_mod
    from hertzmap.study.spec import load_study

    study = load_study(a.study)
    kw = study.solver_kwargs()
    omega, sigma, zeta = study.axis("omega"), study.axis("sigma"), study.axis("zeta")
    lines = list(range(a.offset, sigma.size, a.every))
    with tempfile.TemporaryDirectory() as tmp:
        searches = {"A": block_mod.LineSearch, "B": line_module(a.vs, tmp).LineSearch}
        print(f"{study.name}: every {a.every}-th sigma line from {a.offset}; A = this tree, "
              f"B = {a.vs}; load average {load_average()}")
        block_mod.solve_block(omega[:4], sigma[:1], zeta, **kw)       # compiled or loaded

        size = max(CLASS_NAMES) + 1
        count = {w: np.zeros(size, int) for w in "AB"}
        lost, gained, kinds = [], [], [0]
        got = {}

        def variant(w):
            def solve(k):
                block_mod.LineSearch = searches[w]
                t0 = time.process_time()
                got[w] = block_mod.solve_block(omega, sigma[lines[k]:lines[k] + 1], zeta, **kw)
                return {"CPU": time.process_time() - t0}
            return solve

        def compare(run):
            """Once both versions solved the round's line: count and compare its orbits."""
            if len(got) < 2:
                return
            j = lines[run.round]
            for w, r in got.items():
                ok = r["status"] == 0
                codes = class_codes(ok, r["period"], r["stable"], r["loses_contact"])
                count[w] += np.bincount(codes[ok].ravel(), minlength=size)
            oa, ob = orbits_of(got["A"]), orbits_of(got["B"])
            for i in range(omega.size):
                lost.extend((omega[i], sigma[j], o["period"], o["stable"]) for o in ob[i]
                            if not any(same_orbit(o, x) for x in oa[i]))
                gained.extend((omega[i], sigma[j], o["period"], o["stable"]) for o in oa[i]
                              if not any(same_orbit(o, x) for x in ob[i]))
            if "attractor_kind" in got["A"]:
                kinds[0] += int((got["A"]["attractor_kind"] != got["B"]["attractor_kind"])
                                .any(axis=-1).sum())
            got.clear()
        try:
            res = abba({"A": variant("A"), "B": variant("B")}, len(lines), each=compare)
        finally:
            block_mod.LineSearch = searches["A"]
    cpu = {w: sum(res.of(w, "CPU")) for w in "AB"}
    print(f"CPU: A {cpu['A']:.2f} s, B {cpu['B']:.2f} s, B / A {cpu['B'] / cpu['A']:.3f}")
    print(res.report("B", "A", "CPU", "CPU B / A, line by line", digits=3))
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
    print(f"points whose census kinds differ: {kinds[0]}")
    print(f"load average at the end {load_average()}")


# -- --save / --against: fixed line sets, one file per tree ----------------------------------

LINES = [
    ("default window, zeta 0.01", np.linspace(0.5, 2.5, 161),
     [0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0], [0.01], {}),
    ("wide window, zeta 0.005 and 0.05", np.linspace(0.3, 3.0, 81), [0.2, 0.5, 0.9],
     [0.005, 0.05], {}),
    ("impact oscillator n = 1", np.linspace(0.5, 2.5, 81), [0.3, 0.7], [0.02],
     {"exponent": 1.0}),
    # where the isola meets the 1T loss region (the default map's omega 0.65-0.8, sigma ~0.3):
    # 2T orbits found only by continuation along the isola
    ("isola band of the default study", np.linspace(0.5, 2.5, 161),
     list(0.05 + 0.0125 * np.arange(17, 25)), [0.01], {}),
]


def line_census() -> dict[str, np.ndarray]:
    from hertzmap.study.solve.block import solve_block

    out = {}
    for i, (name, omega, sigma, zeta, kw) in enumerate(LINES):
        t0 = time.perf_counter()
        r = solve_block(omega, np.array(sigma), np.array(zeta), harmonics=False, **kw)
        wall = time.perf_counter() - t0
        ok = r["status"] == 0
        print(f"{name}: {omega.size * len(sigma) * len(zeta)} points in {wall:.2f} s; converged "
              f"slots {ok.sum()} (1T {(ok & (r['period'] == 1)).sum()}, "
              f"2T {(ok & (r['period'] == 2)).sum()})")
        for key in ("period", "status", "ptp"):
            out[f"{i}_{key}"] = r[key]
    return out


def orbit_set(r, i, idx) -> list[tuple[int, float]]:
    per, ok, ptp = r[f"{i}_period"][idx], r[f"{i}_status"][idx] == 0, r[f"{i}_ptp"][idx]
    return sorted((int(p), round(float(x), 6)) for p, x, c in zip(per, ptp, ok) if c)


def compare_sets(new, old) -> int:
    differing = 0
    for i, (name, *_rest) in enumerate(LINES):
        shape = new[f"{i}_period"].shape[:3]
        diff = [idx for idx in np.ndindex(shape)
                if orbit_set(new, i, idx) != orbit_set(old, i, idx)]
        differing += len(diff)
        print(f"{name}: {len(diff)} points with a different set of orbits")
        for idx in diff[:10]:
            print(f"    (omega, sigma, zeta) index {idx}: old {orbit_set(old, i, idx)} "
                  f"new {orbit_set(new, i, idx)}")
    return differing


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vs", help="the revision B whose line.py is compared (e.g. a commit)")
    ap.add_argument("--study", default=str(ROOT / "scenes" / "default.toml"), help="--vs: the study")
    ap.add_argument("--every", type=int, default=2, help="--vs: every k-th sigma line (default 2)")
    ap.add_argument("--offset", type=int, default=0, help="--vs: the first sigma line")
    ap.add_argument("--save", metavar="FILE", help="solve the fixed line sets, write them (.npz)")
    ap.add_argument("--against", metavar="FILE",
                    help="with --save: the other tree's file, compared point by point")
    a = ap.parse_args(argv)
    if a.vs:
        versus(a)
        return 0
    if not (a.save or a.against):
        ap.error("give --vs REV, or --save FILE [--against OTHER]")
    new = line_census()
    if a.save:
        np.savez(a.save, **new)
    if a.against:
        return 1 if compare_sets(new, dict(np.load(a.against))) else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
