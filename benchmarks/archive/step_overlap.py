"""What a DOP853 step costs in a loop, and why: inlined or called, one chain or two, fixed or
adaptive step size.

    .venv/bin/python benchmarks/archive/step_overlap.py          (about 30 s, compiles first)

Chained steps of the state + variational system (each from the last one's result, model
parameters as run-time values), per step, fastest of 3:
* inlined: ``kernels._dop853.step_var`` as the kernels use it since stop 13 (inline='always');
* called: the same generated source compiled as a separate function (a call per step, the
  arrays passed through it), as before stop 13;
* two lanes: two independent chains interleaved in one loop (does the CPU overlap them?);
* adaptive: each step size computed from the previous step's error norm, as in the integrator
  (the next step cannot start before the last one's error is known), inlined and called.
"""
from __future__ import annotations

import re
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from hertzmap.kernels._dop853 import step_var  # noqa: E402
from benchmarks.work_precision import STEP_PARAMS, seconds_per_step, step_loop  # noqa: E402

N = 300_000     # steps per timing


def called_copy():
    """step_var's generated source compiled as an ordinary (called) function."""
    src = (ROOT / "kernels" / "_dop853.py").read_text()
    body = re.search(r"\n(def step_var\(.*?)(?=\n@njit)", src, re.S).group(1)
    head = src[src.index("from math"):src.index("\n\n\n@njit")]
    ns: dict = {}
    exec(head + "\n\n@njit(inline='never')\n" + body.replace("def step_var(", "def step_called("), ns)
    return ns["step_called"]


@njit
def two_lanes(k, y, f, y_new, f_new, K, y2, f2, y_new2, f_new2, K2, omega, sigma, zeta, n, model,
              tol):
    acc = 0.0
    t = 0.0
    for i in range(k):
        acc += step_var(t, 0.05, y, f, y_new, f_new, K, omega, sigma, zeta, n, model, tol, tol)
        acc += step_var(t + 0.01, 0.05, y2, f2, y_new2, f_new2, K2, omega, sigma, zeta, n, model,
                        tol, tol)
        t += 0.05
        y[:] = y_new
        f[:] = f_new
        y2[:] = y_new2
        f2[:] = f_new2
        if (i & 1023) == 0:
            y[2:] = (1.0, 0.0, 0.0, 1.0)
            y2[2:] = (1.0, 0.0, 0.0, 1.0)
    return acc


def arrays(q):
    return (np.array([q, 0.2, 1.0, 0.0, 0.0, 1.0]), np.array([0.2, 0.3, 0.0, 1.0, -1.0, -0.02]),
            np.empty(6), np.empty(6), np.empty((16, 2)))


def main() -> None:
    step_called = called_copy()
    t_in = seconds_per_step(step_loop(step_var, "chained"), N)
    t_call = seconds_per_step(step_loop(step_called, "chained"), N)
    t_ad = seconds_per_step(step_loop(step_var, "adaptive"), N)
    t_call_ad = seconds_per_step(step_loop(step_called, "adaptive"), N)
    lanes = [arrays(0.1), arrays(-0.1)]
    two_lanes(10, *lanes[0], *lanes[1], *STEP_PARAMS)
    t_two = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        two_lanes(N, *lanes[0], *lanes[1], *STEP_PARAMS)
        t_two = min(t_two, (time.perf_counter() - t0) / (2 * N))
    print(f"inlined, fixed h:    {t_in * 1e6:.3f} us per step")
    print(f"called, fixed h:     {t_call * 1e6:.3f} us per step ({t_call / t_in:.2f}x the inlined)")
    print(f"two lanes, inlined:  {t_two * 1e6:.3f} us per step ({t_two / t_in:.2f}x the one-lane step)")
    print(f"inlined, adaptive h: {t_ad * 1e6:.3f} us per step ({t_ad / t_in:.2f}x the fixed-h step)")
    print(f"called, adaptive h:  {t_call_ad * 1e6:.3f} us per step ({t_call_ad / t_ad:.2f}x the inlined)")


if __name__ == "__main__":
    main()
