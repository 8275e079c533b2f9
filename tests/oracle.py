"""Independent reference for the kernels: scipy solve_ivp (DOP853, tight tolerances) with the
contact switches as terminal events and restarts, a finite-difference Jacobian and scipy's root
finder. Shares no code with kernels/ (not even the force law), so agreement is evidence.
"""
from __future__ import annotations

from math import pi

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root


def force(q, n=1.5, model="hertz"):
    if model == "taylor":
        return 1.0 + q + q * q / 6.0 - q ** 3 / 54.0
    s = 1.0 + q / n
    return s ** n if s > 0.0 else 0.0


def flow(x0, t0, t1, omega, sigma, zeta, n=1.5, model="hertz", rtol=1e-13, atol=1e-13,
         max_events=10_000):
    """Integrate paper Eq. 7 from (q, v) at t0 to t1, restarting at every crossing of q = -n."""
    def rhs(t, y):
        return [y[1], 1.0 + sigma * np.cos(omega * t) - 2.0 * zeta * y[1] - force(y[0], n, model)]

    def surface(t, y):
        return y[0] + n
    surface.terminal = True

    t, y = t0, np.array(x0, float)
    for _ in range(max_events):
        sol = solve_ivp(rhs, (t, t1), y, method="DOP853", rtol=rtol, atol=atol,
                        events=None if model == "taylor" else surface)
        if sol.status == 1 and sol.t_events[0].size:
            te = sol.t_events[0][0]
            ye = sol.y_events[0][0].copy()
            # step just past the surface so that the restart does not re-detect it
            if te <= t + 1e-12:
                sol2 = solve_ivp(rhs, (t, t1), y, method="DOP853", rtol=rtol, atol=atol,
                                 first_step=1e-9, max_step=1e-9 * 4)
                # fall back: advance a tiny fixed amount without events
                sol2 = solve_ivp(rhs, (te, min(t1, te + 1e-9)), ye, method="DOP853", rtol=rtol,
                                 atol=atol)
                t, y = sol2.t[-1], sol2.y[:, -1]
                continue
            ye[0] = -n
            t, y = te, ye
            # leave the surface with one tiny event-free step
            sol2 = solve_ivp(rhs, (t, min(t1, t + 1e-10)), y, method="DOP853", rtol=rtol, atol=atol)
            t, y = sol2.t[-1], sol2.y[:, -1]
            if t >= t1:
                return y
            continue
        return sol.y[:, -1]
    raise RuntimeError("too many events")


def period_map(x, omega, sigma, zeta, m=1, **kw):
    return flow(x, 0.0, m * 2.0 * pi / omega, omega, sigma, zeta, **kw)


def fixed_point(guess, omega, sigma, zeta, m=1, **kw):
    """Periodic orbit start point by scipy.optimize.root on Phi(x) - x (FD Jacobian inside)."""
    sol = root(lambda x: period_map(x, omega, sigma, zeta, m, **kw) - x, np.asarray(guess, float),
               method="hybr", options={"xtol": 1e-14})
    return sol.x, sol.success


def monodromy_fd(x, omega, sigma, zeta, m=1, delta=1e-6, **kw):
    """Central finite differences of the period map."""
    M = np.empty((2, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = delta
        M[:, j] = (period_map(x + e, omega, sigma, zeta, m, **kw)
                   - period_map(x - e, omega, sigma, zeta, m, **kw)) / (2 * delta)
    return M
