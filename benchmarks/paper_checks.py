"""The paper's continuation results (section 3.2, Fig. 6-10) recomputed by hertzmap.

    .venv/bin/python benchmarks/paper_checks.py            # all checks, about a minute
    .venv/bin/python benchmarks/paper_checks.py --quick    # one tolerance only

Each located value is computed at integrator tolerances rtol = 1e-8, 1e-10, 1e-12; the accuracy
quoted is the spread against the 1e-12 value (and the located bracket, which is smaller).
Hertz model, n = 3/2 (paper Eq. 7).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from hertzmap.kernels import continuation as cont
from hertzmap.study.analytic import multiple_scales as ms
from hertzmap.study.solve.seeds import linear_response_seed
from hertzmap.study.solve.discovery import discover_line

RTOLS = (1e-8, 1e-10, 1e-12)


def low_fold_sigma05(rtol):
    """zeta 0.01, sigma 0.5: 2T branch from the flip near omega = 2 down to its fold."""
    z, s = 0.01, 0.5
    b1 = cont.continue_orbit(z, linear_response_seed(2.2, s, z), omega=2.2, sigma=s, period=1,
                             direction=-1, p_min=1.9, p_max=2.3, rtol=rtol, dp_max=0.01)
    flips = sorted([p for p in b1.special if p.kind == "flip"], key=lambda p: -p.omega)
    x, w, _, tan = cont.switch_at_flip(z, flips[0], rtol=rtol)
    b2 = cont.continue_orbit(z, x, omega=w, sigma=s, period=2, tangent=tan, p_min=0.3,
                             p_max=2.5, rtol=rtol, max_points=4000)
    folds = [p for p in b2.special if p.kind == "fold"]
    return {"flips": [p.omega for p in flips], "fold": min(p.omega for p in folds),
            "fold_acc": folds[0].accuracy, "status": b2.status_name, "points": len(b2),
            "end": [p.omega for p in b2.special if p.kind == "branch_point"],
            "grazing": sorted((p.omega for p in b2.special if p.kind == "grazing"), reverse=True)}


def isola_sigma02(rtol):
    """zeta 0.01, sigma 0.2: the isola from a grid line, no hand-given seed."""
    r = discover_line(np.linspace(1.0, 2.0, 21), 0.2, 0.01, rtol=rtol)
    folds = sorted(d["omega"] for d in r.special if d["kind"] == "fold" and d["period"] == 2)
    counts = r.classes().sum(axis=0)
    return {"folds": folds, "counts": counts, "seconds": r.seconds["total"], "special": r.special}


def isola_sigma02_transients_only(rtol):
    """The same line seeded by transients alone (no sweep, no MMS seeds)."""
    r = discover_line(np.linspace(1.0, 2.0, 21), 0.2, 0.01, rtol=rtol, sweep=False,
                      initial=[[] for _ in range(21)])
    folds = sorted(d["omega"] for d in r.special if d["kind"] == "fold" and d["period"] == 2)
    return {"folds": folds}


def traced_isola(rtol):
    """zeta 0.01: the isola's fold curve as the curves output traces it (trace_curve, the
    window of the fig09 scene): sigma** (its refined lowest vertex) and where it ends on the
    1T orbit (extrapolated: the isola joins the flip-born branch)."""
    iso = discover_line(np.linspace(1.0, 2.0, 21), 0.2, 0.01, rtol=rtol, transients=0)
    lo = min((d for d in iso.special if d["kind"] == "fold" and d["period"] == 2),
             key=lambda d: d["omega"])
    c = cont.trace_curve((lo["q0"], lo["v0"]), lo["omega"], 0.2, 0.01, kind="fold", period=2,
                         bounds={"omega": (1.0, 2.2), "sigma": (0.1, 0.5)}, rtol=rtol)
    V = c.vertices
    k = int(np.argmin(V["sigma"]))
    join = [p for p in c.codim2 if p.kind == "fold_flip"]
    return {"sigma_min": V["sigma"][k], "omega_at_min": V["omega"][k],
            "join": (join[0].omega, join[0].sigma, join[0].accuracy) if join else None,
            "vertices": len(c), "status": c.status_names}


def flip_curve(zeta, rtol, omega_bounds=(1.85, 2.15), sigma_max=1.2):
    """The flip curve of the 1T orbit in (omega, sigma), from a flip at sigma = 0.5, traced
    across the window (trace_curve), its vertices close enough (dp_frac) for the linear
    interpolation of its crossings of a sigma line."""
    s = 0.5
    b1 = cont.continue_orbit(zeta, linear_response_seed(2.3, s, zeta), omega=2.3, sigma=s,
                             period=1, direction=-1, p_min=1.85, p_max=2.35, rtol=rtol,
                             dp_max=0.01)
    flip = [p for p in b1.special if p.kind == "flip"][0]
    return cont.trace_curve(flip.x0, flip.omega, s, zeta, kind="flip", period=1, rtol=rtol,
                            bounds={"omega": omega_bounds, "sigma": (0.0, sigma_max)},
                            dp_frac=0.001)


def lowest_sigma(curve):
    """(sigma, omega, refined) of a traced curve's lowest vertex; refined: it is a located
    extremum (VERTEX_EXTREMUM: the extremum of sigma along the curve, not a vertex near it)."""
    V = curve.vertices
    k = int(np.argmin(V["sigma"]))
    return V["sigma"][k], V["omega"][k], bool(int(V["flag"][k]) & cont.VERTEX_EXTREMUM)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    rtols = (1e-10,) if a.quick else RTOLS
    t0 = time.perf_counter()

    print("## Fig. 6: zeta 0.01, sigma 0.5, 2T branch from the flip near omega = 2")
    res = {r: low_fold_sigma05(r) for r in rtols}
    for r, v in res.items():
        print(f"rtol {r:.0e}: flips {np.round(v['flips'], 9)}, 2T fold omega = {v['fold']:.10f}"
              f" (bracket {v['fold_acc']:.1e}), branch {v['status']} at {np.round(v['end'], 5)}"
              f" after {v['points']} points; grazing at {np.round(v['grazing'], 7)}")
    ref = res[rtols[-1]]["fold"]
    print("spread of the fold vs tightest:", max(abs(v["fold"] - ref) for v in res.values()))

    print("\n## Fig. 8: zeta 0.01, sigma 0.2, isola from the grid line 1..2 (21 points)")
    res = {r: isola_sigma02(r) for r in rtols}
    for r, v in res.items():
        print(f"rtol {r:.0e}: 2T folds {np.round(v['folds'], 10)}, class counts {v['counts']},"
              f" {v['seconds']:.2f} s")
    ref = np.array(res[rtols[-1]]["folds"])
    print("spread vs tightest:", max(np.max(np.abs(np.array(v["folds"]) - ref))
                                     for v in res.values()))
    t = isola_sigma02_transients_only(rtols[-1] if a.quick else 1e-10)
    print("transients only (no sweep, no MMS):", np.round(t["folds"], 10))

    print("\n## Fig. 9/10: zeta 0.01, fold curve of the isola's 2T orbits")
    res = {r: traced_isola(r) for r in rtols}
    for r, v in res.items():
        j = v["join"]
        print(f"traced (trace_curve, the curves output), rtol {r:.0e}: sigma** = "
              f"{v['sigma_min']:.9f} at omega {v['omega_at_min']:.7f}; joins the 1T orbit at "
              f"omega {j[0]:.8f}, sigma {j[1]:.8f} (extrapolation spread {j[2]:.0e}); "
              f"{v['vertices']} vertices, {v['status']}")
    r = discover_line(np.linspace(1.0, 2.1, 45), 0.336, 0.01, rtol=rtols[-1])
    print("sigma 0.336 line (1.0..2.1):", [(d["kind"], d["period"], round(d["omega"], 6))
                                          for d in r.special],
          "class counts", r.classes().sum(axis=0))
    c01 = flip_curve(0.01, rtols[-1] if a.quick else 1e-10)
    smin, wmin, refined = lowest_sigma(c01)
    print(f"flip curve zeta 0.01: min sigma {smin:.7f} at omega {wmin:.6f} (refined: {refined});"
          f" MMS sigma_star(min) {float(ms.sigma_star(0.01, 'min')):.7f}")

    print("\n## Fig. 7: zeta 0.005, flip curve of the 1T orbit against MMS sigma2")
    c = flip_curve(0.005, rtols[-1] if a.quick else 1e-10)
    P = c.vertices
    print(f"{len(c)} vertices, {c.status_names}, omega {P['omega'].min():.4f}.."
          f"{P['omega'].max():.4f}, sigma {P['sigma'].min():.4f}..{P['sigma'].max():.4f}")
    print("| sigma | omega (continuation) | omega (MMS sigma2, derived) | difference |")
    print("|---|---|---|---|")
    for s in (0.2, 0.3, 0.5, 0.8, 1.0):
        ws = []
        # a crossing between two vertices, once where it falls on a vertex (the seed's sigma)
        below = P["sigma"] < s
        for k in np.nonzero(below[:-1] != below[1:])[0]:
            th = (s - P["sigma"][k]) / (P["sigma"][k + 1] - P["sigma"][k])
            ws.append(P["omega"][k] + th * (P["omega"][k + 1] - P["omega"][k]))
        for w in sorted(ws):
            grid = np.linspace(w - 0.01, w + 0.01, 20001)
            d = ms.sigma2(grid, 0.005) - s
            ks = np.nonzero(np.diff(np.sign(d)))[0]
            roots = grid[ks] - d[ks] * (grid[ks + 1] - grid[ks]) / (d[ks + 1] - d[ks])
            wm = roots[np.argmin(np.abs(roots - w))] if roots.size else np.nan
            print(f"| {s} | {w:.6f} | {wm:.6f} | {w - wm:+.1e} |")
    smin, wmin, refined = lowest_sigma(c)
    print(f"min sigma of the flip curve: {smin:.7f} at omega {wmin:.6f} (refined: {refined});"
          f" MMS: {float(ms.sigma_star(0.005, 'min')):.7f}")
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
