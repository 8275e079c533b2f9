"""The stiff and extreme cases of the kernels: the case table, the routine that solves, checks
and measures one case (tests/kernels/test_extremes.py asserts on the rows), and, run as a
script, the rows as the markdown table of RELIABILITY.md.

    .venv/bin/python benchmarks/extreme_cases.py        (about 10-20 s with a warm numba cache)

For each case: shoot at rtol 1e-10 from up to four guesses (linear response first), stop at the
first converged orbit (the cases of ROUTES, which no guess reaches, first from the point where
a continuation in sigma or omega arrives). A converged orbit is measured by (1) the residual of
its start point mapped by kernels.simulate at rtol 1e-12 (the state-only integration path, no
variational equations, no Newton), (2) its Liouville error (det M against exp(-2 zeta P)),
(3) its distance to a reference re-solved at rtol 1e-13 from it.

The table, per case: the status at rtol 1e-10 (first of up to four guesses that converges;
"guess" is its index, 0 = linear response; the cases of ROUTES start from the point of a
continuation in sigma or omega instead, not timed here), the start-point error against a
re-solve at rtol 1e-13, the residual of the state-only integration (|simulate(x0, P) - x0|),
the Liouville error, the largest Floquet multiplier modulus (> 1: unstable), contact switches
per orbit, flight fraction, integrator steps of one period map (on the orbit), Newton
iterations of the successful (or last) solve, and the time of all guesses.
"""
from __future__ import annotations

from math import exp, pi
import time

import numpy as np

from hertzmap.kernels import shoot, simulate


RTOL = 1e-10
REF_RTOL = 1e-13

# (id, omega, sigma, zeta, period, exponent)
CASES = [
    ("zeta 1e-4, 1T", 1.5, 0.2, 1e-4, 1, 1.5),
    ("zeta 1e-4, 2T contact loss", 1.9, 0.5, 1e-4, 2, 1.5),
    ("zeta 0 (undamped), 2T", 2.0, 0.5, 0.0, 2, 1.5),
    ("zeta 1, sigma 3", 1.0, 3.0, 1.0, 1, 1.5),
    ("zeta 10 (overdamped)", 1.0, 0.5, 10.0, 1, 1.5),
    ("zeta 10, omega 0.05, sigma 5", 0.05, 5.0, 10.0, 1, 1.5),
    ("omega 0.05", 0.05, 0.5, 0.01, 1, 1.5),
    ("omega 0.05, sigma 3", 0.05, 3.0, 0.01, 1, 1.5),
    ("omega 10", 10.0, 0.5, 0.01, 1, 1.5),
    ("omega 10, sigma 10", 10.0, 10.0, 0.01, 1, 1.5),
    ("sigma 10, omega 1", 1.0, 10.0, 0.01, 1, 1.5),
    ("sigma 10, omega 0.3", 0.3, 10.0, 0.01, 1, 1.5),
    ("sigma 9, omega 3, 2T", 3.0, 9.0, 0.001, 2, 1.5),
    ("omega 0.2, sigma 3 (93 % flight)", 0.2, 3.0, 0.01, 1, 1.5),
    ("many switches: omega 0.05, sigma 1.6", 0.05, 1.6, 0.05, 1, 1.5),
    ("many switches: omega 0.1, sigma 1.1", 0.1, 1.1, 0.01, 1, 1.5),
    ("n = 1, impacts", 0.5, 0.8, 0.05, 1, 1.0),
    ("n = 1, 2T", 1.9, 0.5, 0.01, 2, 1.0),
    ("n = 10/9, long flights", 0.8, 2.0, 0.01, 1, 10 / 9),
    ("n = 10/9, 2T", 1.9, 0.5, 0.01, 2, 10 / 9),
    ("grazing (min q = -n + 0)", 0.6, None, 0.05, 1, 1.5),   # sigma found by bisection
]


# Cases that no guess reaches (status from all four: not_converged or singular). Their orbit is
# followed by pseudo-arclength continuation (kernels.continuation) from a parameter value where a
# guess converges, then solved at the case's parameters from the continuation's last point and
# checked like any other: (parameter, start value, continuation keywords)
ROUTES = {
    "sigma 10, omega 1": ("sigma", 0.05, dict(ds=0.05, ds_max=0.5)),
    "sigma 10, omega 0.3": ("sigma", 0.05, dict(ds=0.05, ds_max=0.5)),
    # in omega from 0.2 (a guess converges there): q0 grows to ~-3500, hence the long arclength
    "omega 0.05, sigma 3": ("omega", 0.2, dict(ds=0.05, ds_max=20.0)),
}


def continuation_guess(omega, sigma, zeta, m, n, route):
    """A start point for (omega, sigma) from continuation along ``route`` (see ROUTES): the
    branch's last point past the target value, or None if the branch does not get there."""
    from hertzmap.kernels.continuation import continue_orbit

    param, start, kw = route
    w0, s0 = (omega, start) if param == "sigma" else (start, sigma)
    for g in guesses(w0, s0, zeta):
        first = shoot(w0, s0, zeta, m, guess=g, exponent=n, rtol=RTOL, max_iter=30)
        if first.converged:
            break
    else:
        return None
    target = sigma if param == "sigma" else omega
    direction = 1.0 if target > start else -1.0
    lo, hi = min(start, target), max(start, target)
    branch = continue_orbit(zeta, first.x0, omega=w0, sigma=s0, period=m, param=param,
                            direction=direction, p_min=lo, p_max=hi, max_points=3000,
                            exponent=n, rtol=RTOL, locate=(), **kw)
    p = branch.points.get(param, np.empty(0))
    if p.size == 0 or abs(p[-1] - target) > 0.05 * abs(target):
        return None
    return (float(branch.points["q0"][-1]), float(branch.points["v0"][-1]))


