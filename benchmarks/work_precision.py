"""Work-precision benchmark (``hertzmap bench``, or ``python -m benchmarks.work_precision``): error
of periodic orbits against run time.

For each case a reference orbit is solved by hertzmap at rtol = 1e-13. Every method then starts
Newton from the same guess (reference + (1e-2, 1e-2)) and is scored by

* the error of the start point, max |x0 - x0_ref|, and of the Floquet multipliers (the two
  multipliers matched to the reference's, largest |mu - mu_ref|);
* the time per orbit (median of repeated calls where affordable).

Methods:

* ``hertzmap``: the numba entry point ``kernels.shooting.shoot_batch_into`` over a batch of
  identical solves (what the grid solver calls), per orbit, at rtol 1e-5 .. 1e-11, with start
  point, multipliers and contact measures (min/max q, flight fraction, impact velocity) but not
  the force harmonics, which no other method here computes (``harmonics=False``);
* ``paper-cd``: the paper's scheme (``kernels.central_difference.cd_shoot``: central
  differences, N steps per period, forward-difference Newton Jacobian), N = 1000 .. 30000,
  Newton stopped at the loosest tolerance that keeps its converged accuracy
  (``paper_scheme_xtol``); its multipliers are the eigenvalues of that Jacobian at the last
  iterate;
* ``paper-cd-tuned``: the same scheme, Newton and xtol coded for speed
  (``kernels.central_difference.cd_shoot_tuned``: the three maps of a Newton iteration in one
  loop, whose dependency chains then overlap in the CPU, no division on those chains, and the
  forcing by a rotation recurrence): the same iterates to ~1e-9, 5-10x less time. The care
  hertzmap's own kernels get, given to the baseline;
* ``scipy-DOP853`` / ``scipy-Radau``: ``scipy.integrate.solve_ivp`` with the contact switches as
  terminal events and restarts (``benchmarks/oracle.py``; Radau with the analytic Jacobian of the
  vector field), ``scipy.optimize.root`` (hybr) on Phi(x) - x; multipliers from central finite
  differences of the period map (4 more maps, included in the time).

Speed ratios at equal accuracy: for every point of another method, the fastest hertzmap run whose
start-point error is <= that point's error (so ratios never favour hertzmap by interpolation).
Writes ``<out>/bench.csv`` and ``<out>/bench.png`` (log-log, error vs time per orbit).
No Dask involved.
"""
from __future__ import annotations

import csv
import os
import platform
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmarks import oracle

CASES = [
    # name, omega, sigma, zeta, period, rough guess
    ("1T in contact", 1.5, 0.2, 0.01, 1, (-0.16, 0.006)),
    ("1T long flights", 0.8, 1.5, 0.01, 1, (-7.7, 0.17)),
    ("2T contact loss", 1.9, 0.5, 0.01, 2, (-0.09, 1.5)),
]
N_EXP = 1.5
REF_RTOL = 1e-13

FULL = dict(rtols=(1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11), cd_steps=(1000, 3000, 10000, 30000),
            dop853=(1e-6, 1e-8, 1e-10, 1e-12), radau=(1e-5, 1e-7, 1e-9), budget=0.5, scipy_reps=3)
QUICK = dict(rtols=(1e-5, 1e-7, 1e-9, 1e-11), cd_steps=(1000, 10000), dop853=(1e-7, 1e-10),
             radau=(1e-6,), budget=0.15, scipy_reps=1)


@dataclass
class Point:
    case: str
    method: str
    setting: str          # rtol or N
    status: str
    err_x0: float
    err_mult: float
    seconds: float        # per orbit
    steps: float = float("nan")        # per period map (hertzmap: DOP853 steps; paper: N * m)
    iterations: float = float("nan")
    floor: float = float("nan")        # hertzmap: time / ((iterations + 1) maps x steps x bare step)


# -- timing -----------------------------------------------------------------------------------

def per_call(fn, budget: float) -> float:
    """Median seconds per call over 5 rounds filling about ``budget`` seconds."""
    fn()
    t0 = time.perf_counter()
    fn()
    one = time.perf_counter() - t0
    reps = max(1, min(400, int(budget / 5 / max(one, 1e-7))))
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(reps):
            fn()
        times.append((time.perf_counter() - t0) / reps)
    return float(np.median(times))


PAPER_XTOLS = (1e-10, 1e-8, 1e-7, 1e-6, 1e-5)


