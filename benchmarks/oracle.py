"""The independent reference of hertzmap: scipy solve_ivp with the contact switches as terminal
events and restarts, scipy's root finder, finite-difference monodromy. The one scipy oracle:
the tests and the benchmarks (``hertzmap bench``, bench_kernels.py) use it.

It shares no code with kernels/ (not even the force law), so agreement is evidence. Paper Eq. 7
(Hertz, contact lost at q = -n) and Eq. 11 (Taylor, no contact loss), dimensionless.
"""
from __future__ import annotations

from math import pi

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root


def force(q, n=1.5, model="hertz"):
    """Contact force F(q)/N: (1 + q/n)^n in contact, 0 in flight (Taylor: Eq. 10)."""
    if model == "taylor":
        return 1.0 + q + q * q / 6.0 - q ** 3 / 54.0
    s = 1.0 + q / n
    return s ** n if s > 0.0 else 0.0


def stiffness(q, n=1.5, model="hertz"):
    """dF/dq."""
    if model == "taylor":
        return 1.0 + q / 3.0 - q * q / 18.0
    s = 1.0 + q / n
    return s ** (n - 1.0) if s > 0.0 else 0.0


def flow(x0, t0, t1, omega, sigma, zeta, n=1.5, model="hertz", rtol=1e-13, atol=1e-13,
         method="DOP853", max_events=10_000):
    """Integrate paper Eq. 7 (or Eq. 11) from (q, v) at t0 to t1, restarting at every crossing
    of q = -n. The event direction alternates (a loss of contact is followed by a recontact), so
    that a restart on the surface does not detect it again. Radau gets the analytic Jacobian.
    Returns (q, v) at t1 (NaN when the integration fails)."""
    def rhs(t, y):
        return [y[1], 1.0 + sigma * np.cos(omega * t) - 2.0 * zeta * y[1] - force(y[0], n, model)]

    def jac(t, y):
        return [[0.0, 1.0], [-stiffness(y[0], n, model), -2.0 * zeta]]

    def surface(t, y):
        return y[0] + n
    surface.terminal = True

    kw = dict(method=method, rtol=rtol, atol=atol)
    if method == "Radau":
        kw["jac"] = jac
    t, y = float(t0), np.array(x0, float)
    if model == "taylor":
        sol = solve_ivp(rhs, (t, t1), y, **kw)
        return sol.y[:, -1] if sol.status >= 0 else np.full(2, np.nan)
    direction = -1.0 if y[0] + n > 0.0 or (y[0] + n == 0.0 and y[1] >= 0.0) else 1.0
    for _ in range(max_events):
        surface.direction = direction
        sol = solve_ivp(rhs, (t, t1), y, events=surface, **kw)
        if sol.status == 1 and sol.t_events[0].size:
            t = float(sol.t_events[0][0])
            y = sol.y_events[0][0].copy()
            y[0] = -n
            direction = -direction      # loss -> next is a recontact, and back
            continue
        if sol.status < 0:
            return np.full(2, np.nan)
        return sol.y[:, -1]
    raise RuntimeError("too many contact events")


def period_map(x, omega, sigma, zeta, m=1, **kw):
    """Phi_{mT}(x), T = 2 pi / omega."""
    return flow(x, 0.0, m * 2.0 * pi / omega, omega, sigma, zeta, **kw)


def fixed_point(guess, omega, sigma, zeta, m=1, **kw):
    """Periodic orbit start point by scipy.optimize.root on Phi(x) - x (FD Jacobian inside).
    Returns (x, success)."""
    xtol = max(kw.get("rtol", 1e-14), 1e-14)

    def g(x):
        if not np.all(np.isfinite(x)) or np.abs(x).max() > 1e6:
            return np.full(2, 1e6)
        return period_map(x, omega, sigma, zeta, m, **kw) - x
    sol = root(g, np.asarray(guess, float), method="hybr", options={"xtol": xtol})
    return sol.x, bool(sol.success)


def monodromy_fd(x, omega, sigma, zeta, m=1, delta=1e-6, **kw):
    """Central finite differences of the period map."""
    M = np.empty((2, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = delta
        M[:, j] = (period_map(x + e, omega, sigma, zeta, m, **kw)
                   - period_map(x - e, omega, sigma, zeta, m, **kw)) / (2 * delta)
    return M


def orbit(guess, omega, sigma, zeta, m=1, *, method="DOP853", rtol=1e-13, n=1.5):
    """(x0, multipliers, ok): root (hybr) on Phi(x) - x, monodromy by central differences with
    a step that balances truncation and tolerance noise."""
    kw = dict(method=method, rtol=rtol, atol=rtol, n=n)
    x, ok = fixed_point(guess, omega, sigma, zeta, m, **kw)
    delta = max(1e-7, 1e2 * rtol) ** 0.5 * 1e-2
    M = monodromy_fd(x, omega, sigma, zeta, m, delta=delta, **kw)
    if not np.all(np.isfinite(M)):
        return x, np.full(2, np.nan), False
    return x, np.linalg.eigvals(M), ok


def flip_function(M):
    """1 + tr M + det M: zero where a multiplier is -1 (the oracle's own, from its FD M)."""
    return 1.0 + M[0, 0] + M[1, 1] + M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]


def fold_function(M):
    """1 - tr M + det M: zero where a multiplier is +1."""
    return 1.0 - M[0, 0] - M[1, 1] + M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