def guesses(omega, sigma, zeta):
    X = sigma / (1 - omega ** 2 + 2j * zeta * omega)
    return [(X.real, (1j * omega * X).real), (0.0, 0.0), (-1.0, 2.0), (2.0, -2.0)]


def grazing_sigma(omega=0.6, zeta=0.05):
    """sigma at which the in-contact 1T orbit just reaches q = -1.5 (bisection, continuation),
    the side that dips below; and a start point there."""
    guess = (0.0, 0.0)
    for s in np.linspace(0.1, 0.9, 9):
        guess = tuple(shoot(omega, s, zeta, 1, guess=guess, rtol=1e-12).x0)
    lo, hi = 0.9, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        o = shoot(omega, mid, zeta, 1, guess=guess, rtol=1e-12)
        if o.converged and o.min_q < -1.5:
            hi = mid
        else:
            lo = mid
            if o.converged:
                guess = tuple(o.x0)
    return hi, guess


def solve_case(omega, sigma, zeta, m, n, extra_guess=None) -> dict:
    """Solve, check, and measure one case; returns a row of the table (never raises)."""
    row = {"status": "not_converged", "converged": False, "guess": None, "err": np.nan,
           "self_map": np.nan, "liouville": np.nan, "steps": -1, "iterations": 0,
           "seconds": 0.0, "max_seconds": 0.0, "flight": np.nan, "events": 0, "ref": ""}
    gs = ([extra_guess] if extra_guess is not None else []) + guesses(omega, sigma, zeta)
    for k, g in enumerate(gs):
        t0 = time.perf_counter()
        o = shoot(omega, sigma, zeta, m, guess=g, exponent=n, rtol=RTOL, max_iter=30)
        dt = time.perf_counter() - t0
        row["seconds"] += dt
        row["max_seconds"] = max(row["max_seconds"], dt)
        row["status"] = o.status_name
        row["iterations"] = o.newton_iterations
        row["orbit"] = o
        if o.converged:
            row.update(converged=True, guess=k)
            break
    if not row["converged"]:
        return row
    o = row["orbit"]
    P = m * 2 * pi / omega
    back = simulate(omega, sigma, zeta, o.x0, t_end=P, t_eval=[P], exponent=n, rtol=1e-12)
    row["self_map"] = float(np.abs(back["final"] - o.x0).max()) if back["status"] == 0 else np.inf
    M = o.monodromy
    expected = exp(-2 * zeta * P)
    scale = max(expected, abs(M[0, 0] * M[1, 1]) + abs(M[0, 1] * M[1, 0]))
    row["liouville"] = abs(np.linalg.det(M) - expected) / scale
    ref = shoot(omega, sigma, zeta, m, guess=tuple(o.x0), exponent=n, rtol=REF_RTOL, max_iter=30)
    row["ref"] = ref.status_name
    if ref.converged:
        row["err"] = float(np.abs(o.x0 - ref.x0).max())
    # steps of one period map: a solve started on the orbit does one map + the measure pass
    # (Orbit.steps of a multi-iteration solve over-counts: kernels.integrate accumulates its
    # step counters across the Newton maps and shoot_into adds the running totals)
    row["steps"] = shoot(omega, sigma, zeta, m, guess=tuple(o.x0), exponent=n, rtol=RTOL).steps // 2
    row["flight"] = o.flight_fraction
    row["events"] = int(o.loses_contact) and _events(omega, sigma, zeta, m, o.x0, n)
    row["x0"] = o.x0
    row["min_q"] = o.min_q
    return row


def _events(omega, sigma, zeta, m, x0, n):
    """Contact switches per orbit (losses + recontacts) from the kernel's batch output."""
    from hertzmap.kernels import shoot_batch
    r = shoot_batch(omega, sigma, zeta, m, x0[0], x0[1], exponent=n, rtol=RTOL)
    return int(r["events"][()]) if np.isfinite(r["events"][()]) else 0


def case_args(case):
    name, omega, sigma, zeta, m, n = case
    extra = None
    if sigma is None:
        sigma, extra = grazing_sigma(omega, zeta)
    elif name in ROUTES:
        extra = continuation_guess(omega, sigma, zeta, m, n, ROUTES[name])
    return name, omega, sigma, zeta, m, n, extra


# -- the table ----------------------------------------------------------------------------

def fmt(x, spec=".1e"):
    return "-" if x != x else format(x, spec)


def print_table():
    print(f"| case | omega | sigma | zeta | T | n | status (rtol {RTOL:g}) | guess | err vs 1e-13 | "
          "self-map | Liouville | max abs multiplier | switches | flight | steps/map | Newton it | ms |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for case in CASES:
        name, omega, sigma, zeta, m, n, extra = case_args(case)
        r = solve_case(omega, sigma, zeta, m, n, extra)
        guess = '-' if r['guess'] is None else str(r['guess'])
        mu = f"{abs(r['orbit'].multipliers).max():.3g}" if r['converged'] else '-'
        if name in ROUTES and r['guess'] == 0:
            guess = f"continuation in {ROUTES[name][0]} from {ROUTES[name][1]:g}"
        print(f"| {name} | {omega:g} | {sigma:.6g} | {zeta:g} | {m} | {n:.4g} | {r['status']} | "
              f"{guess} | {fmt(r['err'])} | {fmt(r['self_map'])} | "
              f"{fmt(r['liouville'])} | {mu} | {r['events']} | {fmt(r['flight'], '.3f')} | {r['steps'] if r['steps'] >= 0 else '-'} | {r['iterations']} | "
              f"{1e3 * r['seconds']:.1f} |")


if __name__ == "__main__":
    print_table()
