"""What a grid pays per stored orbit against what the kernel pays for the same orbit, one run.

    .venv/bin/python benchmarks/grid_cost.py                 (every 4th sigma line of the default study)
    .venv/bin/python benchmarks/grid_cost.py --every 1       (all 77 lines, ~1 min of one core)

1. **Grid.** The default study's blocks (one omega line each, study.solve.block.solve_block with
   the study's own options, in this process, no Dask), every ``--every``-th sigma line: solver
   time per stored orbit (converged slots in the returned arrays).
2. **Kernel.** A sample of those stored orbits (``--sample``, seeded) re-solved in one batch by
   the numba entry point (kernels.shooting.shoot_batch_into, the study's rtol, exponent and
   harmonics) from a guess 1e-2 away in q0 and q'0: time per orbit, the fastest of 5 rounds.
   Printed: grid per stored orbit / kernel per orbit (issue 16's target: <= 3x).
3. **Where the rest goes.** The same lines again with every shooting call timed row by row
   (each seed solved as a batch of one, so each has its own time; the per-call overhead of a
   few us is in these figures, and their sum is printed against the plain run's). The rows are
   classed by outcome: *stored* (the first converged solve of an orbit that ends in a slot),
   *again* (a converged solve of an orbit the point already had: the way down of the sweep,
   two seeds onto one orbit, re-solves at the minimal period), *not stored* (converged, but no
   slot holds it: a 2T solve onto the 1T orbit, more orbits than slots), *failed* (no
   convergence: exploratory seeds, continuation past a fold). The phases' times (sweeps, fold
   turning, census) are the LineSearch's own. Outside the shooting calls: the census's
   transients (its batch kernel and Lyapunov exponent), the period maps of the continuation
   (kernels.continuation.System.map: the fold turning's arc-length paths), and the solver's
   Python between kernel calls.
4. **What the target leaves.** 3x the kernel per stored orbit, against the work no search of
   these orbits can skip: their first solves and the census's transients (which the census
   runs whatever the search found).
"""
from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.machine import load_average  # noqa: E402
from hertzmap.kernels import status as st  # noqa: E402
from hertzmap.kernels.periodic_orbit import DEFAULT_MAX_STEPS  # noqa: E402
from hertzmap.kernels.model import MODELS  # noqa: E402
from hertzmap.kernels import attractors as attractors_mod  # noqa: E402
from hertzmap.kernels.shooting import F, N_FIELDS, shoot_batch_into  # noqa: E402
from hertzmap.kernels import continuation as cont_mod  # noqa: E402
from hertzmap.study.solve import block as block_mod  # noqa: E402
from hertzmap.study.solve import census as census_mod  # noqa: E402
from hertzmap.study.solve import line as line_mod  # noqa: E402
from hertzmap.study.solve import point as point_mod  # noqa: E402
from hertzmap.study.orbit_rules import same_orbit  # noqa: E402
from hertzmap.study.spec import load_study  # noqa: E402


def lines(study, every: int):
    omega = study.axis("omega")
    sigma = study.axis("sigma")
    zeta = study.axis("zeta")
    for j in range(0, sigma.size, every):
        for k in range(zeta.size):
            yield omega, sigma[j:j + 1], zeta[k:k + 1]


def solve_grid(study, every: int):
    kw = study.solver_kwargs()
    out, seconds = [], 0.0
    for omega, sigma, zeta in lines(study, every):
        t0 = time.perf_counter()
        arrays = block_mod.solve_block(omega, sigma, zeta, **kw)
        seconds += time.perf_counter() - t0
        out.append((sigma[0], zeta[0], omega, arrays))
    return out, seconds


def stored_orbits(results):
    """(omega, sigma, zeta, period, q0, v0, min_q, max_q, ptp, trace of M) of every converged
    slot."""
    rows = []
    for sigma, zeta, omega, a in results:
        ok = a["status"][:, 0, 0, :] == st.CONVERGED
        for i, s in zip(*np.nonzero(ok)):
            rows.append((omega[i], sigma, zeta, int(a["period"][i, 0, 0, s]),
                         a["q0"][i, 0, 0, s], a["v0"][i, 0, 0, s],
                         a["min_q"][i, 0, 0, s], a["max_q"][i, 0, 0, s],
                         a["ptp"][i, 0, 0, s], float(np.sum(a["multipliers"][i, 0, 0, s]).real)))
    return np.array(rows, float).reshape(-1, 10)