def paper_scheme_xtol(omega, sigma, zeta, m, guess, exponent, x_ref, N) -> tuple[float, int]:
    """Newton stopping tolerance for the paper's scheme: the loosest of PAPER_XTOLS whose start
    point is as accurate (within 1 %) as at 1e-10. Its discretisation error dominates long
    before; a tighter xtol only adds iterations (three period maps each), which would flatter
    the comparison. Returns (xtol, Newton iterations)."""
    from hertzmap.kernels.central_difference import cd_shoot

    out = np.zeros(9)
    found = {}
    for xtol in PAPER_XTOLS:
        cd_shoot(omega, sigma, zeta, m, guess[0], guess[1], exponent, 0, N, 40, xtol, out)
        found[xtol] = (float(np.abs(out[1:3] - x_ref).max()), int(out[3]))
    best = max(x for x in found if found[x][0] <= 1.01 * found[PAPER_XTOLS[0]][0])
    return best, found[best][1]


STEP_PARAMS = (1.0, 0.3, 0.01, 1.5, 0, 1e-10)   # omega, sigma, zeta, n, model, tolerance


def step_loop(step, mode: str):
    """A compiled loop of DOP853 steps (``step`` with step_var's signature), k steps per call.

    ``mode`` is frozen into the code: a run-time flag would make h depend on the error norm
    through a select even when off. "repeated": the same step from the same state (successive
    steps overlap in the CPU: throughput); "chained": each step from the last one's result, fixed
    h (latency); "adaptive": chained, and each h computed from the last error norm by the
    integrator's rule (the next step waits for it, as in any adaptive integrator). The model's
    parameters are run-time arguments (an inlined step would fold constants into the loop).
    """
    from numba import njit

    chained = mode in ("chained", "adaptive")
    adaptive = mode == "adaptive"
    if mode not in ("repeated", "chained", "adaptive"):
        raise ValueError(f"mode must be repeated, chained or adaptive, not {mode!r}")

    @njit(cache=False)
    def run(k, omega, sigma, zeta, n_exp, model, tol):
        y = np.array([0.1, 0.2, 1.0, 0.0, 0.0, 1.0])
        f = np.array([0.2, 0.3, 0.0, 1.0, -1.0, -0.02])
        y_new = np.empty(6)
        f_new = np.empty(6)
        K = np.empty((16, 2))
        acc = 0.0
        t = 0.0
        h = 0.05
        for i in range(k):
            if chained:
                err = step(t, h, y, f, y_new, f_new, K, omega, sigma, zeta, n_exp, model, tol,
                           tol)
                acc += err
                t += h
                y[:] = y_new
                f[:] = f_new
                if adaptive:    # integrate's rule, h kept inside [0.01, 0.3]
                    fac = 0.9 / np.sqrt(np.sqrt(np.sqrt(err + 1e-300)))
                    h = min(0.3, max(0.01, h * min(10.0, max(0.2, fac))))
                if (i & 1023) == 0:     # keep the variational matrix bounded
                    y[2:] = (1.0, 0.0, 0.0, 1.0)
            else:
                acc += step(0.001 * i, 0.1, y, f, y_new, f_new, K, omega, sigma, zeta, n_exp,
                            model, tol, tol)
        return acc
    return run


def seconds_per_step(loop, n: int = 500_000, rounds: int = 3) -> float:
    """Fastest of ``rounds`` timings of a ``step_loop``, per step."""
    loop(10, *STEP_PARAMS)
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        loop(n, *STEP_PARAMS)
        best = min(best, (time.perf_counter() - t0) / n)
    return float(best)


def bare_step_seconds(n: int = 500_000, chained: bool = False, adaptive: bool = False) -> float:
    """Seconds of one bare DOP853 step with its variational equations (the arithmetic unit).

    ``chained=False``: the same step repeated from the same state: the CPU overlaps successive
    steps, so this is the step's throughput (the issue's "arithmetic floor"). ``chained=True``:
    each step starts from the last one's result, as in an integration: its latency.
    ``adaptive=True``: chained, each step's size waiting for the previous step's error norm, as
    in any adaptive integrator: the floor one can actually reach. See ``step_loop``.
    """
    from hertzmap.kernels._dop853 import step_var

    mode = "adaptive" if adaptive else ("chained" if chained else "repeated")
    return seconds_per_step(step_loop(step_var, mode), n)


def mult_error(mu, mu_ref) -> float:
    mu = np.asarray(mu, complex)
    mu_ref = np.asarray(mu_ref, complex)
    if not np.all(np.isfinite(mu)):
        return float("nan")
    a = max(abs(mu[0] - mu_ref[0]), abs(mu[1] - mu_ref[1]))
    b = max(abs(mu[0] - mu_ref[1]), abs(mu[1] - mu_ref[0]))
    return float(min(a, b))


# -- one case ---------------------------------------------------------------------------------

