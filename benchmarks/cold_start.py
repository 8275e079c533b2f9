"""Cold start, in one run: what a new user waits for before the first orbit and the first map.

    .venv/bin/python benchmarks/cold_start.py               (about 2-4 min on 2 cores)
    .venv/bin/python benchmarks/cold_start.py --rounds 3    (more rounds of the first orbit)
    .venv/bin/python benchmarks/cold_start.py --no-study    (the first orbit only)

1. The first orbit in a new process (``import kernels; kernels.shoot(...)``, the 1T orbit in
   contact of bench_kernels.py), with an empty numba cache (a new temporary NUMBA_CACHE_DIR)
   and then with that cache warm, alternately, ``--rounds`` times: wall from the process's
   start to its end, as a command's user waits, and to the orbit (the import included; the
   rest is the interpreter's exit, which frees numba's compiled modules), and this process's
   CPU (its helper processes, kernels._jit, run on the other core and are not counted in it). The ratio
   cold / warm is taken round by round.
2. The default study (scenes/default.toml) on 2 workers into a temporary store, with an empty
   numba cache and then warm: "setup" (cluster start and every worker's warm-up, which
   compiles the kernels) and the compute wall, as ``hertzmap run`` prints them; ratio cold /
   warm of the setup.

The machine's load average is printed before and after: on a shared machine the walls move
with it, the ratios less.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.machine import load_line  # noqa: E402
from benchmarks.run_summary import run_summary  # noqa: E402

FIRST_ORBIT = ("import time, os; import hertzmap.kernels as kernels; "
         "o = kernels.shoot(1.5, 0.2, 0.01, 1, guess=(-0.16, 0.006)); "
         "assert o.status == 0, o; "
         "print(time.time(), time.process_time())")


def first_orbit(cache: str) -> tuple[float, float, float]:
    """(wall from the process's start to its end, from its start to the orbit, CPU of the
    process up to the orbit) for one orbit. The difference of the first two is the
    interpreter's exit (freeing numba's compiled modules: about 0.5 s after a cold compile)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    t0 = time.time()
    out = subprocess.run([sys.executable, "-c", FIRST_ORBIT], env=env, cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout
    wall = time.time() - t0
    at_orbit, cpu = map(float, out.split())
    return wall, at_orbit - t0, cpu


def study(cache: str, store: str) -> dict[str, float]:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    cmd = [str(ROOT / ".venv" / "bin" / "hertzmap"), "run", str(ROOT / "scenes" / "default.toml"),
           "--workers", "2", "--store", store, "--overwrite", "--error-sample", "0"]
    t0 = time.perf_counter()
    res = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True)
    whole = time.perf_counter() - t0
    if res.returncode:
        raise RuntimeError(res.stdout + res.stderr)
    summary = run_summary(res.stdout + res.stderr)
    return {"setup": summary["setup"], "wall": summary["wall"], "compute": summary["compute"],
            "whole": whole}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=2, help="cold/warm pairs of the first orbit")
    ap.add_argument("--no-study", action="store_true", help="skip the default study")
    a = ap.parse_args(argv)
    print(f"cores {os.cpu_count()}; {load_line()}; helpers: "
          f"{os.environ.get('HERTZMAP_COMPILE_HELPERS', 'default')}", flush=True)

    rows = []
    for r in range(a.rounds):      # --rounds 0: the study only
        with tempfile.TemporaryDirectory(prefix="hertzmap-cold-") as cache:
            cold = first_orbit(cache)
            warm = first_orbit(cache)
        rows.append((cold, warm))
        print(f"first orbit, round {r + 1}: empty cache {cold[0]:.2f} s wall (the orbit after "
              f"{cold[1]:.2f} s; {cold[2]:.2f} s CPU), "
              f"warm cache {warm[0]:.2f} s wall ({warm[2]:.2f} s CPU); cold / warm "
              f"{cold[0] / warm[0]:.1f}x wall", flush=True)
    med = statistics.median
    if rows:
        print(f"first orbit in a new process, median of {a.rounds}: empty numba cache "
              f"{med(c[0] for c, _ in rows):.2f} s wall (the orbit after "
              f"{med(c[1] for c, _ in rows):.2f} s), {med(c[2] for c, _ in rows):.2f} s CPU; "
              f"warm disk cache {med(w[0] for _, w in rows):.2f} s wall, "
              f"{med(w[2] for _, w in rows):.2f} s CPU; cold / warm "
              f"{med(c[0] / w[0] for c, w in rows):.1f}x (pair by pair); {load_line()}", flush=True)

    if not a.no_study:
        with tempfile.TemporaryDirectory(prefix="hertzmap-cold-") as tmp:
            cache = os.path.join(tmp, "numba")
            cold = study(cache, os.path.join(tmp, "cold.zarr"))
            warm = study(cache, os.path.join(tmp, "warm.zarr"))
        for name, s in (("empty cache", cold), ("warm cache", warm)):
            print(f"default study, 2 workers, {name}: setup {s['setup']:.1f} s, compute "
                  f"{s['wall']:.1f} s wall ({s['compute']:.1f} s of task time), whole command "
                  f"{s['whole']:.1f} s", flush=True)
        print(f"default study: setup cold / warm {cold['setup'] / warm['setup']:.1f}x, whole "
              f"command cold / warm {cold['whole'] / warm['whole']:.1f}x; {load_line()}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