def kernel_time(orbits: np.ndarray, kw: dict, rounds: int = 5):
    n = len(orbits)
    w, s, z = (np.ascontiguousarray(orbits[:, c]) for c in range(3))
    m = orbits[:, 3].astype(np.int64)
    q = np.ascontiguousarray(orbits[:, 4] + 1e-2)
    v = np.ascontiguousarray(orbits[:, 5] + 1e-2)
    rtol = float(kw.get("rtol", 1e-10))
    out = np.empty((n, N_FIELDS))
    args = (w, s, z, m, q, v, float(kw.get("exponent", 1.5)), MODELS[kw.get("model", "hertz")],
            rtol, rtol, point_mod.MAX_ITER_1T, 1.0, DEFAULT_MAX_STEPS, bool(kw.get("harmonics", True)),
            out)
    shoot_batch_into(*args)
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        shoot_batch_into(*args)
        best = min(best, time.perf_counter() - t0)
    back = np.abs(out[:, F["q0"]] - orbits[:, 4]) <= 1e-6 * (1 + np.abs(orbits[:, 4]))
    ok = (out[:, F["status"]] == st.CONVERGED) & back
    return best / n, int(ok.sum())


class Recorder:
    """Wraps the shooting entry point of study.solve.point: each row solved alone and timed."""

    def __init__(self):
        # (omega, sigma, zeta, period, seconds, status, q0, v0, min_q, max_q, ptp, trace of M)
        self.rows = []

    def __call__(self, w, s, z, m, q, v, *rest):
        out = rest[-1]
        for i in range(len(w)):
            row = out[i:i + 1]
            t0 = time.perf_counter()
            shoot_batch_into(w[i:i + 1], s[i:i + 1], z[i:i + 1], m[i:i + 1], q[i:i + 1],
                             v[i:i + 1], *rest[:-1], row)
            dt = time.perf_counter() - t0
            self.rows.append((w[i], s[i], z[i], int(m[i]), dt, int(row[0, F["status"]]),
                              row[0, F["q0"]], row[0, F["v0"]], row[0, F["min_q"]],
                              row[0, F["max_q"]], row[0, F["ptp"]], row[0, F["trace_m"]]))


