"""Task size against the client's share of the cores: one study run with two ``--task-seconds``
targets in turn (A B, then B A, ...), in one session.

    .venv/bin/python benchmarks/task_size.py                          (default study, 0.25 vs 2 s)
    .venv/bin/python benchmarks/task_size.py --study scenes/fine_map.toml --pairs 1

Each run is ``hertzmap run STUDY --workers 2 --task-seconds S`` into a temporary store (warm
numba cache: run the study once before). Printed per run: the tasks, the grid's wall and task
compute as the run's summary gives them (benchmarks.run_summary), and the CPU seconds of the
client process itself (scheduler and single writer: every finished chunk is written there, one
file per variable) sampled from /proc while the run lasts. Per pair: the ratio of the grid
walls, A / B. On a 2-core machine the client shares the cores with the two workers, so its CPU
is taken from theirs.
"""
from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.machine import load_line  # noqa: E402
from benchmarks.run_summary import run_summary  # noqa: E402


def one_run(study: str, task_seconds: float) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [str(ROOT / ".venv/bin/hertzmap"), "run", study, "--workers", "2",
               "--store", str(Path(tmp) / "s.zarr"), "--task-seconds", str(task_seconds),
               "--error-sample", "0"]
        with open(Path(tmp) / "out.txt", "w") as out:
            p = subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=subprocess.STDOUT)
            client = psutil.Process(p.pid)
            cpu = 0.0
            while p.poll() is None:
                try:
                    t = client.cpu_times()
                    cpu = t.user + t.system
                except psutil.Error:
                    break
                time.sleep(0.2)
        text = (Path(tmp) / "out.txt").read_text()
    if p.returncode != 0:
        raise SystemExit(f"run failed ({p.returncode}):\n{text}")
    tasks = int(re.search(r"running (\d+) tasks", text).group(1))
    return dict(run_summary(text), tasks=tasks, client=cpu)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study", default="scenes/default.toml")
    ap.add_argument("--a", type=float, default=0.25, help="task seconds of run A (one sigma line per task on the default study and the fine map, as before 2026-11-24)")
    ap.add_argument("--b", type=float, default=2.0, help="task seconds of run B (the default)")
    ap.add_argument("--pairs", type=int, default=2)
    args = ap.parse_args(argv)
    print(f"{args.study}; A: --task-seconds {args.a}, B: --task-seconds {args.b}; {load_line()}")
    ratios = []
    for k in range(args.pairs):
        order = ("A", "B") if k % 2 == 0 else ("B", "A")
        got = {}
        for name in order:
            got[name] = r = one_run(args.study, args.a if name == "A" else args.b)
            print(f"  {name}: {r['tasks']:4d} tasks, grid {r['wall']:6.2f} s wall, task compute "
                  f"{r['compute']:6.2f} s, client CPU {r['client']:5.2f} s (whole run)")
        ratios.append(got["A"]["wall"] / got["B"]["wall"])
        print(f"pair {k + 1}: grid wall A / B = {ratios[-1]:.2f}x; {load_line()}")
    print(f"median A / B over {len(ratios)} pairs: {statistics.median(ratios):.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
