"""What one omega line holds: every periodic response found by discovery (transients,
continuation, branch switching) per class, and the located fold, flip and grazing points.

    .venv/bin/python benchmarks/archive/discover_line.py --sigma 0.2 --zeta 0.01 --omega 1.0 2.0 41
"""
from __future__ import annotations

import argparse

import numpy as np

from hertzmap.study.orbit_rules import CLASS_NAMES
from hertzmap.study.solve.discovery import discover_line


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="benchmarks/archive/discover_line.py",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--sigma", type=float, required=True)
    ap.add_argument("--zeta", type=float, default=0.01)
    ap.add_argument("--omega", type=float, nargs=3, metavar=("START", "STOP", "NUM"),
                    default=(1.0, 2.0, 41))
    ap.add_argument("--transients", type=int, default=16)
    ap.add_argument("--rtol", type=float, default=1e-10)
    a = ap.parse_args(argv)
    omega = np.linspace(a.omega[0], a.omega[1], int(a.omega[2]))
    r = discover_line(omega, a.sigma, a.zeta, transients=a.transients, rtol=a.rtol)
    counts = r.classes()
    print(f"sigma = {a.sigma}, zeta = {a.zeta}: {len(r.branches)} branches, "
          f"{sum(len(s) for s in r.solutions)} solutions on {omega.size} points; "
          + ", ".join(f"{k} {v:.2f} s" for k, v in r.seconds.items()))
    for code, name in CLASS_NAMES.items():
        if code == 0:
            continue
        idx = np.nonzero(counts[:, code - 1])[0]
        if idx.size:
            print(f"  {name:58s} at {idx.size:3d} points, omega {omega[idx].min():.4f}"
                  f" .. {omega[idx].max():.4f}")
    for d in r.special:
        print(f"  {d['kind']:12s} {d['period']}T omega = {d['omega']:.9f} +- {d['accuracy']:.1e}"
              f"  (test function {d['value']:.1e})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