def run_case(name, omega, sigma, zeta, m, rough, cfg, log=print) -> list[Point]:
    from hertzmap.kernels import shoot
    from hertzmap.kernels import status as kst
    from hertzmap.kernels.central_difference import cd_shoot, cd_shoot_tuned
    from hertzmap.kernels.shooting import FIELDS, N_FIELDS, shoot_batch_into

    ref = shoot(omega, sigma, zeta, m, guess=rough, rtol=REF_RTOL, exponent=N_EXP)
    if not ref.converged:
        raise RuntimeError(f"{name}: reference did not converge ({ref.status_name})")
    guess = ref.x0 + 1e-2
    pts: list[Point] = []
    F = {f: i for i, f in enumerate(FIELDS)}

    nb = 64
    args = [np.full(nb, v) for v in (omega, sigma, zeta)] + [np.full(nb, m, np.int64)] + \
        [np.full(nb, guess[0]), np.full(nb, guess[1])]
    res = np.empty((nb, N_FIELDS))
    bare = bare_step_seconds()
    for rtol in cfg["rtols"]:
        # what every method here delivers: start point and multipliers (hertzmap adds the
        # contact measures; the force harmonics, which no other method computes, are off)
        batch = lambda: shoot_batch_into(*args, N_EXP, 0, rtol, rtol, 40, 1.0, 200_000, False, res)  # noqa: E731
        t = per_call(batch, cfg["budget"]) / nb
        r = res[0]
        mu = [complex(r[F["multiplier1_re"]], r[F["multiplier1_im"]]),
              complex(r[F["multiplier2_re"]], r[F["multiplier2_im"]])]
        # steps of one period map: a solve started on its own orbit does one map + the measure
        # pass (Orbit.steps of a multi-iteration solve over-counts: kernels.integrate's step
        # counters accumulate across the Newton maps and shoot_into adds running totals)
        spm = shoot(omega, sigma, zeta, m, guess=tuple(r[1:3]), rtol=rtol, exponent=N_EXP).steps / 2
        it = float(r[F["newton_iterations"]])
        pts.append(Point(name, "hertzmap", f"{rtol:.0e}", kst.NAMES[int(r[F["status"]])],
                         float(np.abs(r[1:3] - ref.x0).max()), mult_error(mu, ref.multipliers), t,
                         spm, it, t / ((it + 1) * spm * bare)))

    out = np.zeros(9)
    for N in cfg["cd_steps"]:
        xtol, _ = paper_scheme_xtol(omega, sigma, zeta, m, guess, N_EXP, ref.x0, N)
        for method, shoot_cd in (("paper-cd", cd_shoot), ("paper-cd-tuned", cd_shoot_tuned)):
            fn = lambda: shoot_cd(omega, sigma, zeta, m, guess[0], guess[1], N_EXP, 0, N, 40,  # noqa: E731
                                  xtol, out)
            t = per_call(fn, cfg["budget"])
            mu = np.linalg.eigvals(out[5:9].reshape(2, 2))
            pts.append(Point(name, method, str(N), kst.NAMES[int(out[0])],
                             float(np.abs(out[1:3] - ref.x0).max()),
                             mult_error(mu, ref.multipliers), t, float(N * m)))

    for method, rtols in (("DOP853", cfg["dop853"]), ("Radau", cfg["radau"])):
        oracle.period_map(guess, omega, sigma, zeta, m, n=N_EXP, method=method, rtol=1e-6,
                          atol=1e-6)                                  # warm scipy's code paths
        for rtol in rtols:
            times = []
            for _ in range(cfg["scipy_reps"]):
                t0 = time.perf_counter()
                x, mu, ok = oracle.orbit(guess, omega, sigma, zeta, m, method=method, rtol=rtol,
                                         n=N_EXP)
                times.append(time.perf_counter() - t0)
            pts.append(Point(name, f"scipy-{method}", f"{rtol:.0e}",
                             "converged" if ok else "not_converged",
                             float(np.abs(x - ref.x0).max()), mult_error(mu, ref.multipliers),
                             float(np.median(times))))
    for p in pts:
        extra = (f"  {p.steps:5.0f} steps/map, {p.iterations:.0f} it, {p.floor:.2f}x floor"
                 if p.method == "hertzmap" else "")
        log(f"  {p.method:14s} {p.setting:>6s} {p.status:13s} err x0 {p.err_x0:8.1e}  "
            f"err mu {p.err_mult:8.1e}  {p.seconds * 1e3:10.3f} ms{extra}")
    return pts


