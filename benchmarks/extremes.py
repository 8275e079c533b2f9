"""The extreme-case table of benchmarks/extreme_cases.py (tested by tests/kernels/test_extremes.py),
as markdown (for RELIABILITY.md).

    .venv/bin/python benchmarks/extremes.py        (about 10-20 s with a warm numba cache)

Per case: the status at rtol 1e-10 (first of up to four guesses that converges; "guess" is its
index, 0 = linear response; the cases of ROUTES start from the point of a continuation in
sigma or omega instead, not timed here), the start-point error against a re-solve at rtol
1e-13, the residual of an independent state-only integration at rtol 1e-12
(|simulate(x0, P) - x0|), the Liouville error, the largest Floquet multiplier modulus (> 1:
unstable), contact switches per orbit, flight fraction, integrator steps of one period map
(on the orbit), Newton iterations of the successful (or last) solve, and the time of all guesses.
"""
from __future__ import annotations

from pathlib import Path
import sys

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.extreme_cases import CASES, ROUTES, RTOL, case_args, solve_case  # noqa: E402


def fmt(x, spec=".1e"):
    return "-" if x != x else format(x, spec)


def main():
    print(f"| case | omega | sigma | zeta | T | n | status (rtol {RTOL:g}) | guess | err vs 1e-13 | "
          "self-map | Liouville | max abs multiplier | switches | flight | steps/map | Newton it | ms |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for case in CASES:
        name, omega, sigma, zeta, m, n, extra = case_args(case)
        r = solve_case(omega, sigma, zeta, m, n, extra)
        guess = '-' if r['guess'] is None else str(r['guess'])
        mu = f"{abs(r['orbit'].multipliers).max():.3g}" if r['converged'] else '-'
        if name in ROUTES and r['guess'] == 0:
            guess = f"continuation in {ROUTES[name][0]} from {ROUTES[name][1]:g}"
        print(f"| {name} | {omega:g} | {sigma:.6g} | {zeta:g} | {m} | {n:.4g} | {r['status']} | "
              f"{guess} | {fmt(r['err'])} | {fmt(r['self_map'])} | "
              f"{fmt(r['liouville'])} | {mu} | {r['events']} | {fmt(r['flight'], '.3f')} | {r['steps'] if r['steps'] >= 0 else '-'} | {r['iterations']} | "
              f"{1e3 * r['seconds']:.1f} |")


if __name__ == "__main__":
    main()
