"""What a cold compile of a study's kernels costs, with the large kernels linked by symbol and
with numba's whole linking, in one run.

    .venv/bin/python benchmarks/compile_cost.py            (about 2 min on 2 cores)
    .venv/bin/python benchmarks/compile_cost.py --rounds 2

Each round, for HERTZMAP_SYMBOL_LINK=1 (the default) and =0, in that order and then the other: a
new process with an empty numba cache and no helper processes compiles, one after the other, what
the default study's workers compile (kernels._jit.compile_shared, then
scheduler.worker.warm_up_kernels with the census and the curves): the CPU of each kernel (its
callees compiled inside it included) and in all. Printed: per kernel the
medians over the rounds, the totals and the ratio whole / by symbol taken round by round. The
machine's load average is printed before and after.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.machine import load_line  # noqa: E402

CHILD = """
import json, time
import kernels
from kernels._jit import compile_kernels, compile_shared, kernel_name
from scheduler.worker import warm_up_kernels
cpu = {}
t0 = time.process_time()
compile_shared("kernels", 0, 1, backward=False)
cpu["shared stages (leaves, the integrator's small kernels)"] = time.process_time() - t0
for d in warm_up_kernels({"attractors": "auto"}, curves=True):
    t = time.process_time()
    compile_kernels([d])
    cpu[kernel_name(d)] = time.process_time() - t
cpu["all"] = time.process_time() - t0
print(json.dumps(cpu))
"""


def compile_once(symbol: bool) -> dict[str, float]:
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, HERTZMAP_COMPILE_HELPERS="0",
                   HERTZMAP_SYMBOL_LINK="1" if symbol else "0")
        out = subprocess.run([sys.executable, "-c", CHILD], env=env, cwd=ROOT,
                             capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=1)
    args = parser.parse_args(argv)
    print(f"cores {os.cpu_count()}; {load_line()}")
    runs = {True: [], False: []}
    for r in range(args.rounds):
        for symbol in ((True, False) if r % 2 == 0 else (False, True)):
            runs[symbol].append(compile_once(symbol))
    names = list(runs[True][0])
    print(f"{'CPU s (median of ' + str(args.rounds) + ')':62s} {'by symbol':>10s} {'whole':>8s}")
    for name in names:
        a = statistics.median(run[name] for run in runs[True])
        b = statistics.median(run[name] for run in runs[False])
        print(f"{name:62s} {a:10.2f} {b:8.2f}")
    ratios = [w["all"] / s["all"] for s, w in zip(runs[True], runs[False])]
    print(f"the default study's kernels compiled serially, CPU: linked by symbol "
          f"{statistics.median(r['all'] for r in runs[True]):.1f} s, whole "
          f"{statistics.median(r['all'] for r in runs[False]):.1f} s; whole / by symbol "
          f"{statistics.median(ratios):.2f}x (round by round); {load_line()}")


if __name__ == "__main__":
    main()