def ratios(pts: list[Point]) -> list[tuple[str, str, str, float, float, float]]:
    """(case, method, setting, its error, its time / fastest hertzmap time at <= that error)."""
    out = []
    for case in dict.fromkeys(p.case for p in pts):
        hm = [p for p in pts if p.case == case and p.method == "hertzmap" and p.status == "converged"]
        for p in pts:
            if p.case != case or p.method == "hertzmap" or not np.isfinite(p.err_x0):
                continue
            ok = [h for h in hm if h.err_x0 <= p.err_x0]
            if not ok:
                out.append((case, p.method, p.setting, p.err_x0, p.seconds, float("nan")))
                continue
            best = min(ok, key=lambda h: h.seconds)
            out.append((case, p.method, p.setting, p.err_x0, p.seconds, p.seconds / best.seconds))
    return out


def write_csv(pts: list[Point], path: Path) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["case", "method", "setting", "status", "err_x0", "err_multipliers",
                    "seconds_per_orbit", "steps_per_map", "newton_iterations", "time_over_floor"])
        for p in pts:
            w.writerow([p.case, p.method, p.setting, p.status, f"{p.err_x0:.3e}",
                        f"{p.err_mult:.3e}", f"{p.seconds:.4e}", p.steps, p.iterations,
                        f"{p.floor:.3f}"])


def plot(pts: list[Point], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(p.case for p in pts))
    fig, axes = plt.subplots(1, len(cases), figsize=(4.2 * len(cases), 3.8), sharey=True)
    axes = np.atleast_1d(axes)
    style = {"hertzmap": "o-", "paper-cd": "s-", "paper-cd-tuned": "s--", "scipy-DOP853": "^-",
             "scipy-Radau": "v-"}
    for ax, case in zip(axes, cases):
        for method, mk in style.items():
            sel = [p for p in pts if p.case == case and p.method == method]
            if not sel:
                continue
            ax.loglog([p.seconds for p in sel], [max(p.err_x0, 1e-16) for p in sel], mk,
                      label=method, ms=4)
        ax.set_title(case, fontsize=10)
        ax.set_xlabel("time per orbit [s]")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("start-point error vs rtol 1e-13")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def run_bench(out_dir: Path = Path("results"), quick: bool = False, log=print) -> dict:
    cfg = QUICK if quick else FULL
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t_all = time.perf_counter()
    log(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.2f} (timings are noisy on a shared machine)")
    pts: list[Point] = []
    for name, w, s, z, m, rough in CASES:
        log(f"{name} (omega {w}, sigma {s}, zeta {z}, {m}T)")
        pts += run_case(name, w, s, z, m, rough, cfg, log)
    suffix = "_quick" if quick else ""
    csv_path, png_path = out_dir / f"bench{suffix}.csv", out_dir / f"bench{suffix}.png"
    write_csv(pts, csv_path)
    plot(pts, png_path)
    log("")
    log("speed-up of hertzmap at equal or better start-point accuracy "
        "(other method's time / fastest hertzmap time with error <= its error):")
    rs = ratios(pts)
    summary = {}
    for case in dict.fromkeys(r[0] for r in rs):
        for method in dict.fromkeys(r[1] for r in rs):
            sel = [r for r in rs if r[0] == case and r[1] == method]
            if not sel:
                continue
            cells = "  ".join(f"{st}: {x:.0f}x" if np.isfinite(x) else f"{st}: (err {e:.0e} < hm)"
                              for _, _, st, e, _, x in sel)
            log(f"  {case:16s} {method:14s} {cells}")
    for method in dict.fromkeys(r[1] for r in rs):
        per_case = []
        for case in dict.fromkeys(r[0] for r in rs):
            xs = [r[5] for r in rs if r[0] == case and r[1] == method and np.isfinite(r[5])]
            if xs:
                per_case.append(min(xs))
        if per_case:
            summary[method] = (min(per_case), float(np.median([r[5] for r in rs if r[1] == method
                                                                 and np.isfinite(r[5])])))
            log(f"  {method:14s} worst setting per case, min over cases {summary[method][0]:.0f}x;"
                f" median over all settings {summary[method][1]:.0f}x")
    fl = [p.floor for p in pts if p.method == "hertzmap" and np.isfinite(p.floor)]
    if fl:
        log(f"  hertzmap time / arithmetic floor ((iterations + 1) maps x steps per map x bare step): "
            f"median {np.median(fl):.2f}, max {max(fl):.2f}")
    log(f"wrote {csv_path} and {png_path} ({time.perf_counter() - t_all:.0f} s)")
    return {"points": pts, "ratios": rs, "summary": summary, "csv": csv_path, "png": png_path}


def main(argv=None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m benchmarks.work_precision",
                                 description="work-precision benchmark: hertzmap vs the paper's "
                                             "scheme vs scipy")
    ap.add_argument("--out", type=Path, default=Path("results"),
                    help="folder for bench.csv and bench.png")
    ap.add_argument("--quick", action="store_true", help="fewer tolerances and repeats (< 2 min)")
    a = ap.parse_args(argv)
    run_bench(a.out, quick=a.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
