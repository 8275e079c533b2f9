"""Cold start: what a new user waits for before the first orbit and the first map, in one run;
the README's main command on a fresh clone; a cold compile kernel by kernel.

    .venv/bin/python benchmarks/cold_start.py               (about 2-4 min on 2 cores)
    .venv/bin/python benchmarks/cold_start.py --rounds 3    (more rounds of the first orbit)
    .venv/bin/python benchmarks/cold_start.py --no-study    (the first orbit only)
    .venv/bin/python benchmarks/cold_start.py clone                       (HEAD, 3 runs, ~3 min each)
    .venv/bin/python benchmarks/cold_start.py clone --vs 454008b --pairs 3
    .venv/bin/python benchmarks/cold_start.py compile [--rounds 3]        (about 1 min a round)

**First orbit and first map** (the default):

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

**clone**: the README's main command as a new user meets it: a fresh clone, empty caches, one
run of ``scripts/run-default.sh``, its steps timed apart; optionally against another revision
(``--vs``), in ABBA rounds of benchmarks/abba.py (A B, then B A, ...), B / A pair by pair. Each
run clones the repository at the revision into a new temporary folder and points
XDG_CACHE_HOME at a new empty folder (uv's, pip's and hertzmap's numba caches all live under
it), then runs the three commands of its scripts/run-default.sh one after the other, timing
each: the install (scripts/install.sh), ``hertzmap run scenes/default.toml`` (its setup, grid
and curves as it prints them: benchmarks.run_summary.run_summary) and ``hertzmap plot``. The whole
is their sum (the script itself adds nothing but bash's start).

**compile**: each round, a new process with an empty numba cache and no helper processes
compiles, one after the other, what the default study's workers compile
(kernels._jit.compile_shared, then scheduler.stages.worker.warm_up_kernels with the census and the
curves): the CPU of each kernel (its callees compiled inside it included) and in all, medians
over the rounds.

The machine's load average is printed before and after (and with every clone run): on a
shared machine the walls move with it, the ratios less.
"""
from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.abba import abba, load_average, load_line  # noqa: E402
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



# -- clone: the README command on a fresh clone -----------------------------------------

def steps(clone: Path) -> list[tuple[str, list[str]]]:
    """The commands of the clone's own scripts/run-default.sh (without its "$@"), named by what
    they do: install, run, plot."""
    out = []
    for line in (clone / "scripts" / "run-default.sh").read_text().splitlines():
        cmd = [w for w in shlex.split(line, comments=True) if w != "$@"]
        if not cmd or cmd[0] in ("set", "cd"):
            continue
        name = "install" if cmd[-1].endswith("install.sh") else cmd[1]
        out.append((name, cmd))
    return out


def clone_run(rev: str) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        clone, cache = Path(tmp) / "clone", Path(tmp) / "cache"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
        subprocess.run(["git", "-C", str(clone), "checkout", "-q", rev], check=True)
        env = dict(os.environ, XDG_CACHE_HOME=str(cache))
        env.pop("NUMBA_CACHE_DIR", None)
        got = {"load": load_average()}
        for name, cmd in steps(clone):
            t0 = time.perf_counter()
            p = subprocess.run(cmd, cwd=clone, env=env, capture_output=True, text=True)
            got[name] = time.perf_counter() - t0
            if p.returncode != 0:
                raise SystemExit(f"{rev}: {' '.join(cmd)} failed ({p.returncode}):\n"
                                 f"{p.stdout[-2000:]}{p.stderr[-2000:]}")
            if name == "run":
                got.update(run_summary(p.stdout + p.stderr))
        got["whole"] = got["install"] + got["run"] + got["plot"]
        return got


def show_clone(label: str, r: dict) -> None:
    print(f"  {label}: {r['whole']:5.1f} s = install {r['install']:4.1f} + run {r['run']:4.1f} "
          f"(setup {r['setup']:4.1f}, grid {r['wall']:4.1f}, curves {r['curves'] or 0:3.1f}) "
          f"+ plot {r['plot']:3.1f}; load average before {r['load']}")


def clone(a) -> int:
    revs = {"A": subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", a.rev],
                                capture_output=True, text=True, check=True).stdout.strip()}
    if a.vs:
        revs["B"] = a.vs
    print("the README command on a fresh clone, empty caches: "
          + ", ".join(f"{k} = {v}" for k, v in revs.items()))
    res = abba({name: (lambda k, rev=rev: clone_run(rev)) for name, rev in revs.items()},
               a.pairs, each=lambda run: show_clone(run.name, run.value))
    for name in revs:
        w = res.of(name, "whole")
        print(f"{name} ({revs[name]}): median {statistics.median(w):.1f} s, "
              f"min {min(w):.1f}, max {max(w):.1f} over {len(w)} runs")
    if a.vs:
        print(res.report("B", "A", "whole", "B / A (whole command)"))
    print(f"load average at the end {load_average()}")
    return 0


# -- compile: kernel by kernel ----------------------------------------------------------------

CHILD = """
import json, time
from hertzmap import kernels
from hertzmap.kernels._jit import compile_kernels, compile_shared, kernel_name
from hertzmap.scheduler.stages.worker import warm_up_kernels
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


# -- the first orbit and the default study ---------------------------------------------------

def start(a) -> int:
    a.rounds = 2 if a.rounds is None else a.rounds
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


def compile_cost(a) -> int:
    rounds = 1 if a.rounds is None else a.rounds
    print(f"cores {os.cpu_count()}; {load_line()}")
    runs = [compile_once() for _ in range(rounds)]
    print(f"{'CPU s (median of ' + str(rounds) + ')':62s} {'compile':>8s}")
    for name in runs[0]:
        print(f"{name:62s} {statistics.median(run[name] for run in runs):8.2f}")
    print(f"the default study's kernels compiled serially: "
          f"{statistics.median(r['all'] for r in runs):.1f} s of CPU; {load_line()}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", nargs="?", choices=("start", "clone", "compile"), default="start",
                    help="start (default): the first orbit and the default study; clone: the "
                         "README command on a fresh clone; compile: kernel by kernel")
    ap.add_argument("--rounds", type=int, default=None,
                    help="start: cold/warm pairs of the first orbit (2); compile: rounds (1)")
    ap.add_argument("--no-study", action="store_true", help="start: skip the default study")
    ap.add_argument("--rev", default="HEAD", help="clone: the revision measured (A)")
    ap.add_argument("--vs", default=None, metavar="REV", help="clone: a revision to compare with (B)")
    ap.add_argument("--pairs", type=int, default=3, help="clone: runs (or ABBA rounds with --vs)")
    a = ap.parse_args(argv)
    return {"start": start, "clone": clone, "compile": compile_cost}[a.what](a)


if __name__ == "__main__":
    sys.exit(main())
