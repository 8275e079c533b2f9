"""``run_cost.py curves``: a traced curve's cost against the grid's ways of getting the same
curve (bisection, fine grids), and the default scene with and without curves (ABBA).

    .venv/bin/python benchmarks/run_cost.py curves [--pairs 3]
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.abba import abba  # noqa: E402
from benchmarks.run_summary import run_summary  # noqa: E402


# -- curves: a traced curve against the grid's ways of getting it -----------------------------

AUTO_MS_PER_POINT = 1.0


def cmd_curves(a) -> int:
    """What a traced curve costs, against the grid's ways of getting the same curve (Hertz
    model, n = 3/2, rtol 1e-10, one process unless said), in one run:

    1. **Per traced vertex** (kernels.continuation.trace_curve, kernels warm): three curves
       across their windows -- the 1T flip curve at zeta 0.005 (orbits in contact), the
       isola's 2T fold curve at zeta 0.01 (long flights) and the 2T grazing curve at zeta 0.01
       -- ms and period maps per vertex, and the accuracy: the largest change of a vertex's
       parameter when the curve's equations are re-solved at rtol 1e-12 (the vertex held in
       the other parameter). AUTO-07p, run as a peer on this model, took about 1 ms per
       continuation point.
    2. **The same curve by bisection on grid lines** at equal accuracy (1e-8 in the free
       parameter): on each sigma line of the curve's window, bisection in omega of the sign
       change of 1 + tr M + det M of the 1T orbit (kernels.shoot at every trial, from the last
       orbit); for the 2T fold, bisection of where the 2T orbit stops existing (shooting from
       the orbit on the existing side). Time per point.
    3. **A grid fine enough for 1e-3**: the flip curve contoured (linear interpolation, as
       products.bifurcation_curves) from 1T grids of steps h in its window, its distance to
       the traced curve, and that grid's time at the measured cost per point; the 2T fold (an
       existence boundary) is known to one grid step only, so 1e-3 needs a step of 1e-3.
    4. **The default scene** (scenes/default.toml, which asks for curves) run with ``hertzmap
       run`` on 2 workers, with and without "curves" in its outputs, in ``--pairs`` ABBA
       rounds (benchmarks/abba.py): whole-command times and their ratio pair by pair (the
       median is the figure: the machine's speed drifts with other jobs), and the curve
       stage's share. ``--skip-scene``: sections 1-3; ``--scene-only``: section 4.
    """
    print(f"load average: {os.getloadavg()[0]:.2f} (2 cores)")
    if a.scene_only:
        _curves_scene(a.pairs)
        return 0
    traced = _curves_traced()
    _curves_bisection(traced)
    _curves_grid(traced)
    if not a.skip_scene:
        _curves_scene(a.pairs)
    return 0


def _flip_curve_seed(zeta, sigma=0.3):
    from hertzmap.kernels import continuation as cont
    from hertzmap.study.solve.seeds import linear_response_seed

    b = cont.continue_orbit(zeta, linear_response_seed(2.1, sigma, zeta), omega=2.1,
                            sigma=sigma, period=1, direction=-1, p_min=1.95, p_max=2.15,
                            dp_max=0.01)
    return [p for p in b.special if p.kind == "flip"][0]


def _isola_fold_seed():
    from hertzmap.study.solve.discovery import discover_line

    line = discover_line(np.linspace(1.0, 2.0, 21), 0.2, 0.01, transients=0)
    return min((d for d in line.special if d["kind"] == "fold" and d["period"] == 2),
               key=lambda d: d["omega"])


def _grazing_seed():
    from hertzmap.kernels import continuation as cont
    from hertzmap.study.solve.seeds import linear_response_seed

    z, s = 0.01, 0.5
    b1 = cont.continue_orbit(z, linear_response_seed(2.2, s, z), omega=2.2, sigma=s, period=1,
                             direction=-1, p_min=1.9, p_max=2.3, dp_max=0.01)
    flip = max((p for p in b1.special if p.kind == "flip"), key=lambda p: p.omega)
    x, w, _, tan = cont.switch_at_flip(z, flip)
    b2 = cont.continue_orbit(z, x, omega=w, sigma=s, period=2, tangent=tan, p_min=1.8,
                             p_max=2.5)
    return [p for p in b2.special if p.kind == "grazing"][0]


def _curve_accuracy(curve, kind, period, zeta, sample=12):
    """Largest change of a vertex's sigma (omega held) when re-solved at rtol 1e-12."""
    from hertzmap.kernels import continuation as cont
    from hertzmap.kernels.continuation.extended_system import CurveSystem, chord_correct

    system = CurveSystem(kind, period, ("omega", "sigma"), zeta, 1.5, "hertz", 1e-12, 10**6)
    V = curve.vertices
    worst = 0.0
    for i in np.linspace(1, len(curve) - 2, sample).astype(int):
        if int(V["flag"][i]) & cont.VERTEX_END:
            continue
        u = np.array([V["q0"][i], V["v0"][i], V["omega"][i], V["sigma"][i]])
        r = chord_correct(system, u, np.array([0.0, 0.0, 1.0, 0.0]), max_iter=30)
        if r is not None:
            worst = max(worst, abs(r.u[3] - u[3]))
    return worst


def _curves_traced():
    from hertzmap.kernels import continuation as cont

    print("## 1. traced curves: time per vertex (kernels warm)")
    cont.trace_curve((0.0, 0.0), 2.0, 0.5, 0.01, kind="grazing", period=2, max_points=3)
    cases = []
    f = _flip_curve_seed(0.005)
    cases.append(("1T flip, zeta 0.005 (in contact)", "flip", 1, 0.005,
                  lambda: cont.trace_curve(f.x0, f.omega, 0.3, 0.005, kind="flip", period=1,
                                           bounds={"omega": (1.9, 2.1), "sigma": (0.15, 1.0)})))
    d = _isola_fold_seed()
    cases.append(("2T fold of the isola, zeta 0.01 (long flights)", "fold", 2, 0.01,
                  lambda: cont.trace_curve((d["q0"], d["v0"]), d["omega"], 0.2, 0.01,
                                           kind="fold", period=2,
                                           bounds={"omega": (0.5, 2.5), "sigma": (0.05, 1.0)})))
    g = _grazing_seed()
    cases.append(("2T grazing, zeta 0.01", "grazing", 2, 0.01,
                  lambda: cont.trace_curve(g.x0, g.omega, 0.5, 0.01, kind="grazing", period=2,
                                           bounds={"omega": (0.5, 2.5), "sigma": (0.05, 1.0)})))
    out = {}
    print("| curve | vertices | time | ms / vertex | maps / vertex | accuracy (rtol 1e-12 vs "
          "1e-10) | vs AUTO ~1 ms / point |")
    print("|---|---|---|---|---|---|---|")
    for name, kind, period, zeta, run in cases:
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            c = run()
            times.append(time.perf_counter() - t0)
        t = min(times)
        acc = _curve_accuracy(c, kind, period, zeta)
        ms = 1e3 * t / len(c)
        print(f"| {name} | {len(c)} | {t:.3f} s | {ms:.3f} | {c.maps / len(c):.1f} | "
              f"{acc:.1e} | {AUTO_MS_PER_POINT / ms:.1f}x faster |")
        out[kind, period] = (c, ms)
    return out


def _on_curve(curve, kind, period, zeta, sigma, near_omega):
    """The traced curve's exact crossing of the sigma line near ``near_omega``: the curve's
    equations solved with sigma held, from the interpolated polyline."""
    from hertzmap.kernels.continuation.extended_system import CurveSystem, chord_correct

    V = curve.vertices
    system = CurveSystem(kind, period, ("omega", "sigma"), zeta, 1.5, "hertz", 1e-10, 10**6)
    k = np.nonzero(np.diff(np.sign(V["sigma"] - sigma)))[0]
    k = k[np.argmin(np.abs(V["omega"][k] - near_omega))]
    th = (sigma - V["sigma"][k]) / (V["sigma"][k + 1] - V["sigma"][k])
    u = np.array([V[n][k] + th * (V[n][k + 1] - V[n][k]) for n in ("q0", "v0", "omega")]
                 + [sigma])
    r = chord_correct(system, u, np.array([0.0, 0.0, 0.0, 1.0]), max_iter=30)
    return (r.u[2], r.u[:2]) if r is not None else (np.nan, u[:2])


def _distance_to_polyline(points, P):
    """Largest distance of ``points`` (k, 2) to the polyline P (n, 2)."""
    a, d = P[:-1], P[1:] - P[:-1]
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    worst = 0.0
    for p in points:
        th = np.clip(np.einsum("ij,ij->i", p - a, d) / dd, 0.0, 1.0)
        worst = max(worst, float(np.min(np.hypot(*(a + th[:, None] * d - p).T))))
    return worst


def _bisect(g, a, b, tol=1e-8, max_iter=80):
    """Bisection of a sign change of g on [a, b]; returns (root, evaluations)."""
    ga = g(a)
    gb = g(b)
    n = 2
    if not (np.isfinite(ga) and np.isfinite(gb)) or ga * gb > 0:
        return np.nan, n
    for _ in range(max_iter):
        if b - a <= tol:
            break
        m = 0.5 * (a + b)
        gm = g(m)
        n += 1
        if not np.isfinite(gm):
            return np.nan, n
        if gm * ga > 0:
            a, ga = m, gm
        else:
            b = m
    return 0.5 * (a + b), n


def _curves_bisection(traced):
    from hertzmap.kernels import continuation as cont
    from hertzmap.kernels import shoot
    from hertzmap.study.solve.seeds import linear_response_seed

    print("\n## 2. the same curves by bisection on grid lines (to 1e-8 in omega)")
    c, ms_traced = traced["flip", 1]
    V = c.vertices
    z = 0.005
    right = V["omega"] > 2.0
    sig = np.linspace(0.2, 1.0, 9)
    worst, evals, found = 0.0, 0, 0
    exact = {}
    for s in sig:
        wt = np.interp(s, V["sigma"][right][np.argsort(V["sigma"][right])],
                       V["omega"][right][np.argsort(V["sigma"][right])])
        exact[s] = _on_curve(c, "flip", 1, z, s, wt)[0]
    t0 = time.perf_counter()
    for s in sig:
        wt = exact[s]
        state = {"x": linear_response_seed(wt, s, z)}

        def g(w):
            o = shoot(w, s, z, 1, state["x"], harmonics=False)
            if not o.converged:
                return np.nan
            state["x"] = o.x0
            return cont.flip_function(o.monodromy)
        w, n = _bisect(g, wt - 0.01, wt + 0.01)
        evals += n
        if np.isfinite(w):
            found += 1
            worst = max(worst, abs(w - wt))
    t = time.perf_counter() - t0
    per = 1e3 * t / max(found, 1)
    print(f"1T flip, zeta 0.005: {found} lines, {per:.2f} ms per point ({evals / len(sig):.0f} "
          f"shoots each); traced {ms_traced:.3f} ms per vertex: bisection {per / ms_traced:.0f}x "
          f"slower per point; |omega_bisection - omega of the traced curve| <= {worst:.1e}")
    # the 2T fold: bisection of the existence boundary on sigma lines
    c, ms_traced = traced["fold", 2]
    V = c.vertices
    lines = [0.2, 0.25, 0.3]
    exact = {s: _on_curve(c, "fold", 2, 0.01, s, 1.1) for s in lines}
    t0 = time.perf_counter()
    found, evals, worst = 0, 0, 0.0
    for s in lines:
        wt, xt = exact[s]
        # the 2T orbit exists for omega above the fold (this side of the isola)
        state = {"x": xt}

        def exists(w):
            o = shoot(w, s, 0.01, 2, state["x"], harmonics=False, max_iter=20)
            ok = o.converged and o.minimal_period == 2
            if ok:
                state["x"] = o.x0
            return 1.0 if ok else -1.0
        lo, hi = wt - 5e-3, wt + 5e-3
        if exists(hi) < 0 or exists(lo) > 0:
            continue
        state["x"] = xt
        a, b, n = lo, hi, 2
        while b - a > 1e-8 and n < 80:
            m = 0.5 * (a + b)
            n += 1
            if exists(m) > 0:
                b = m
            else:
                a = m
        evals += n
        found += 1
        worst = max(worst, abs(0.5 * (a + b) - wt))
    t = time.perf_counter() - t0
    per = 1e3 * t / max(found, 1)
    print(f"2T fold (isola), zeta 0.01: {found} lines, {per:.2f} ms per point "
          f"({evals / max(found, 1):.0f} shoots each; the orbit's existence, bisected: Newton "
          f"slows down at a fold, so its 1e-8 is in omega of existence, not of the fold); traced "
          f"{ms_traced:.3f} ms per vertex: {per / ms_traced:.0f}x; |difference| <= {worst:.1e}")


def _curves_grid(traced):
    from hertzmap.kernels import shoot_batch
    from hertzmap.study.products.bifurcation_curves import contour_lines
    from hertzmap.study.solve.seeds import linear_response_seed

    print("\n## 3. a grid fine enough for the curve to 1e-3")
    c, _ = traced["flip", 1]
    V = c.vertices
    z = 0.005
    lo_w, hi_w, lo_s, hi_s = 1.96, 2.04, 0.2, 0.6
    ref_w, ref_s = V["omega"], V["sigma"]
    print("| grid step (omega = sigma) | points | 1T solve time | max distance of the contour to "
          "the traced curve |")
    print("|---|---|---|---|")
    per_point = None
    for h in (0.02, 0.01, 0.005, 0.0025):
        om = np.arange(lo_w, hi_w + 1e-12, h)
        sg = np.arange(lo_s, hi_s + 1e-12, h)
        W, S = np.meshgrid(om, sg, indexing="ij")
        guess = np.array([linear_response_seed(w, s, z) for w, s in zip(W.ravel(), S.ravel())])
        t0 = time.perf_counter()
        r = shoot_batch(W.ravel(), S.ravel(), z, 1, guess[:, 0], guess[:, 1], harmonics=False)
        t = time.perf_counter() - t0
        per_point = t / W.size
        mu1 = r["multiplier1_re"] + 1j * r["multiplier1_im"]
        mu2 = r["multiplier2_re"] + 1j * r["multiplier2_im"]
        g = np.real((1 + mu1) * (1 + mu2)).reshape(W.shape)
        g[r["status"].reshape(W.shape) != 0] = np.nan
        P = np.column_stack([ref_w, ref_s])
        worst = max((_distance_to_polyline(line, P) for line in contour_lines(om, sg, g, 0.0)),
                    default=np.nan)
        print(f"| {h:g} | {W.size} | {t:.2f} s | {worst:.1e} |")
    # error ~ C h^2 (linear interpolation of a smooth field): the step for 1e-3
    print(f"(measured {1e3 * per_point:.3f} ms per 1T point; a contour's error falls like h^2)")
    print("2T fold (existence boundary, products.curves boundary_2T / isola): one grid step; "
          "1e-3 needs step 1e-3: the default window (omega 0.5..2.5 x sigma 0.05..1) would be "
          f"{2001 * 951:,} points, {2001 * 951 * 0.772e-3 / 2 / 60:.0f} min on 2 workers at "
          "0.772 ms per 1T + 2T point (scheduler/stages/plan.py), against one traced curve.")


def _curves_scene(pairs=3):
    print("\n### 4. the default scene with and without curves (hertzmap run, 2 workers, ABBA)")
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    text = (ROOT / "scenes" / "default.toml").read_text()
    outputs = re.search(r"^outputs = \[(.*)\]", text, re.M)
    assert outputs and '"curves"' in outputs.group(1), "scenes/default.toml asks for no curves"
    plain = ", ".join(o for o in re.findall(r'"\w+"', outputs.group(1)) if o != '"curves"')
    texts = {"plain": text[:outputs.start(1)] + plain + text[outputs.end(1):], "curves": text}
    with tempfile.TemporaryDirectory() as d:
        def variant(label):
            def run(k):
                study, store = Path(d) / f"{label}{k}.toml", Path(d) / f"{label}{k}.zarr"
                study.write_text(texts[label])
                t0 = time.perf_counter()
                r = subprocess.run([sys.executable, "-m", "hertzmap.scheduler.doors.cli", "run",
                                    str(study), "--store", str(store), "--workers", "2"],
                                   capture_output=True, text=True, cwd=ROOT)
                total = time.perf_counter() - t0
                shutil.rmtree(store, ignore_errors=True)
                if r.returncode != 0:
                    raise RuntimeError(r.stdout + r.stderr)
                summary = run_summary(r.stdout)
                line = [ln for ln in r.stdout.splitlines() if ln.startswith("curves:")]
                print(f"  pair {k + 1} {label}: whole command {total:.1f} s, grid "
                      f"{summary['wall']:.1f} s wall"
                      + (f", curve stage {summary['curves']:.2f} s"
                         if summary["curves"] is not None else ""), flush=True)
                if line:
                    print("    " + line[0])
                return {"whole": total, "curve stage": summary["curves"] or 0.0}
            return run
        res = abba({"plain": variant("plain"), "curves": variant("curves")}, pairs)
    stage = [c / p for c, p in zip(res.of("curves", "curve stage"), res.of("plain", "whole"))]
    print(res.report("curves", "plain", "whole", "with curves / without (whole command)")
          + f"; the curve stage alone: median {100 * np.median(stage):.0f} % of the run without "
          "curves; issue 19 asks <= 1.5")
