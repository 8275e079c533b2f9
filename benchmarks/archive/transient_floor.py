"""Stroboscopic transients (kernels.attractors) against the integrator's adaptive step floor.

    .venv/bin/python benchmarks/archive/transient_floor.py          (about 30 s after compilation)

The floor is study.benchmark's compiled loop of bare DOP853 steps, each step size waiting for
the last error norm ("adaptive"): the cost of a step with nothing around it. It is measured for
the 2-D state step (step_state: what a transient integrates) and for the 6-D state +
variational step (step_var: Benettin's record window; bare_step_seconds(adaptive=True), the
floor benchmarks/bench_kernels.py prints). Per case, a transient of a fixed number of forcing
periods (attractor_batch_into with detection switched off: cycle_tol = 1e-300, record 1 period) and a
Benettin run (lyapunov_into) over a quarter as many, each timed as the fastest of 5 runs; time
per step = time / (accepted + rejected + partial steps). Flight is closed form and costs no
steps, so its time is charged to the steps: a long-flight case's ratio includes the flight's
own cost (and the scan for its recontact). The target (issue 21): transient time per step
<= 2x the floor. On a shared machine the numbers double under load: repeat, and keep the
quietest run.
"""
from __future__ import annotations

import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", ".."))

from hertzmap.kernels._dop853 import step_state  # noqa: E402
from hertzmap.kernels.attractors import (A, N_ATTRACTOR_FIELDS, N_LYAPUNOV_FIELDS,  # noqa: E402
                                attractor_batch_into, lyapunov_into)
from hertzmap.kernels.shooting import N_FIELDS  # noqa: E402
from benchmarks.work_precision import bare_step_seconds, seconds_per_step, step_loop  # noqa: E402

CASES = [
    # name, omega, sigma, zeta, x0, periods
    ("1T in contact", 1.5, 0.2, 0.01, (0.5, 0.0), 4000),
    ("chaotic, 90% flight", 0.5, 2.5, 0.01, (0.0, 0.0), 4000),
    ("chaotic transient, 78% flight", 1.0, 2.0, 0.01, (0.0, 0.0), 2000),
    ("chaotic, 80% flight", 0.8, 1.5, 0.01, (0.0, 0.0), 4000),
    ("2T/4T near flip, impacts", 1.905, 2.5, 0.01, (0.0, 0.0), 4000),
    ("1T with impacts, zeta 0.05", 0.5, 0.8, 0.05, (0.0, 0.0), 4000),
]
RTOL = 1e-8


def fastest(fn, rounds=5):
    fn()
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def transient(w, s, z, x0, periods):
    rows = np.empty((1, N_ATTRACTOR_FIELDS))
    orbits = np.empty((1, N_FIELDS))
    strobes = np.empty((1, 1, 2))
    q0, v0 = np.array([x0[0]]), np.array([x0[1]])

    def run():
        attractor_batch_into(w, s, z, q0, v0, 1.5, 0, periods, 1, False, 0, 0, 1e-300, 7, RTOL,
                             RTOL, 1e-10, 200_000, False, rows, orbits, strobes)
    t = fastest(run)
    row = rows[0]
    return t, row[A["steps"]], row[A["events"]], row[A["status"]]


def benettin(w, s, z, x0, periods):
    out = np.empty(N_LYAPUNOV_FIELDS)

    def run():
        lyapunov_into(w, s, z, x0[0], x0[1], 1.5, 0, periods, 0, RTOL, RTOL, 200_000, out)
    t = fastest(run)
    return t, out[8], out[0]


def main():
    load0 = os.getloadavg()[0]
    floor2 = seconds_per_step(step_loop(step_state, "adaptive"))
    floor6 = bare_step_seconds(adaptive=True)
    print(f"adaptive step floor: {floor2 * 1e9:.1f} ns (2-D state), {floor6 * 1e9:.1f} ns "
          f"(6-D state + variational: bench_kernels.py's)")
    head = (f"{'case':30s} {'periods':>7s} | {'transient':>9s} {'steps/T':>7s} {'ns/step':>7s} "
            f"{'/floor2':>7s} {'/floor6':>7s} | {'Benettin':>8s} {'ns/step':>7s} {'/floor6':>7s}"
            f" | {'events/T':>8s}")
    print(head)
    print(f"{'':30s} {'':7s} | {'ms':>9s} {'':7s} {'':7s} {'':7s} {'':7s} | {'ms':>8s}")
    print("-" * len(head))
    r2s, r6s = [], []
    for name, w, s, z, x0, periods in CASES:
        t, steps, events, code = transient(w, s, z, x0, periods)
        tb, steps_b, code_b = benettin(w, s, z, x0, periods // 4)
        r2s.append(t / steps / floor2)
        r6s.append(t / steps / floor6)
        flag = "" if code == 7 and code_b == 0 else f"  status {code:.0f}/{code_b:.0f}"
        print(f"{name:30s} {periods:7d} | {t * 1e3:9.2f} {steps / periods:7.1f} "
              f"{t / steps * 1e9:7.1f} {r2s[-1]:7.2f} {r6s[-1]:7.2f} | {tb * 1e3:8.2f} "
              f"{tb / steps_b * 1e9:7.1f} {tb / steps_b / floor6:7.2f} | "
              f"{events / periods:8.2f}{flag}")
    print(f"transient time per step: median {np.median(r2s):.2f}x (max {max(r2s):.2f}x) the 2-D "
          f"floor, median {np.median(r6s):.2f}x (max {max(r6s):.2f}x) the 6-D floor; target <= 2")
    print(f"load average {load0:.2f} before, {os.getloadavg()[0]:.2f} after (2 cores: repeat "
          "when above ~1)")


if __name__ == "__main__":
    main()
