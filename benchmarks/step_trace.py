"""Every step evaluation of one period map on an orbit: where an integration spends its steps.

    .venv/bin/python benchmarks/step_trace.py OMEGA SIGMA ZETA PERIOD RTOL [Q0 V0] [--exponent N]

The orbit is solved at rtol 1e-13 from (Q0, V0) (default: the linear response), then one period
map from it is run through the Python source of ``kernels.integrate.integrate`` (its
``py_func``: the same algorithm, the compiled steps) with a wrapper on ``_step`` that records
every step evaluation: accepted and rejected steps and the partial steps that locate a crossing.
The map is run twice and the second is printed, so that it starts with the step sizes a Newton
run carries over. Columns: mode (t: time steps, rec: w-steps after a recontact, loss: w-steps
onto a located loss of contact, hgt: steps in x = -sqrt(q + n) onto a loss of contact), the physical times the step spans, its size in its own variable, its
error norm (accepted if <= 1; a crossing's trial step shows a large one), q at its end. Slow
(Python), for reading, not timing.
"""
from __future__ import annotations

import argparse
import sys
from math import pi
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import hertzmap.kernels.integrate as integ  # noqa: E402
from hertzmap.kernels import shoot  # noqa: E402

MODE_NAMES = {integ.MODE_T: "t", integ.MODE_RECONTACT: "rec", integ.MODE_LOSS: "loss",
              integ.MODE_HEIGHT: "hgt"}


def trace_map(omega, sigma, zeta, m, rtol, x0, n=1.5):
    """[(mode, t_start, t_end, h, err, q_end)] of one period map from x0, and the stats."""
    compiled_step = integ._step
    log = []

    def recording_step(dim, mode, x, h, y, f, y_new, *rest):
        err = compiled_step(dim, mode, x, h, y, f, y_new, *rest)
        t_ref = rest[-1]
        if mode == integ.MODE_HEIGHT:       # y[0] is t - t_ref, q = x^2 - n
            log.append((MODE_NAMES[mode], t_ref + y[0], t_ref + y_new[0], h, err,
                        (x + h) ** 2 - rest[-5]))
        else:
            log.append((MODE_NAMES[mode], integ._time(mode, x, t_ref),
                        integ._time(mode, x + h, t_ref), h, err, y_new[0]))
        return err

    P = m * 2 * pi / omega
    stats = np.zeros(integ.N_STATS)
    integ._step = recording_step
    try:
        for _ in range(2):
            log.clear()
            keep = stats[integ.S_H_RECONTACT]
            h = stats[integ.S_H_FIRST] if stats[integ.S_H_FIRST] > 0 else min(0.1, P / 16)
            stats[:] = 0.0
            stats[integ.S_H_RECONTACT] = keep
            y = np.array([x0[0], x0[1], 1.0, 0.0, 0.0, 1.0])
            integ.integrate.py_func(
                y, 0.0, P, omega, sigma, zeta, n, 0, rtol, rtol, h, 200_000, True, False, False,
                P, np.zeros((2, integ.N_HARMONICS + 1)), np.empty(0), np.empty((3, 0)), stats,
                np.empty(6), np.empty(6), np.empty(6), np.empty((16, 2)), np.empty((7, 2)))
    finally:
        integ._step = compiled_step
    return log, stats


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("numbers", type=float, nargs="+",
                    help="OMEGA SIGMA ZETA PERIOD RTOL [Q0 V0]")
    ap.add_argument("--exponent", type=float, default=1.5)
    a = ap.parse_args(argv)
    if len(a.numbers) not in (5, 7):
        ap.error("give OMEGA SIGMA ZETA PERIOD RTOL, optionally Q0 V0")
    omega, sigma, zeta, m, rtol = a.numbers[:5]
    m = int(m)
    if len(a.numbers) == 7:
        guess = tuple(a.numbers[5:])
    else:
        X = sigma / (1 - omega ** 2 + 2j * zeta * omega)
        guess = (X.real, (1j * omega * X).real)
    ref = shoot(omega, sigma, zeta, m, guess=guess, rtol=1e-13, exponent=a.exponent)
    if not ref.converged:
        raise SystemExit(f"no orbit from {guess}: {ref.status_name}")
    print(f"orbit x0 = ({ref.x0[0]:.8g}, {ref.x0[1]:.8g}), flight {ref.flight_fraction:.2f}, "
          f"multipliers {np.round(ref.multipliers, 4)}")
    log, stats = trace_map(omega, sigma, zeta, m, rtol, ref.x0, a.exponent)
    print(f"{'mode':>4s} {'t from':>9s} {'t to':>9s} {'h':>10s} {'err':>9s} {'q end':>9s}")
    for mode, t0, t1, h, err, q in log:
        print(f"{mode:>4s} {t0:9.4f} {t1:9.4f} {h:10.3e} {err:9.2e} {q:+9.4f}")
    print(f"{len(log)} step evaluations: accepted {int(stats[integ.S_ACCEPTED])}, rejected "
          f"{int(stats[integ.S_REJECTED])}, partial {int(stats[integ.S_PARTIAL])}; contact "
          f"switches {int(stats[integ.S_EVENTS])}")


if __name__ == "__main__":
    main()
