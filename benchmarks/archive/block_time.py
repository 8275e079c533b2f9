"""Time of one grid block of the fine map (scenes/fine_map.toml), the unit of work of a task.

    .venv/bin/python benchmarks/archive/block_time.py [--lines 100:103] [--rounds 4]

Solves the fine map's 400 omega points on the sigma lines given (a slice of its 250; zeta 0.01,
1T and 2T seeds, rtol 1e-10) with ``study.block.solve_block``, after a small warm-up solve, and
prints the fastest of ``rounds`` runs in seconds. To compare two kernel versions, run it
alternately in this tree and in a worktree of the other commit with its own NUMBA_CACHE_DIR:

    git worktree add /tmp/old REV
    (cd /tmp/old && PYTHONPATH=/tmp/old NUMBA_CACHE_DIR=/tmp/old-cache \\
        /path/to/.venv/bin/python benchmarks/archive/block_time.py)
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hertzmap.study.solve.block import solve_block  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", default="100:103", help="slice of the 250 sigma lines")
    ap.add_argument("--rounds", type=int, default=4)
    a = ap.parse_args(argv)
    lo, hi = (int(v) for v in a.lines.split(":"))
    omega = np.linspace(0.5, 2.5, 400)
    sigma = np.linspace(0.05, 1.0, 250)[lo:hi]
    zeta = np.array([0.01])
    solve_block(omega[:5], sigma[:1], zeta, periods=(1, 2), rtol=1e-10)
    best = np.inf
    for _ in range(a.rounds):
        t0 = time.perf_counter()
        solve_block(omega, sigma, zeta, periods=(1, 2), rtol=1e-10)
        best = min(best, time.perf_counter() - t0)
    print(f"{len(omega) * len(sigma)} points (sigma lines {lo}:{hi}): {best:.3f} s "
          f"(fastest of {a.rounds})")


if __name__ == "__main__":
    main()
