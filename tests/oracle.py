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


# ---- the state with its variational matrix, for Benettin's method and period-m shooting -------

def variational_flow(x0, t0, t1, omega, sigma, zeta, n=1.5, rtol=1e-10, atol=1e-10,
                     max_step=np.inf, max_events=100_000):
    """Integrate paper Eq. 7 and its variational equations Phi' = J Phi (J = [[0, 1],
    [-F'(q), -2 zeta]], F' = 0 in flight) from (q, v) at t0 with Phi = I to t1. The contact
    switches q = -n are terminal events; the event direction alternates (a loss of contact is
    a downward crossing, a recontact an upward one), so a restart on the surface does not
    re-detect it. The vector field is continuous at q = -n (F(-n) = 0), so Phi continues
    unchanged across a switch (the saltation matrix is the identity). A contact excursion (or
    flight) shorter than a step can fall between two steps' sign tests: ``max_step`` bounds
    the steps so that such grazing switches are seen. Returns (x(t1), Phi)."""
    def rhs(t, y):
        s = 1.0 + y[0] / n
        F, dF = (s ** n, s ** (n - 1.0)) if s > 0.0 else (0.0, 0.0)
        tz = 2.0 * zeta
        return [y[1], 1.0 + sigma * np.cos(omega * t) - tz * y[1] - F,
                y[4], y[5], -dF * y[2] - tz * y[4], -dF * y[3] - tz * y[5]]

    def surface(t, y):
        return y[0] + n
    surface.terminal = True

    y = np.array([x0[0], x0[1], 1.0, 0.0, 0.0, 1.0], float)
    t = t0
    contact = y[0] + n > 0.0 or (y[0] + n == 0.0 and y[1] >= 0.0)
    for _ in range(max_events):
        surface.direction = -1.0 if contact else 1.0
        sol = solve_ivp(rhs, (t, t1), y, method="DOP853", rtol=rtol, atol=atol, events=surface,
                        max_step=max_step)
        if sol.status < 0:
            raise RuntimeError(sol.message)
        if sol.status == 1 and sol.t_events[0].size:
            t = float(sol.t_events[0][0])
            y = sol.y_events[0][0].copy()
            y[0] = -n
            contact = not contact
            continue
        y = sol.y[:, -1]
        return y[:2].copy(), y[2:].reshape(2, 2)
    raise RuntimeError("too many events")


def lyapunov_benettin(x0, omega, sigma, zeta, periods, discard=20, n=1.5, rtol=1e-10,
                      blocks=8, max_step=np.inf):
    """Largest Lyapunov exponent (per unit tau) by Benettin's method: the period map's Jacobian
    M_k from variational_flow over each forcing period, w <- M_k w / |M_k w|, the mean of
    log |M_k w| over ``periods`` periods after ``discard``, divided by T. Returns
    (exponent, standard error of the mean over ``blocks`` equal blocks, final state)."""
    T = 2.0 * pi / omega
    w = np.array([1.0, 1.0]) / np.sqrt(2.0)
    x = np.asarray(x0, float)
    logs = []
    for k in range(discard + periods):
        x, M = variational_flow(x, 0.0, T, omega, sigma, zeta, n=n, rtol=rtol, atol=rtol,
                                max_step=max_step)
        w = M @ w
        g = np.linalg.norm(w)
        w /= g
        if k >= discard:
            logs.append(np.log(g))
    logs = np.array(logs)
    per_block = len(logs) // blocks
    means = logs[:per_block * blocks].reshape(blocks, per_block).mean(axis=1) / T
    return logs.mean() / T, means.std(ddof=1) / np.sqrt(blocks), x


def shoot_period(guess, omega, sigma, zeta, m, n=1.5, rtol=1e-12, tol=1e-11, max_iter=30):
    """Period-m orbit by Newton on Phi_{mT}(x) - x with the monodromy M from
    variational_flow. Returns (x0, M); raises if Newton does not converge."""
    x = np.asarray(guess, float)
    P = m * 2.0 * pi / omega
    for _ in range(max_iter):
        y, M = variational_flow(x, 0.0, P, omega, sigma, zeta, n=n, rtol=rtol, atol=rtol)
        r = y - x
        if np.abs(r).max() <= tol * (1.0 + np.abs(x).max()):
            return x, M
        x = x + np.linalg.solve(M - np.eye(2), -r)
    raise RuntimeError("period-m shooting did not converge")


def trajectory(x0, t0, t1, t_eval, omega, sigma, zeta, n=1.5, rtol=1e-12, atol=1e-12,
               max_events=100_000):
    """Paper Eq. 7 from (q, v) at t0 to t1 with the switches as terminal events (direction
    alternating, as in variational_flow). Returns (q, v at the sorted times t_eval, the
    switches as an array of rows (t, v, +1 recontact / -1 loss of contact))."""
    def rhs(t, y):
        s = 1.0 + y[0] / n
        return [y[1], 1.0 + sigma * np.cos(omega * t) - 2.0 * zeta * y[1]
                - (s ** n if s > 0.0 else 0.0)]

    def surface(t, y):
        return y[0] + n
    surface.terminal = True

    t_eval = np.asarray(t_eval, float)
    out = np.full((2, t_eval.size), np.nan)
    switches = []
    y = np.array(x0, float)
    t = t0
    contact = y[0] + n > 0.0 or (y[0] + n == 0.0 and y[1] >= 0.0)
    for _ in range(max_events):
        surface.direction = -1.0 if contact else 1.0
        sol = solve_ivp(rhs, (t, t1), y, method="DOP853", rtol=rtol, atol=atol, events=surface,
                        dense_output=True)
        if sol.status < 0:
            raise RuntimeError(sol.message)
        end = float(sol.t[-1])
        inside = (t_eval >= t) & (t_eval <= end)
        if inside.any():
            out[:, inside] = sol.sol(t_eval[inside])
        if sol.status == 1 and sol.t_events[0].size:
            t = float(sol.t_events[0][0])
            y = sol.y_events[0][0].copy()
            y[0] = -n
            switches.append((t, y[1], -1.0 if contact else 1.0))
            contact = not contact
            continue
        return out[0], out[1], np.array(switches).reshape(-1, 3)
    raise RuntimeError("too many events")
