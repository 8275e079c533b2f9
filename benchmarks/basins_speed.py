"""The speed of dense basin maps (issue 52): ``hertzmap basins`` at 100 x 100 and 1000 x 1000
initial states, same run, ABBA rounds (benchmarks/abba.py), on an embedded cluster.

    .venv/bin/python benchmarks/basins_speed.py --omega 1.35 --sigma 0.7625 [--workers 2]
        [--rounds 2] [--method reuse]

The store is a 3 x 3 grid around the point at zeta 0.01 (the default scene's solver, no
census), made once into results/basins_bench_<w>_<s>.zarr by ``hertzmap run``: it holds the
point's stable orbits. Printed: each run's wall (the command's, start-up included) and the
map's seconds after the cluster's start and the CPU of the command with its workers (on a
shared machine the CPU moves less than the walls), then the ratios 1000 x 1000 / 100 x 100 pair
by pair
(asked: at most 8 for 100 times the states) and the 1000 x 1000 map's seconds (asked: at most
60 beyond start-up on 2 cores).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.abba import Command, abba, figure_parser, load_line  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
HERTZMAP = [sys.executable, "-m", "hertzmap.scheduler.doors.cli"]
STUDY = """
[study]
name = "basins_bench"
[grid]
omega = [{w0}, {w}, {w1}]
sigma = [{s0}, {s}, {s1}]
zeta = [0.01]
[search]
attractors = "never"
"""


def store_for(omega: float, sigma: float) -> Path:
    """The 3 x 3 store around the point (made once)."""
    store = ROOT / "results" / f"basins_bench_{omega:g}_{sigma:g}.zarr"
    if not (store / "zarr.json").exists() and not (store / ".zgroup").exists():
        toml = store.with_suffix(".toml")
        toml.parent.mkdir(exist_ok=True)
        toml.write_text(STUDY.format(w0=omega - 0.01, w=omega, w1=omega + 0.01,
                                     s0=sigma - 0.01, s=sigma, s1=sigma + 0.01))
        subprocess.run(HERTZMAP + ["run", str(toml), "--store", str(store), "--workers", "1"],
                       check=True, cwd=ROOT)
    return store


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--omega", type=float, required=True)
    p.add_argument("--sigma", type=float, required=True)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--method", default="reuse")
    a = p.parse_args(argv)
    store = store_for(a.omega, a.sigma)
    parse = figure_parser({"map": r"initial states: [\d.]+ s \(([\d.]+) s after"})

    def command(side: int) -> Command:
        return Command(HERTZMAP + ["basins", str(store), "--omega", str(a.omega), "--sigma",
                                   str(a.sigma), "--grid", f"{side}x{side}", "--workers",
                                   str(a.workers), "--method", a.method, "--out",
                                   str(ROOT / "results")], cwd=ROOT, parse=parse)
    print(load_line())
    res = abba({"100x100": command(100), "1000x1000": command(1000)}, a.rounds,
               warm_up=False, each=lambda r: print(
                   f"  {r.name} round {r.round}: wall {r.wall:.1f} s, map {r['map']:.1f} s "
                   f"after the cluster's start, CPU {r.cpu:.1f} s (the command and its "
                   f"workers)", flush=True))
    print(res.report("1000x1000", "100x100", "wall", "1000x1000 / 100x100 wall (asked <= 8)"))
    print(res.report("1000x1000", "100x100", "map", "1000x1000 / 100x100 map seconds"))
    print(res.report("1000x1000", "100x100", "cpu", "1000x1000 / 100x100 CPU"))
    print(f"1000x1000 map seconds after the cluster's start: "
          f"{', '.join(f'{x:.1f}' for x in res.of('1000x1000', 'map'))} (asked <= 60)")
    print(load_line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
