"""Where the vibro-impact scene's time goes: shooting (the seeded sweeps and the fold tracing)
against the attractor census (its transients in the kernel, the exponent, and the shooting of
the orbits the census finds), per omega line, in one process.

    .venv/bin/python benchmarks/vibro_impact_cost.py                 # every 8th sigma line
    .venv/bin/python benchmarks/vibro_impact_cost.py --lines 2

CPU seconds (time.process_time) of this process, so that other work on the machine does not
count; the whole scene's wall time on 2 workers is printed by ``hertzmap run
scenes/vibro_impact.toml --workers 2``.
"""
from __future__ import annotations

import argparse
import time

import hertzmap.study.solve.census as census_module
from hertzmap.study.solve.line import LineSearch
from hertzmap.study.spec import load_study


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study", default="scenes/vibro_impact.toml")
    ap.add_argument("--lines", type=int, default=8, help="every k-th sigma line")
    a = ap.parse_args(argv)
    s = load_study(a.study)
    omega, zeta = s.axis("omega"), float(s.axis("zeta")[0])
    options = dict(exponent=s.exponent or 1.5, model=s.model, rtol=s.rtol, harmonics=False,
                   seeds=())
    kernel = {"seconds": 0.0, "calls": 0}
    batch, lyap = census_module.attractor_batch_into, census_module.lyapunov_into

    def timed(fn):
        def wrapper(*args):
            t0 = time.process_time()
            fn(*args)
            kernel["seconds"] += time.process_time() - t0
            kernel["calls"] += 1
        return wrapper

    census_module.attractor_batch_into = timed(batch)
    census_module.lyapunov_into = timed(lyap)
    LineSearch(omega[:3], float(s.axis("sigma")[-1]), zeta, s.periods, options).sweep()
    census_module.census(1.0, 2.0, zeta, [], options, 2, 20, 32)        # compile
    kernel.update(seconds=0.0, calls=0)
    totals = dict(sweep=0.0, tracing=0.0, census=0.0)
    points = census_points = 0
    for sigma in s.axis("sigma")[::a.lines]:
        ls = LineSearch(omega, float(sigma), zeta, s.periods, options)
        t0 = time.process_time()
        ls.sweep()
        t1 = time.process_time()
        ls.turn_folds()
        t2 = time.process_time()
        ls.run_census(s.attractors, s.initial_states, s.transient_periods, s.record_periods)
        t3 = time.process_time()
        totals["sweep"] += t1 - t0
        totals["tracing"] += t2 - t1
        totals["census"] += t3 - t2
        points += omega.size
        census_points += len(ls.attractors)
    shooting = totals["sweep"] + totals["tracing"]
    transients = kernel["seconds"]
    census_shooting = totals["census"] - transients
    all_ = shooting + totals["census"]
    print(f"{points} points ({a.lines}-th sigma lines of {s.name}), census at {census_points}")
    print(f"shooting (sweeps {totals['sweep']:.1f} s + fold tracing {totals['tracing']:.1f} s): "
          f"{shooting:.1f} s ({100 * shooting / all_:.0f} %)")
    print(f"census transients and exponents (kernel): {transients:.1f} s "
          f"({100 * transients / all_:.0f} %), {1e3 * transients / max(census_points, 1):.0f} ms "
          "per census point")
    print(f"census shooting (orbits it found: refinement, close returns, tracing): "
          f"{census_shooting:.1f} s ({100 * census_shooting / all_:.0f} %)")
    print(f"per grid point: {1e3 * all_ / points:.1f} ms; the whole scene ({s.size} points) "
          f"about {all_ / points * s.size:.0f} s of one core")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
