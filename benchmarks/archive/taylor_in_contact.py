"""Would a Taylor-series integrator beat DOP853 here? One period map of orbits in contact.

    .venv/bin/python benchmarks/archive/taylor_in_contact.py          (about 1 minute, compiles first)

Taylor-series methods are the other high-order family for small ODE systems at tight
tolerances: the series of q and of the variational matrix come from recurrences (the power
law F = s^n by J.C.P. Miller's recurrence, F' = s^(n-1) likewise, the forcing in closed form),
the step size from the last two coefficients (Jorba & Zou 2005), no stages, no rejections.
This script is an experiment, not part of the kernels: a straightforward numba Taylor
integrator of order K for the state and its variational matrix **in contact only** (no
contact switches; the orbits below never lose contact), timed in compiled loops against
``kernels.integrate.integrate`` on the same map (state + variational, no measures), fastest of
7 rounds, alternated. Errors are the max over (q, q', Phi) against the kernel at rtol 1e-14.
For each DOP853 tolerance it prints the fastest Taylor setting (order K, tolerance) whose error
is no larger, and the speed-up. Orbits with contact loss would need the Taylor analogue of the
approaches in w and x (the series radius shrinks to zero at the switch, as the RK step does).
"""
from __future__ import annotations

import sys
import time
from math import cos, pi, sin
from pathlib import Path

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import hertzmap.kernels.integrate as integ  # noqa: E402
from hertzmap.kernels import shoot  # noqa: E402
from hertzmap.kernels.shooting import _start  # noqa: E402  (y = (q, q', Phi = I))

CASES = [  # name, omega, sigma, zeta, period, rough guess (benchmarks/bench_kernels.py)
    ("1T in contact", 1.5, 0.2, 0.01, 1, (-0.16, 0.006)),
    ("1T primary resonance", 1.0, 0.05, 0.05, 1, (0.0, 0.5)),
    ("2T in contact", 1.9, 0.5, 0.01, 2, (0.86, 0.37)),
]
ORDERS = (12, 16, 20, 24)
TAYLOR_TOLS = (3e-8, 1e-8, 3e-9, 1e-9, 3e-10, 1e-10, 3e-11, 1e-11, 3e-12)
DOP_RTOLS = (1e-8, 1e-9, 1e-10)
N_EXP = 1.5


@njit(cache=True, nogil=True)
def taylor_map(y, t0, t1, omega, sigma, zeta, n, order, tol, co):
    """Advance y = (q, q', Phi11, Phi12, Phi21, Phi22) in contact from t0 to t1; returns steps.

    co is a (6, order + 1) work array: series of q, F, F', and the two columns of Phi's first
    row (their derivatives are the second row).
    """
    K = order
    t = t0
    steps = 0
    inv_n = 1.0 / n
    q = co[0]
    p = co[1]
    g = co[2]
    a = co[3]
    b = co[4]
    s = co[5]
    while t < t1 and steps < 100000:
        q[0] = y[0]
        q[1] = y[1]
        a[0] = y[2]
        a[1] = y[4]
        b[0] = y[3]
        b[1] = y[5]
        s[0] = 1.0 + q[0] * inv_n
        p[0] = s[0] ** n
        inv_s0 = 1.0 / s[0]
        g[0] = p[0] * inv_s0
        c0 = cos(omega * t)
        s0 = sin(omega * t)
        wk = 1.0                        # omega^k / k!
        for k in range(K - 1):
            if k > 0:
                s[k] = q[k] * inv_n
                acc_p = 0.0
                acc_g = 0.0
                for j in range(k):      # Miller: k s0 p_k = sum (n (k - j) - j) s_{k-j} p_j
                    acc_p += (n * (k - j) - j) * s[k - j] * p[j]
                    acc_g += ((n - 1.0) * (k - j) - j) * s[k - j] * g[j]
                p[k] = acc_p * inv_s0 / k
                g[k] = acc_g * inv_s0 / k
            m4 = k & 3                  # d^k/dt^k cos(omega t) / k! = omega^k/k! cos(. + k pi/2)
            if m4 == 0:
                ck = c0
            elif m4 == 1:
                ck = -s0
            elif m4 == 2:
                ck = -c0
            else:
                ck = s0
            fk = sigma * ck * wk
            if k == 0:
                fk += 1.0
            wk *= omega / (k + 1)
            den = 1.0 / ((k + 1) * (k + 2))
            q[k + 2] = (fk - 2.0 * zeta * (k + 1) * q[k + 1] - p[k]) * den
            ca = 0.0
            cb = 0.0
            for j in range(k + 1):
                ca += g[j] * a[k - j]
                cb += g[j] * b[k - j]
            a[k + 2] = (-2.0 * zeta * (k + 1) * a[k + 1] - ca) * den
            b[k + 2] = (-2.0 * zeta * (k + 1) * b[k + 1] - cb) * den
        scale = tol * max(1.0, abs(q[0]))
        h = 1e300
        for c in range(3):
            arr = q if c == 0 else (a if c == 1 else b)
            e1 = abs(arr[K - 1])
            e2 = abs(arr[K])
            if e1 > 0.0:
                h = min(h, (scale / e1) ** (1.0 / (K - 1)))
            if e2 > 0.0:
                h = min(h, (scale / e2) ** (1.0 / K))
        h *= 0.9
        if t + h > t1:
            h = t1 - t
        for c in range(3):
            arr = q if c == 0 else (a if c == 1 else b)
            val = arr[K]
            der = K * arr[K]
            for k in range(K - 1, -1, -1):
                val = val * h + arr[k]
                if k > 0:
                    der = der * h + k * arr[k]
            if c == 0:
                y[0] = val
                y[1] = der
            elif c == 1:
                y[2] = val
                y[4] = der
            else:
                y[3] = val
                y[5] = der
        t += h
        steps += 1
    return steps


