"""Coverage of ``hertzmap fit``'s 95 % intervals (issue 49): over noise draws of one synthetic
measurement at known parameters, how often each parameter's interval holds the truth (17 to
20 of 20 is what 95 % intervals give: a binomial(20, 0.95) is below 17 with probability
1.6 %).

    PYTHONPATH=. .venv/bin/python benchmarks/identify_coverage.py --draws 20 --workers 2

The measurement is the worked example's (benchmarks/make_fit_example.py: the paper's rig,
f0 = 270.6 Hz, sigma = 0.33, zeta = 0.0055, 200 steps a direction over 200 .. 600 Hz) made
once by the scipy oracle (benchmarks/oracle_sweep.py, no code of kernels/ or study/), then
read with the fit's noise model (a = 3 %, b = 0.05 N) with seeds 1, 2, ..., draws; each draw
fitted with the worked example's rig table on one Dask cluster (scheduler.stages.fit_tasks). Prints
a line per draw and the count per parameter; ``--csv`` writes the draws.
"""
from __future__ import annotations

import argparse
import csv
import datetime
import os
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.make_fit_example import FREQUENCIES, N, NOISE, RIG_TABLE, TRUTH
from benchmarks.oracle_sweep import clean_sweeps, columns, with_noise


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--draws", type=int, default=20)
    p.add_argument("--first-seed", type=int, default=1)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--csv", type=Path, default=None, help="write each draw's result here")
    args = p.parse_args()

    from hertzmap.scheduler.cluster.clusters import ClusterSpec, close_quietly, make_client
    from hertzmap.scheduler.stages.fit_tasks import run_fit
    from hertzmap.study.identify.measurement import measurement_from_columns

    print(f"# {' '.join(['PYTHONPATH=. .venv/bin/python', *sys.argv])}")
    print(f"# {datetime.date.today()}, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f}")
    t0 = time.perf_counter()
    clean = clean_sweeps(FREQUENCIES, N=N, **TRUTH)
    print(f"# the oracle's clean sweeps: {len(clean)} steps, {time.perf_counter() - t0:.0f} s")
    client, cluster = make_client(ClusterSpec(kind="local", workers=args.workers))
    names = ("f0", "sigma", "zeta")
    covered = {n: 0 for n in names}
    out = []
    try:
        for k in range(args.draws):
            seed = args.first_seed + k
            rows = with_noise(clean, seed=seed, **NOISE)
            meas = measurement_from_columns(columns(rows), source=f"<draw {seed}>")
            t = time.perf_counter()
            ds = run_fit(meas, RIG_TABLE, client=client, report=lambda s: None, figure=False)
            wall = time.perf_counter() - t
            row = {"seed": seed, "seconds": round(wall, 1)}
            text = []
            for i, n in enumerate(ds["parameter"].values):
                lo, hi = float(ds["lower"][i]), float(ds["upper"][i])
                hit = lo <= TRUTH[n] <= hi
                covered[n] += hit
                row.update({f"{n}": float(ds["best"][i]), f"{n}_lower": lo, f"{n}_upper": hi,
                            f"{n}_covered": int(hit),
                            f"{n}_identified": int(ds["identified"][i])})
                text.append(f"{n} {float(ds['best'][i]):.6g} [{lo:.6g}, {hi:.6g}]"
                            f"{'' if hit else ' MISSES'}")
            out.append(row)
            print(f"seed {seed:3d}: " + "; ".join(text) + f"  ({wall:.0f} s, restarts "
                  f"{ds.attrs['restarts']})", flush=True)
    finally:
        close_quietly(client, cluster)
    print("coverage of the 95 % intervals over "
          f"{len(out)} draws: " + ", ".join(f"{n} {covered[n]}/{len(out)}" for n in names)
          + f"  (truth: " + ", ".join(f"{n} = {TRUTH[n]}" for n in names) + ")")
    for n in names:
        x = np.array([r[n] for r in out])
        print(f"  {n}: mean estimate {x.mean():.6g} (truth {TRUTH[n]}), sd over the draws "
              f"{x.std(ddof=1):.3g}, mean interval width "
              f"{np.mean([r[n + '_upper'] - r[n + '_lower'] for r in out]):.3g}")
    if args.csv:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        with open(args.csv, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(out[0]))
            w.writeheader()
            w.writerows(out)
        print(f"# {args.csv}")


if __name__ == "__main__":
    main()
