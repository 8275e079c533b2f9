# Answered: it found the attractor examples now pinned by tests/kernels/test_attractors.py (docs/kernels.md).
"""Find the attractor examples of tests/kernels/test_attractors.py on paper Eq. 7 (n = 1.5).

    .venv/bin/python benchmarks/archive/attractor_scan.py grid    [--zeta 0.01] [--states 4]
    .venv/bin/python benchmarks/archive/attractor_scan.py chaos   OMEGA SIGMA [--zeta 0.01]
    .venv/bin/python benchmarks/archive/attractor_scan.py flip    OMEGA_LO OMEGA_HI SIGMA [--zeta 0.01]
    .venv/bin/python benchmarks/archive/attractor_scan.py orbit   OMEGA SIGMA M [--zeta 0.01]

``grid``: kernels.attractor_batch over omega 0.3..3.5 (step 0.05) x sigma 1..3 from (0, 0)
and a few fixed initial states; prints per point the outcomes (period m of a confirmed
stable orbit, "u" unsettled with the sign of its exponent, "?" unconfirmed, "!" a failure)
and lists the stable orbits of period >= 3 and the unsettled points with a positive exponent.
``chaos``: the exponent of one point from several initial states and budgets (does it
converge, is it the same attractor, does the response ever settle).
``flip``: the 2T orbit's flip test function 1 + tr M + det M along omega (continuation by
shooting from the attractor found at OMEGA_LO), its sign change located by bisection.
``orbit``: the attractor of period M at one point, with its multipliers.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from hertzmap.kernels import attractor, attractor_batch, shoot, status
from hertzmap.kernels.shooting import F as ORBIT

STATES = np.array([(0.0, 0.0), (-1.0, 1.0), (1.0, -1.0), (2.0, 2.0), (-3.0, 0.0), (0.5, 3.0),
                   (-2.0, -2.0), (3.0, 0.5)])


def grid(args):
    omegas = np.round(np.arange(args.omega_lo, args.omega_hi + 1e-9, args.omega_step), 4)
    sigmas = np.array(args.sigmas)
    states = STATES[:args.states]
    t0 = time.perf_counter()
    periodic, chaotic = [], []
    print(f"zeta {args.zeta}, {len(states)} initial states, budget {args.transient} + "
          f"{args.record} periods")
    print("sigma\\omega " + " ".join(f"{w:>5.2f}" for w in omegas[::4]))
    for s in sigmas:
        line = []
        for w in omegas:
            b = attractor_batch(w, s, args.zeta, states, transient_periods=args.transient,
                                record_periods=args.record, lyapunov=True)
            marks = []
            for i in range(len(states)):
                code = int(b["status"][i])
                m = int(b["period"][i])
                if code == status.CONVERGED:
                    marks.append(str(m) if m < 10 else chr(ord("a") + m - 10))
                    if m >= 3:
                        o = b["orbit"][i]
                        periodic.append((w, s, m, o[ORBIT["q0"]], o[ORBIT["v0"]],
                                         b["settled_at"][i]))
                elif code == status.UNSETTLED:
                    lam, err = b["lyapunov"][i], b["lyapunov_error"][i]
                    marks.append("+" if lam - 3 * err > 0 else "u")
                    if lam - 3 * err > 0:
                        chaotic.append((w, s, lam, err, b["min_q"][i]))
                elif code == status.UNCONFIRMED:
                    marks.append("?")
                else:
                    marks.append("!")
            line.append("".join(marks))
        print(f"sigma {s:4.2f}: " + " ".join(line))
        sys.stdout.flush()
    print(f"{time.perf_counter() - t0:.1f} s")
    print("stable orbits of period >= 3 (omega, sigma, m, q0, v0, settled at):")
    seen = set()
    for w, s, m, q, v, k in periodic:
        if (w, s, m) not in seen:
            seen.add((w, s, m))
            print(f"  {w:.3f} {s:.2f} m={m} x0=({q:.9f}, {v:.9f}) after {k:.0f} periods")
    print("unsettled with lambda > 3 sigma (omega, sigma, lambda, err, min q):")
    for w, s, lam, err, mq in chaotic[:60]:
        print(f"  {w:.3f} {s:.2f} {lam:.4f} +- {err:.4f} min q {mq:.1f}")


def chaos(args):
    for budget in args.budgets:
        for x0 in STATES[:args.states]:
            t0 = time.perf_counter()
            a = attractor(args.omega, args.sigma, args.zeta, tuple(x0),
                          transient_periods=args.transient, record_periods=budget,
                          lyapunov=True)
            print(f"x0 {tuple(x0)} record {budget}: {a.status_name} m={a.period} lambda "
                  f"{a.lyapunov:.5f} +- {a.lyapunov_error:.5f} (halves {a.lyapunov_halves:.5f})"
                  f" flight {a.flight_fraction:.3f} min q {a.min_q:.1f} max q {a.max_q:.2f} "
                  f"impact {a.max_impact_velocity:.2f} peak F {a.peak_force:.2f} rms F "
                  f"{a.rms_force:.4f} quad err {a.force_quadrature_error:.1e} "
                  f"{time.perf_counter() - t0:.2f} s")
            sys.stdout.flush()


def flip_test(o):
    M = o.monodromy
    return 1.0 + np.trace(M) + np.linalg.det(M)


def flip(args):
    a = attractor(args.omega_lo, args.sigma, args.zeta, (0.0, 0.0),
                  transient_periods=args.transient, record_periods=args.record)
    if a.period != 2:
        print(f"no 2T attractor at omega {args.omega_lo}: {a.status_name} m={a.period}")
        return
    x = a.orbit.x0
    prev = None
    for w in np.linspace(args.omega_lo, args.omega_hi, args.steps):
        o = shoot(w, args.sigma, args.zeta, 2, guess=x, rtol=1e-12)
        if not o.converged:
            print(f"omega {w:.5f}: {o.status_name}")
            break
        g = flip_test(o)
        print(f"omega {w:.5f}: x0 ({o.x0[0]:.9f}, {o.x0[1]:.9f}) mu {np.round(o.multipliers, 6)}"
              f" 1+trM+detM {g:+.3e} min q {o.min_q:.3f} min period {o.minimal_period}")
        if prev is not None and np.sign(g) != np.sign(prev[1]):
            lo, hi, glo, xlo = prev[0], w, prev[1], prev[2]
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                om = shoot(mid, args.sigma, args.zeta, 2, guess=xlo, rtol=1e-12)
                gm = flip_test(om)
                if np.sign(gm) == np.sign(glo):
                    lo, glo, xlo = mid, gm, om.x0
                else:
                    hi = mid
            print(f"flip between omega {lo:.10f} and {hi:.10f}")
            return
        prev = (w, g, o.x0)
        x = o.x0


def orbit(args):
    a = attractor(args.omega, args.sigma, args.zeta, (0.0, 0.0),
                  transient_periods=args.transient, record_periods=args.record)
    print(a.status_name, a.period, a.periods_run)
    if a.orbit is not None:
        o = a.orbit
        print(f"x0 ({o.x0[0]!r}, {o.x0[1]!r}) mu {o.multipliers} stable {o.stable} "
              f"min period {o.minimal_period} flight {o.flight_fraction:.3f} min q {o.min_q:.3f}")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=["grid", "chaos", "flip", "orbit"])
    p.add_argument("numbers", nargs="*", type=float)
    p.add_argument("--zeta", type=float, default=0.01)
    p.add_argument("--states", type=int, default=4)
    p.add_argument("--transient", type=int, default=3000)
    p.add_argument("--record", type=int, default=400)
    p.add_argument("--omega-lo", type=float, default=0.3)
    p.add_argument("--omega-hi", type=float, default=3.5)
    p.add_argument("--omega-step", type=float, default=0.05)
    p.add_argument("--sigmas", type=float, nargs="+", default=[1.0, 1.5, 2.0, 2.5, 3.0])
    p.add_argument("--budgets", type=int, nargs="+", default=[1000, 4000])
    p.add_argument("--steps", type=int, default=41)
    args = p.parse_args(argv)
    if args.what == "grid":
        grid(args)
    elif args.what == "chaos":
        args.omega, args.sigma = args.numbers
        chaos(args)
    elif args.what == "flip":
        args.omega_lo, args.omega_hi, args.sigma = args.numbers
        flip(args)
    else:
        args.omega, args.sigma, m = args.numbers
        orbit(args)


if __name__ == "__main__":
    main()