@njit(cache=True, nogil=True)
def dop853_loop(reps, x0, v0, P, omega, sigma, zeta, n, rtol, h, y, stats, harm, t_eval,
                out_eval, f, y_new, f_new, Kw, Pw):
    for _ in range(reps):
        _start(y, x0, v0)
        stats[integ.S_ACCEPTED] = 0.0
        stats[integ.S_REJECTED] = 0.0
        integ.integrate(y, 0.0, P, omega, sigma, zeta, n, integ.HERTZ, rtol, rtol, h, 100000,
                        True, False, False, P, harm, t_eval, out_eval, stats, f, y_new, f_new,
                        Kw, Pw)
    return stats[integ.S_ACCEPTED] + stats[integ.S_REJECTED]


@njit(cache=True, nogil=True)
def taylor_loop(reps, x0, v0, P, omega, sigma, zeta, n, order, tol, y, co):
    steps = 0
    for _ in range(reps):
        _start(y, x0, v0)
        steps = taylor_map(y, 0.0, P, omega, sigma, zeta, n, order, tol, co)
    return steps


class Dop853:
    def __init__(self, x0, P, omega, sigma, zeta):
        self.args = (x0[0], x0[1], P, omega, sigma, zeta, N_EXP)
        self.y = np.empty(6)
        self.work = (np.zeros(integ.N_STATS), np.zeros((2, 8)), np.empty(0), np.empty((3, 0)),
                     np.empty(6), np.empty(6), np.empty(6), np.empty((16, 6)), np.empty((7, 6)))

    def run(self, rtol, reps=1):
        stats = self.work[0]
        dop853_loop(1, *self.args, rtol, 0.1, self.y, *self.work)       # carry the first step
        h = stats[integ.S_H_FIRST]
        steps = dop853_loop(reps, *self.args, rtol, h, self.y, *self.work)
        return self.y.copy(), steps


def fastest(fn, reps, rounds):
    best = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn(reps)
        best = min(best, (time.perf_counter() - t0) / reps)
    return best


def main() -> None:
    print(__doc__.split("\n\n")[0])
    for name, omega, sigma, zeta, m, rough in CASES:
        orbit = shoot(omega, sigma, zeta, m, guess=rough, rtol=1e-13)
        P = m * 2 * pi / omega
        dop = Dop853(orbit.x0, P, omega, sigma, zeta)
        ref, _ = dop.run(1e-14)
        y = np.empty(6)
        taylor = {}
        for K in ORDERS:
            co = np.zeros((6, K + 1))
            for tol in TAYLOR_TOLS:
                steps = taylor_loop(1, orbit.x0[0], orbit.x0[1], P, omega, sigma, zeta, N_EXP,
                                    K, tol, y, co)
                taylor[K, tol] = [steps, float(np.abs(y - ref).max()), np.inf, co]
        dops = {}
        for rtol in DOP_RTOLS:
            yd, steps = dop.run(rtol)
            dops[rtol] = [steps, float(np.abs(yd - ref).max()), np.inf]
        reps = 2000
        for _ in range(7):              # alternate the methods round by round
            for rtol, rec in dops.items():
                rec[2] = min(rec[2], fastest(lambda r: dop.run(rtol, r), reps, 1))
            for (K, tol), rec in taylor.items():
                rec[2] = min(rec[2], fastest(
                    lambda r: taylor_loop(r, orbit.x0[0], orbit.x0[1], P, omega, sigma, zeta,
                                          N_EXP, K, tol, y, rec[3]), reps, 1))
        print(f"\n{name} (omega {omega}, sigma {sigma}, zeta {zeta}, {m}T; min q "
              f"{orbit.min_q:.3f}): one period map, state + variational")
        print("  DOP853 rtol  steps  error    us   | fastest Taylor at <= its error: "
              "K  tol     steps  error    us   speed-up")
        for rtol, (steps, err, sec) in dops.items():
            ok = [(rec[2], K, tol, rec[0], rec[1]) for (K, tol), rec in taylor.items()
                  if rec[1] <= err]
            line = f"  {rtol:8.0e}   {steps:4.0f}  {err:.1e} {sec * 1e6:5.2f} |"
            if ok:
                tsec, K, tol, tsteps, terr = min(ok)
                line += (f"                                  {K:2d} {tol:.0e}  {tsteps:4d}  "
                         f"{terr:.1e} {tsec * 1e6:5.2f}  {sec / tsec:.2f}x")
            else:
                line += "  none reaches this error"
            print(line)


if __name__ == "__main__":
    main()
