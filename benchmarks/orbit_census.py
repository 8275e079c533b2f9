"""Census of the periodic orbits the block solver finds on fixed grid lines, to compare solver
versions: a faster solver must not lose orbits.

    .venv/bin/python benchmarks/orbit_census.py --save results/census_new.npz
    .venv/bin/python benchmarks/orbit_census.py --save new.npz --compare old.npz

(for an older version: ``git stash`` or ``git worktree add``, run it there with --save, come
back). Four sets of lines, about 3,400 grid points, 1T and 2T seeds, rtol 1e-10:
the default study's window (zeta 0.01, 9 sigma lines), a wider window at light and stronger
damping (zeta 0.005 and 0.05), the linear impact oscillator (n = 1), and the band where the
isola meets the 1T contact-loss region (sigma 0.2625..0.35). Prints, per set, the
converged slots by period and the wall time; with --compare, the points whose sets of orbits
(period, peak-to-peak q to 1e-6) differ. Where more orbits coexist than the 4 slots hold, two
versions may keep different subsets: such points are listed with both sets.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

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


def census() -> dict[str, np.ndarray]:
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


def compare(new, old) -> int:
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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--save", help="write the census to this .npz")
    ap.add_argument("--compare", help="an earlier census (.npz) to compare with")
    a = ap.parse_args(argv)
    new = census()
    if a.save:
        np.savez(a.save, **new)
    if a.compare:
        compare(new, dict(np.load(a.compare)))


if __name__ == "__main__":
    main()