def classify(rec: Recorder, stored: np.ndarray):
    """Seconds and counts per class (see the module's docstring); a solve is a stored orbit's
    by study.orbit_rules.same_orbit, the rule the block solver keeps orbits by."""
    index = defaultdict(list)
    for r in stored:
        index[(r[0], r[1], r[2], int(r[3]))].append(
            {"period": int(r[3]), "min_q": r[6], "max_q": r[7], "ptp": r[8], "trace_m": r[9]})
    seen = set()
    secs, count = defaultdict(float), defaultdict(int)
    for w, s, z, m, dt, status, q0, v0, mn, mx, ptp, trace in rec.rows:
        if status != st.CONVERGED:
            cls = f"failed {m}T"
        else:
            solved = {"period": m, "min_q": mn, "max_q": mx, "ptp": ptp, "trace_m": trace}
            match = next((n for n, orbit in enumerate(index.get((w, s, z, m), ()))
                          if same_orbit(solved, orbit)), None)
            if match is None:
                cls = "not stored"
            elif (w, s, z, m, match) in seen:
                cls = "again"
            else:
                seen.add((w, s, z, m, match))
                cls = "stored"
        secs[cls] += dt
        count[cls] += 1
    return secs, count


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study", default=str(ROOT / "scenes" / "default.toml"))
    ap.add_argument("--every", type=int, default=4, help="every k-th sigma line (default 4)")
    ap.add_argument("--sample", type=int, default=1000, help="stored orbits re-solved")
    ap.add_argument("--no-breakdown", action="store_true")
    a = ap.parse_args(argv)
    study = load_study(a.study)
    kw = study.solver_kwargs()
    print(f"{study.name}: every {a.every}th sigma line; load average "
          + load_average(), flush=True)
    # compile (or load) everything first: the first line would otherwise pay it
    first = next(lines(study, a.every))
    block_mod.solve_block(first[0][:8], first[1], first[2], **kw)

    results, grid_s = solve_grid(study, a.every)
    stored = stored_orbits(results)
    points = sum(r[2].size for r in results)
    rng = np.random.default_rng(16)
    pick = rng.choice(len(stored), size=min(a.sample, len(stored)), replace=False)
    k_per, k_ok = kernel_time(stored[pick], kw)
    g_per = grid_s / len(stored)
    print(f"grid: {grid_s:.2f} s of solver time for {points} points, {len(stored)} stored orbits: "
          f"{g_per * 1e6:.0f} us per stored orbit ({grid_s / points * 1e3:.2f} ms per point)")
    print(f"kernel: {len(pick)} of them from a guess 1e-2 away in one batch: "
          f"{k_per * 1e6:.1f} us per orbit (fastest of 5; {k_ok} converged back to the stored "
          f"start point)")
    print(f"grid per stored orbit / kernel per orbit: {g_per / k_per:.1f}x (target <= 3x)",
          flush=True)
    if a.no_breakdown:
        return 0

    rec = Recorder()
    phases = defaultdict(float)
    point_mod.shoot_batch_into = rec
    # the other kernels' time: the census's transients, the continuation's period maps
    kernel_secs = defaultdict(float)

    def timed_kernel(fn, key):
        def call(*args, **kws):
            t0 = time.perf_counter()
            try:
                return fn(*args, **kws)
            finally:
                kernel_secs[key] += time.perf_counter() - t0
        return call
    system_map = cont_mod.System.map
    census_mod.attractor_batch_into = timed_kernel(census_mod.attractor_batch_into,
                                                   "census transients")
    census_mod.lyapunov_into = timed_kernel(census_mod.lyapunov_into, "census transients")
    cont_mod.System.map = timed_kernel(cont_mod.System.map, "continuation maps")
    originals = {}
    for name, key in (("sweep", "sweeps"), ("turn_folds", "fold turning"),
                      ("run_census", "census")):
        fn = getattr(line_mod.LineSearch, name)
        originals[name] = fn

        def timed(self, *args, _fn=fn, _key=key, **kws):
            t0 = time.perf_counter()
            try:
                return _fn(self, *args, **kws)
            finally:
                phases[_key] += time.perf_counter() - t0
        setattr(line_mod.LineSearch, name, timed)
    try:
        results2, grid2 = solve_grid(study, a.every)
    finally:
        point_mod.shoot_batch_into = shoot_batch_into
        for name, fn in originals.items():
            setattr(line_mod.LineSearch, name, fn)
        census_mod.attractor_batch_into = attractors_mod.attractor_batch_into
        census_mod.lyapunov_into = attractors_mod.lyapunov_into
        cont_mod.System.map = system_map
    same = all(np.array_equal(r1[3]["q0"], r2[3]["q0"], equal_nan=True)
               for r1, r2 in zip(results, results2))
    secs, count = classify(rec, stored)
    shoot_total = sum(secs.values())
    print(f"\nbreakdown (row by row; {grid2:.2f} s in all against {grid_s:.2f} s plain; "
          f"the same stored orbits: {same}):")
    print(f"  {'phase':28s} {'s':>7s} {'share':>6s}")
    for key in ("sweeps", "fold turning", "census"):
        print(f"  {key:28s} {phases[key]:7.2f} {phases[key] / grid2:6.1%}")
    print(f"  {'shooting calls (all phases)':28s} {shoot_total:7.2f} {shoot_total / grid2:6.1%}")
    print(f"  {'class of shooting row':28s} {'s':>7s} {'share':>6s} {'rows':>7s} {'us/row':>7s}")
    for cls in sorted(secs, key=lambda c: -secs[c]):
        print(f"  {cls:28s} {secs[cls]:7.2f} {secs[cls] / grid2:6.1%} {count[cls]:7d} "
              f"{secs[cls] / count[cls] * 1e6:7.0f}")
    rest = grid2 - shoot_total
    print(f"  {'outside shooting calls':28s} {rest:7.2f} {rest / grid2:6.1%}")
    for key in ("census transients", "continuation maps"):
        print(f"    {key:26s} {kernel_secs[key]:7.2f} {kernel_secs[key] / grid2:6.1%}")
    python = rest - sum(kernel_secs.values())
    print(f"    {'Python (solver, no kernel)':26s} {python:7.2f} {python / grid2:6.1%}")
    print(f"stored orbits {len(stored)}; first solves of them {count['stored']} "
          f"({secs['stored'] / max(1, count['stored']) * 1e6:.0f} us each, row by row)")
    # what the target leaves: 3x the kernel per stored orbit, against the work no search of
    # these orbits can skip (their first solves, and the census's transients, which the
    # census needs whatever the search)
    budget = 3.0 * k_per * len(stored)
    floor = secs["stored"] + kernel_secs["census transients"]
    print(f"the target's budget, 3 x {k_per * 1e6:.1f} us x {len(stored)} stored orbits: "
          f"{budget:.2f} s; the first solves of the stored orbits and the census's transients "
          f"alone: {floor:.2f} s ({floor / budget:.2f}x the budget)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
