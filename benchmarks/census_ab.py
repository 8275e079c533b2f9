"""The attractor census with one of its shortcuts against the same census without it, on the
vibro-impact scene's lines, same run: CPU, and what each names.

    .venv/bin/python -m benchmarks.census_ab                          # recognition, every 8th line
    .venv/bin/python -m benchmarks.census_ab --lines 16 --offset 4
    .venv/bin/python -m benchmarks.census_ab --compare neighbours
    .venv/bin/python -m benchmarks.census_ab --compare certified --study scenes/default.toml --lines 8

``--compare recognition``: transients stop once recognised on what the point's earlier ones
found (study.solve.recognition) / every transient runs its whole budget.
``--compare neighbours``: transients also start from the neighbouring points' attractors
(study.solve.census, "Neighbours") / from the point's own states only.
``--compare certified``: transients also stop in the certified neighbourhood of a stable orbit
the point knows (study.solve.certificate) / only on the points of what earlier ones found.
``--compare rtol``: the transients' integrator tolerance (census.TRANSIENT_RTOL and the
certificates' RTOL) 1e-6 / 1e-8.
``--compare hints``: each certificate's ladder starts at the rung nearest the last grid point's
level of the same orbit (study.solve.certificate.LevelHints) / at rung 0.
``--compare iterations``: certified neighbourhoods of the J-fold iterated orbit map
(certificate.ITERATIONS) J = 2 / J = 1; ``iterations4``: J = 4 / J = 1.

Each chosen sigma line is searched twice (sweeps and fold turning, then the census at the
points the study asks it at: study.solve.line), once per mode: one ABBA round of
benchmarks/abba.py per line, the modes' order alternating from line to line so that a drift
of the machine's speed falls on both; only the census's CPU (time.process_time of this
process) is counted, in all and line by line (the ratios' median and spread). Printed per mode: census CPU, census points,
points per kind of attractor set, points holding a stable orbit (per period, and in all),
points named (a periodic or non-periodic attractor), the transients' periods (summed over
every census kernel call: what the transients cost), attractors no own state reached (basin
fraction 0: found from a neighbour), and for the points both call chaotic how many exponents
differ by more than three combined standard errors.
"""
from __future__ import annotations

import argparse
import collections
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import hertzmap.study.solve.census as census_module  # noqa: E402
import hertzmap.study.solve.certificate as certificate_module  # noqa: E402
import hertzmap.study.solve.line as line_module  # noqa: E402
from benchmarks.abba import abba  # noqa: E402
from hertzmap.study.solve.line import LineSearch  # noqa: E402
from hertzmap.study.spec import load_study  # noqa: E402

