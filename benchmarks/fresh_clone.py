"""The README's main command as a new user meets it: a fresh clone, empty caches, one run of
``scripts/run-default.sh``, its steps timed apart; optionally against another revision, pair by
pair (A B, then B A, ...), in one session.

    .venv/bin/python benchmarks/fresh_clone.py                      (HEAD, 3 runs, ~3 min)
    .venv/bin/python benchmarks/fresh_clone.py --vs 454008b --pairs 3

Each run clones the repository at the revision into a new temporary folder and points
XDG_CACHE_HOME at a new empty folder (uv's, pip's and hertzmap's numba caches all live under
it), then runs the three commands of its scripts/run-default.sh one after the other, timing each: the
install (scripts/install.sh), ``hertzmap run scenes/default.toml`` (its setup, grid and
curves as it prints them: benchmarks.run_summary) and ``hertzmap plot``. The whole is their
sum (the script itself adds nothing but bash's start). The machine's load average is printed
with every run: this VM's speed moves with its neighbours.
"""
from __future__ import annotations

import argparse
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

from benchmarks.machine import load_average  # noqa: E402
from benchmarks.run_summary import run_summary  # noqa: E402

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


def one_run(rev: str) -> dict:
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


def show(label: str, r: dict) -> None:
    print(f"  {label}: {r['whole']:5.1f} s = install {r['install']:4.1f} + run {r['run']:4.1f} "
          f"(setup {r['setup']:4.1f}, grid {r['wall']:4.1f}, curves {r['curves'] or 0:3.1f}) "
          f"+ plot {r['plot']:3.1f}; load average before {r['load']}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rev", default="HEAD", help="the revision measured (A)")
    ap.add_argument("--vs", default=None, metavar="REV", help="a revision to compare with (B)")
    ap.add_argument("--pairs", type=int, default=3, help="runs (or A/B pairs with --vs)")
    a = ap.parse_args(argv)
    revs = {"A": subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", a.rev],
                                capture_output=True, text=True, check=True).stdout.strip()}
    if a.vs:
        revs["B"] = a.vs
    print("the README command on a fresh clone, empty caches: "
          + ", ".join(f"{k} = {v}" for k, v in revs.items()))
    wholes = {k: [] for k in revs}
    ratios = []
    for k in range(a.pairs):
        order = list(revs) if k % 2 == 0 else list(revs)[::-1]
        got = {}
        for name in order:
            got[name] = one_run(revs[name])
            wholes[name].append(got[name]["whole"])
            show(name, got[name])
        if a.vs:
            ratios.append(got["B"]["whole"] / got["A"]["whole"])
            print(f"pair {k + 1}: B / A = {ratios[-1]:.2f}x")
    for name, w in wholes.items():
        print(f"{name} ({revs[name]}): median {statistics.median(w):.1f} s, "
              f"min {min(w):.1f}, max {max(w):.1f} over {len(w)} runs")
    if ratios:
        print(f"B / A, pair by pair: median {statistics.median(ratios):.2f}x "
              f"({', '.join(f'{r:.2f}' for r in ratios)})")
    print(f"load average at the end {load_average()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
