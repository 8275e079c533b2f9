"""What a cold compile of a study's kernels costs, kernel by kernel, in one process.

    .venv/bin/python benchmarks/compile_cost.py            (about 1 min on 2 cores)
    .venv/bin/python benchmarks/compile_cost.py --rounds 3

Each round, a new process with an empty numba cache and no helper processes compiles, one after
the other, what the default study's workers compile (kernels._jit.compile_shared, then
scheduler.worker.warm_up_kernels with the census and the curves): the CPU of each kernel (its
callees compiled inside it included) and in all, medians over the rounds. The machine's load
average is printed before and after.
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
from hertzmap import kernels
from hertzmap.kernels._jit import compile_kernels, compile_shared, kernel_name
from hertzmap.scheduler.worker import warm_up_kernels
cpu = {}
t0 = time.process_time()
compile_shared(0, 1, backward=False)
cpu["shared stages (leaves, the integrator's small kernels)"] = time.process_time() - t0
for d in warm_up_kernels({"attractors": "auto"}, curves=True):
    t = time.process_time()
    compile_kernels([d])
    cpu[kernel_name(d)] = time.process_time() - t
cpu["all"] = time.process_time() - t0
print(json.dumps(cpu))
"""


def compile_once() -> dict[str, float]:
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, HERTZMAP_COMPILE_HELPERS="0")
        out = subprocess.run([sys.executable, "-c", CHILD], env=env, cwd=ROOT,
                             capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=1)
    args = parser.parse_args(argv)
    print(f"cores {os.cpu_count()}; {load_line()}")
    runs = [compile_once() for _ in range(args.rounds)]
    print(f"{'CPU s (median of ' + str(args.rounds) + ')':62s} {'compile':>8s}")
    for name in runs[0]:
        print(f"{name:62s} {statistics.median(run[name] for run in runs):8.2f}")
    print(f"the default study's kernels compiled serially: "
          f"{statistics.median(r['all'] for r in runs):.1f} s of CPU; {load_line()}")


if __name__ == "__main__":
    main()