#: per comparison: the module settings it switches, their values in the two modes, and the
#: modes' names (the first: the shortcut on; the second: as shipped)
COMPARISONS = {
    "recognition": (((census_module, "RECOGNITION"),), (True, False),
                    ("recognition", "full transients")),
    "neighbours": (((census_module, "NEIGHBOUR_STARTS"),), (True, False),
                   ("neighbour starts", "own states only")),
    "certified": (((census_module, "CERTIFIED"),), (True, False),
                  ("certified orbits", "attractors' points only")),
    "rtol": (((census_module, "TRANSIENT_RTOL"), (certificate_module, "RTOL")), (1e-6, 1e-8),
             ("rtol 1e-6", "rtol 1e-8")),
    "iterations": (((certificate_module, "ITERATIONS"),), (2, 1), ("J = 2", "J = 1")),
    "hints": (((census_module, "LEVEL_HINTS"),), (True, False),
              ("ladders from the neighbour's level", "ladders from rung 0")),
    "iterations4": (((certificate_module, "ITERATIONS"),), (4, 1), ("J = 4", "J = 1")),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study", default="scenes/vibro_impact.toml")
    ap.add_argument("--lines", type=int, default=8, help="every k-th sigma line")
    ap.add_argument("--offset", type=int, default=0, help="the first line's index")
    ap.add_argument("--compare", choices=sorted(COMPARISONS), default="recognition")
    a = ap.parse_args(argv)
    settings, values, modes = COMPARISONS[a.compare]
    value = dict(zip(modes, values))
    shipped = {setting: getattr(*setting) for setting in settings}
    s = load_study(a.study)
    kw = s.solver_kwargs()
    omega, zeta = s.axis("omega"), float(s.axis("zeta")[0])
    options = dict(exponent=s.exponent or 1.5, model=s.model, rtol=s.rtol, harmonics=False,
                   seeds=())
    census = census_module.census
    spent = collections.Counter()
    periods_run = collections.Counter()
    run_transients = census_module.run_transients

    def counted(*args, **kwargs):
        run_transients(*args, **kwargs)
        periods_run[mode_now[0]] += float(np.nansum(
            args[8][:, census_module.A["periods_run"]]))
    mode_now = [modes[0]]

    def timed(*args, **kwargs):
        t0 = time.process_time()
        out = census(*args, **kwargs)
        spent[mode_now[0]] += time.process_time() - t0
        return out

    line_module.census = timed
    census_module.run_transients = counted
    LineSearch(omega[:3], float(s.axis("sigma")[-1]), zeta, s.periods, options).sweep()
    census(1.0, 2.0, zeta, [], options, 2, 20, 32)          # compile
    kinds = {m: collections.Counter() for m in modes}
    stable = {m: collections.Counter() for m in modes}
    named = collections.Counter()
    points = collections.Counter()
    exponents = {m: {} for m in modes}
    sets = {m: {} for m in modes}          # point -> its attractors' (kind, period)
    unreached = {m: collections.Counter() for m in modes}
    sigmas = s.axis("sigma")[a.offset::a.lines]

    def variant(mode):
        def search(k):
            sigma = sigmas[k]
            mode_now[0] = mode
            before = spent[mode]
            for setting in settings:
                setattr(*setting, value[mode])
            ls = LineSearch(omega, float(sigma), zeta, s.periods, options)
            ls.sweep()
            ls.turn_folds()
            ls.run_census(s.attractors, s.initial_states, s.transient_periods,
                          s.record_periods, kw.get("max_transient_periods"),
                          kw.get("point_steps", 2_000_000), kw.get("lyapunov_error"))
            for i, found in ls.attractors.items():
                sets[mode][(i, float(sigma))] = sorted((f.kind, f.period) for f in found)
                points[mode] += 1
                kinds[mode][tuple(sorted({f.kind for f in found}))] += 1
                named[mode] += any(f.kind in ("periodic", "non_periodic") for f in found)
                for f in found:
                    if f.count == 0:
                        unreached[mode][f"{f.period}T" if f.period else f.kind] += 1
                    if f.kind == "non_periodic":
                        exponents[mode][(i, float(sigma))] = (
                            f.row[census_module.A["lyapunov"]],
                            f.row[census_module.A["lyapunov_error"]])
            for orbits in ls.per_point:
                periods = {o["period"] for o in orbits if o.get("stable") and o["status"] == 0}
                stable[mode]["any"] += bool(periods)
                for m in periods:
                    stable[mode][m] += 1
            return {"census CPU": spent[mode] - before}
        return search

    res = abba({m: variant(m) for m in modes}, len(sigmas))
    for setting, shipped_value in shipped.items():
        setattr(*setting, shipped_value)
    line_module.census = census
    census_module.run_transients = run_transients
    print(f"{len(sigmas)} sigma lines of {a.study} (every {a.lines}th from {a.offset}), "
          f"{len(omega)} omega points each")
    for mode in modes:
        per_period = ", ".join(f"{m}T {c}" for m, c in sorted(
            (k, v) for k, v in stable[mode].items() if k != "any"))
        print(f"{mode}: census {spent[mode]:.1f} s CPU at {points[mode]} points; named "
              f"{named[mode]}; transients {periods_run[mode]:,.0f} periods; with a stable orbit {stable[mode]['any']} ({per_period})")
        print("  attractors no own state reached: " + (", ".join(
            f"{k} {v}" for k, v in sorted(unreached[mode].items())) or "none"))
        print("  kinds: " + "; ".join(f"{'+'.join(k)} {v}" for k, v in
                                      sorted(kinds[mode].items(), key=lambda kv: -kv[1])))
    both = set(exponents[modes[0]]) & set(exponents[modes[1]])
    apart = sum(1 for p in both if abs(exponents[modes[0]][p][0] - exponents[modes[1]][p][0])
                > 3 * math.hypot(exponents[modes[0]][p][1], exponents[modes[1]][p][1]))
    print(f"chaotic in both: {len(both)} points, exponents more than 3 combined standard "
          f"errors apart: {apart}")
    differ = [p for p in set(sets[modes[0]]) & set(sets[modes[1]])
              if sets[modes[0]][p] != sets[modes[1]][p]]
    lost = [p for p in differ if not set(sets[modes[1]][p]) <= set(sets[modes[0]][p])]
    print(f"points whose attractors (kind, period) differ: {len(differ)}; where {modes[0]} "
          f"lacks one {modes[1]} names: {len(lost)}"
          + "".join(f"\n  omega {omega[i]:.4g} sigma {sg:.4g}: {sets[modes[0]][(i, sg)]} / "
                    f"{sets[modes[1]][(i, sg)]}" for i, sg in sorted(differ)[:8]))
    print(f"census CPU, {modes[1]} / {modes[0]}: "
          f"{spent[modes[1]] / max(spent[modes[0]], 1e-9):.2f}x")
    print(res.report(modes[1], modes[0], "census CPU", "  line by line"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
