"""Where a grid block's integration steps go: every kernel call of the block solver counted by
period, Newton budget and outcome.

    .venv/bin/python benchmarks/archive/grid_steps.py          (about 10 s after the numba cache)

The block: every 4th omega and every 25th sigma of scenes/fine_map.toml (100 x 10 points,
zeta 0.01, 1T and 2T seeds, rtol 1e-10). The 1T solves have a budget of 40 Newton iterations,
the 2T ones 15 (study.block MAX_ITER_1T, MAX_ITER_2T); status 0 is converged, 1 not converged
(kernels.status). Steps are DOP853 steps, accepted and rejected, of all the Newton maps.
"""
from __future__ import annotations

import time
from collections import defaultdict

import numpy as np

import hertzmap.study.solve.block as block
from hertzmap.kernels.shooting import F


def main() -> None:
    real = block.shoot_batch_into
    acc: dict[tuple[int, int, int], list[float]] = defaultdict(lambda: [0, 0.0])

    def counted(omega, sigma, zeta, period, q, v, n, model, rtol, atol, max_iter, max_steps,
                harmonics, rows):
        real(omega, sigma, zeta, period, q, v, n, model, rtol, atol, max_iter, max_steps,
             harmonics, rows)
        for r in rows:
            a = acc[(int(period[0]), int(max_iter), int(r[F["status"]]))]
            a[0] += 1
            a[1] += r[F["steps"]]

    block.shoot_batch_into = counted
    omega = np.linspace(0.5, 2.5, 400)[::4]
    sigma = np.linspace(0.05, 1.0, 250)[::25]
    t0 = time.perf_counter()
    block.solve_block(omega, sigma, np.array([0.01]), harmonics=False)
    print(f"{omega.size * sigma.size} points in {time.perf_counter() - t0:.2f} s")
    total = sum(a[1] for a in acc.values())
    for (period, budget, status), (solves, steps) in sorted(acc.items()):
        print(f"{period}T, budget {budget:2d} iterations, status {status:2d}: {solves:5d} solves, "
              f"{steps:9.0f} steps ({100 * steps / total:4.1f} %), {steps / solves:7.1f} per solve")


if __name__ == "__main__":
    main()
