"""The independent reference of hertzmap: scipy solve_ivp with the contact switches as terminal
events and restarts (one loop, ``piecewise``), scipy's root finder, the monodromy from the
variational equations integrated with the orbit (``map_and_monodromy``; the finite-difference
``monodromy_fd`` is kept for the integrator comparisons of work_precision.py and for the tests
that check a monodromy against an independent one); and from these its own bifurcation points
(``flip_omega`` / ``flip_point``: brentq on 1 + tr M + det M; ``fold_point``: the fixed point
and 1 - tr M + det M = 0 solved together for (q, v, omega); ``fold_on_line``, ``grazing_point``).
The one scipy oracle: the tests and the benchmarks (``hertzmap bench``, bench_kernels.py) use it.

It shares no code with kernels/ (not even the force law), so agreement is evidence. Paper Eq. 7
(Hertz, contact lost at q = -n) and Eq. 11 (Taylor, no contact loss), dimensionless.
"""
from __future__ import annotations

from math import pi

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, root


def _hertz(q, n):
    s = 1.0 + q / n
    return (s ** n, s ** (n - 1.0)) if s > 0.0 else (0.0, 0.0)


def _taylor(q, n):
    return 1.0 + q + q * q / 6.0 - q ** 3 / 54.0, 1.0 + q / 3.0 - q * q / 18.0


#: the oracle's own contact laws by name, (F, dF/dq) of (q, n): paper Eq. 7 (Hertz: (1 +
#: q/n)^n in contact, 0 in flight) and Eq. 10 (Taylor); a law the kernels declare
#: (kernels.model.LAWS) must have its twin here, written independently
LAWS = {"hertz": _hertz, "taylor": _taylor}


def force(q, n=1.5, model="hertz"):
    """Contact force F(q)/N."""
    return LAWS[model](q, n)[0]


def stiffness(q, n=1.5, model="hertz"):
    """dF/dq."""
    return LAWS[model](q, n)[1]


class IntegrationFailed(RuntimeError):
    """solve_ivp failed (status < 0) on a piece between two contact switches."""


def piecewise(rhs, y0, t0, t1, *, n=1.5, switches=True, method="DOP853", rtol=1e-13,
              atol=1e-13, jac=None, max_step=np.inf, events=(), dense_output=False,
              on_piece=None, max_events=100_000):
    """The one event-restart loop of the oracle: integrate y' = rhs(t, y) (y[0] = q, y[1] = v,
    further components carried along) from t0 to t1 with solve_ivp, the contact switches
    q = -n as terminal events, restarting on the surface at each. The event direction
    alternates (a loss of contact is a downward crossing, a recontact an upward one), so that
    a restart on the surface does not detect it again; q is set to -n exactly at the restart.
    Each piece is smooth (no kink of the force inside it), which is what DOP853's error control
    needs. ``switches=False`` (the Taylor model): one piece, no events. ``events``: further
    (non-terminal) event functions, their results in each piece's solution; ``on_piece(sol)``
    is called with every piece's solve_ivp result. Returns (y(t1), the switches as rows
    (t, v, +1 recontact / -1 loss of contact)); raises IntegrationFailed when solve_ivp fails
    and RuntimeError after ``max_events`` switches."""
    kw = dict(method=method, rtol=rtol, atol=atol, max_step=max_step, dense_output=dense_output)
    if jac is not None:
        kw["jac"] = jac
    t, y = float(t0), np.array(y0, float)
    if not switches:
        sol = solve_ivp(rhs, (t, t1), y, events=list(events) or None, **kw)
        if sol.status < 0:
            raise IntegrationFailed(sol.message)
        if on_piece is not None:
            on_piece(sol)
        return sol.y[:, -1].copy(), []

    def surface(t, y):
        return y[0] + n
    surface.terminal = True
    contact = y[0] + n > 0.0 or (y[0] + n == 0.0 and y[1] >= 0.0)
    found = []
    for _ in range(max_events):
        surface.direction = -1.0 if contact else 1.0
        sol = solve_ivp(rhs, (t, t1), y, events=[surface, *events], **kw)
        if sol.status < 0:
            raise IntegrationFailed(sol.message)
        if on_piece is not None:
            on_piece(sol)
        if sol.status == 1 and sol.t_events[0].size:
            t = float(sol.t_events[0][0])
            y = sol.y_events[0][0].copy()
            y[0] = -n
            found.append((t, y[1], -1.0 if contact else 1.0))
            contact = not contact           # loss -> next is a recontact, and back
            continue
        return sol.y[:, -1].copy(), found
    raise RuntimeError("too many contact events")


def flow(x0, t0, t1, omega, sigma, zeta, n=1.5, model="hertz", rtol=1e-13, atol=1e-13,
         method="DOP853", max_events=10_000):
    """Integrate paper Eq. 7 (or Eq. 11) from (q, v) at t0 to t1, restarting at every crossing
    of q = -n (:func:`piecewise`). Radau gets the analytic Jacobian. Returns (q, v) at t1 (NaN
    when the integration fails)."""
    def rhs(t, y):
        return [y[1], 1.0 + sigma * np.cos(omega * t) - 2.0 * zeta * y[1] - force(y[0], n, model)]

    def jac(t, y):
        return [[0.0, 1.0], [-stiffness(y[0], n, model), -2.0 * zeta]]

    try:
        y, _ = piecewise(rhs, x0, t0, t1, n=n, switches=model != "taylor", method=method,
                         rtol=rtol, atol=atol, jac=jac if method == "Radau" else None,
                         max_events=max_events)
    except IntegrationFailed:
        return np.full(2, np.nan)
    return y


def force_moments(x0, omega, sigma, zeta, m=1, n=1.5, model="hertz", rtol=1e-12):
    """(mean F, rms F, max q) over one period m T from x0: the integrals of F and F^2 carried
    along as two more components of the flow (:func:`piecewise`), max q from each piece's
    dense output refined by a bounded scalar search."""
    from scipy.optimize import minimize_scalar

    P = m * 2.0 * np.pi / omega

    def rhs(t, y):
        f = force(y[0], n, model)
        return [y[1], 1.0 + sigma * np.cos(omega * t) - 2.0 * zeta * y[1] - f, f, f * f]

    peaks = []

    def on_piece(sol):
        tt = np.linspace(sol.t[0], sol.t[-1], 2001)
        k = int(np.argmax(sol.sol(tt)[0]))
        lo, hi = tt[max(k - 1, 0)], tt[min(k + 1, tt.size - 1)]
        r = minimize_scalar(lambda t: -sol.sol(t)[0], bounds=(lo, hi), method="bounded",
                            options={"xatol": 1e-12})
        peaks.append(max(-r.fun, float(sol.sol(tt[k])[0])))

    y, _ = piecewise(rhs, [x0[0], x0[1], 0.0, 0.0], 0.0, P, n=n, switches=model != "taylor",
                     rtol=rtol, atol=rtol, dense_output=True, on_piece=on_piece)
    return y[2] / P, float(np.sqrt(y[3] / P)), max(peaks)


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


# ---- the state with its variational matrix, for Benettin's method and period-m shooting -------

def variational_flow(x0, t0, t1, omega, sigma, zeta, n=1.5, rtol=1e-10, atol=1e-10,
                     max_step=np.inf, max_events=100_000, model="hertz"):
    """Integrate paper Eq. 7 (or Eq. 11) and its variational equations Phi' = J Phi (J = [[0,
    1], [-F'(q), -2 zeta]], F' = 0 in flight) from (q, v) at t0 with Phi = I to t1, across the
    contact switches q = -n by :func:`piecewise` (Taylor: one piece). A contact excursion (or
    flight) shorter than a step can fall between two steps' sign tests: ``max_step`` bounds
    the steps so that such grazing switches are seen. Returns (x(t1), Phi).

    No jump of Phi at a switch: the saltation matrix of a transversal crossing of q = -n is
    I + (f+ - f-) n^T / (n^T f-), and f+ = f- there because the force is continuous at the
    surface (F(-n) = (1 + q/n)^n = 0 = the flight's force, for any exponent n > 0), so it is
    the identity and Phi continues unchanged. For the Hertz exponent 1.5 the force is even
    C^1 there (F' = (1 + q/n)^(n-1) = 0 at q = -n): J itself is continuous, only its
    derivative (F'' ~ (q + n)^(-1/2)) is not, and the restart at each switch keeps that
    singularity at the end of a piece. (A grazing orbit, n^T f- = 0, is where this fails.)"""
    tz = 2.0 * zeta
    taylor = model == "taylor"

    def rhs(t, y):
        if taylor:
            q = y[0]
            F, dF = 1.0 + q + q * q / 6.0 - q ** 3 / 54.0, 1.0 + q / 3.0 - q * q / 18.0
        else:
            s = 1.0 + y[0] / n
            F, dF = (s ** n, s ** (n - 1.0)) if s > 0.0 else (0.0, 0.0)
        return [y[1], 1.0 + sigma * np.cos(omega * t) - tz * y[1] - F,
                y[4], y[5], -dF * y[2] - tz * y[4], -dF * y[3] - tz * y[5]]

    y0 = np.array([x0[0], x0[1], 1.0, 0.0, 0.0, 1.0], float)
    y, _ = piecewise(rhs, y0, t0, t1, n=n, switches=not taylor, rtol=rtol, atol=atol,
                     max_step=max_step, max_events=max_events)
    return y[:2].copy(), y[2:].reshape(2, 2)


def map_and_monodromy(x, omega, sigma, zeta, m=1, *, n=1.5, model="hertz", rtol=1e-13):
    """(Phi_{mT}(x), M): the period-m map and its monodromy matrix dPhi_{mT}/dx, exact to the
    integration tolerance (the variational equations integrated with the orbit by DOP853 at
    rtol = atol = ``rtol``, :func:`variational_flow`), no finite differences."""
    return variational_flow(x, 0.0, m * 2.0 * pi / omega, omega, sigma, zeta, n=n, rtol=rtol,
                            atol=rtol, model=model)


def monodromy(x, omega, sigma, zeta, m=1, *, n=1.5, model="hertz", rtol=1e-13):
    """The monodromy matrix of the period-m map at x from the variational equations."""
    return map_and_monodromy(x, omega, sigma, zeta, m, n=n, model=model, rtol=rtol)[1]


def shoot(guess, omega, sigma, zeta, m=1, *, n=1.5, model="hertz", rtol=1e-13, tol=None):
    """(x, M, residual): the m T orbit near ``guess`` by scipy.optimize.root (hybr) on
    Phi_{mT}(x) - x with its exact Jacobian M - I (the variational equations), then Phi and M
    once more at the root: M is the monodromy at the returned x and ``residual`` =
    max |Phi(x) - x| there. Raises ArithmeticError unless the residual is <= ``tol`` (1 + |x|)
    (default 1e3 rtol: hybr's own success flag is not used, its xtol can be below what the
    integration noise allows)."""
    def g(x):
        if not np.all(np.isfinite(x)) or np.abs(x).max() > 1e6:
            return np.full(2, 1e6), np.eye(2)
        y, M = map_and_monodromy(x, omega, sigma, zeta, m, n=n, model=model, rtol=rtol)
        return y - x, M - np.eye(2)
    sol = root(g, np.asarray(guess, float), jac=True, method="hybr",
               options={"xtol": max(rtol, 1e-14)})
    x = sol.x.copy()
    y, M = map_and_monodromy(x, omega, sigma, zeta, m, n=n, model=model, rtol=rtol)
    residual = float(np.abs(y - x).max())
    tol = 1e3 * rtol if tol is None else tol
    if not residual <= tol * (1.0 + np.abs(x).max()):
        raise ArithmeticError(f"oracle orbit at omega = {omega!r}, sigma = {sigma!r}: "
                              f"residual {residual:.2e}")
    return x, M, residual


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


def shoot_period(guess, omega, sigma, zeta, m, n=1.5, rtol=1e-12, tol=1e-11):
    """Period-m orbit by :func:`shoot` (hybr on Phi_{mT}(x) - x with the monodromy M from
    variational_flow). Returns (x0, M); raises ArithmeticError unless the residual is
    <= ``tol`` (1 + |x|)."""
    x, M, _ = shoot(guess, omega, sigma, zeta, m, n=n, rtol=rtol, tol=tol)
    return x, M


# -- bifurcation points located by the oracle itself ------------------------------------------
# Each is the oracle's own root: its fixed point (scipy root on its own period map) and its own
# monodromy (the variational equations, :func:`map_and_monodromy`), no value from kernels/.
# The tests compare hertzmap's located points with these.

def checked_fixed_point(guess, omega, sigma, zeta, m=1, *, n=1.5, model="hertz", rtol=1e-12):
    """The m T orbit's start point near ``guess`` (``fixed_point`` at rtol = atol = ``rtol``),
    checked by its residual: raises ArithmeticError unless |Phi(x) - x| <= 1e3 rtol (1 + |x|).
    (hybr's own success flag is not used: its xtol can be below what the integration noise
    allows while the residual is at the tolerance.)"""
    kw = dict(rtol=rtol, atol=rtol, n=n, model=model)
    x, _ = fixed_point(np.asarray(guess, float), omega, sigma, zeta, m, **kw)
    residual = np.abs(period_map(x, omega, sigma, zeta, m, **kw) - x).max()
    if not residual <= 1e3 * rtol * (1.0 + np.abs(x).max()):
        raise ArithmeticError(f"oracle fixed point at omega = {omega!r}: residual {residual:.2e}")
    return x


def flip_function_at(omega, sigma, zeta, guess, m=1, *, n=1.5, model="hertz", rtol=1e-12):
    """(1 + tr M + det M, x): the flip function of the oracle's m T orbit near ``guess`` at
    ``omega`` (:func:`shoot`: M from the variational equations at the orbit)."""
    x, M, _ = shoot(guess, omega, sigma, zeta, m, n=n, model=model, rtol=rtol)
    return flip_function(M), x


def flip_omega(bracket, sigma, zeta, guess, m=1, *, n=1.5, model="hertz", rtol=1e-12,
               xtol=1e-10):
    """(omega, x): the frequency in ``bracket`` = (omega_a, omega_b) where the oracle's m T orbit
    has a Floquet multiplier -1 (a flip, period doubling): scipy.optimize.brentq on
    ``flip_function_at``, each orbit started from the previous one (the first from ``guess``).
    The flip function must change sign over the bracket (brentq raises otherwise)."""
    state = {"x": np.asarray(guess, float)}

    def g(w):
        value, state["x"] = flip_function_at(w, sigma, zeta, state["x"], m, n=n, model=model,
                                             rtol=rtol)
        return value

    omega = brentq(g, bracket[0], bracket[1], xtol=xtol)
    x, _, _ = shoot(state["x"], omega, sigma, zeta, m, n=n, model=model, rtol=rtol)
    return omega, x


def fold_point(guess, omega, sigma, zeta, m=2, *, n=1.5, model="hertz", rtol=1e-12,
               xtol=1e-10):
    """(x, omega, residuals): the point (q, v, omega) where the oracle's m T orbit has a Floquet
    multiplier +1 (a fold, saddle-node), as the root of the three equations

        Phi_mT(x; omega) - x = 0,    fold_function(M(x; omega)) = 0

    by scipy.optimize.root (hybr, forward-difference Jacobian with relative steps 1e-8) from
    (``guess``, ``omega``), Phi and M from one integration of the variational equations
    (:func:`map_and_monodromy`). ``residuals`` = (max |Phi(x) - x|, |fold function|) at the
    root: the caller checks them (hybr may report "no progress" once the equations are at their
    noise level). Along the branch omega - omega_fold grows like the square of the distance to
    the fold, so an error e in the fold function moves omega by O(e^2)."""
    def equations(u):
        x, w = u[:2], u[2]
        y, M = map_and_monodromy(x, w, sigma, zeta, m, n=n, model=model, rtol=rtol)
        return np.r_[y - x, fold_function(M)]

    sol = root(equations, np.r_[np.asarray(guess, float), omega], method="hybr",
               options={"xtol": xtol, "eps": 1e-8})
    f = equations(sol.x)
    return sol.x[:2].copy(), float(sol.x[2]), (float(np.abs(f[:2]).max()), float(abs(f[2])))


def trajectory(x0, t0, t1, t_eval, omega, sigma, zeta, n=1.5, rtol=1e-12, atol=1e-12,
               max_events=100_000):
    """Paper Eq. 7 from (q, v) at t0 to t1 across the switches (:func:`piecewise`). Returns
    (q, v at the sorted times t_eval, the switches as an array of rows (t, v, +1 recontact /
    -1 loss of contact))."""
    def rhs(t, y):
        s = 1.0 + y[0] / n
        return [y[1], 1.0 + sigma * np.cos(omega * t) - 2.0 * zeta * y[1]
                - (s ** n if s > 0.0 else 0.0)]

    t_eval = np.asarray(t_eval, float)
    out = np.full((2, t_eval.size), np.nan)

    def sample(sol):
        inside = (t_eval >= sol.t[0]) & (t_eval <= sol.t[-1])
        if inside.any():
            out[:, inside] = sol.sol(t_eval[inside])

    _, switches = piecewise(rhs, x0, t0, t1, n=n, rtol=rtol, atol=atol, dense_output=True,
                            on_piece=sample, max_events=max_events)
    return out[0], out[1], np.array(switches).reshape(-1, 3)


# ---- curves: points of fold, flip and grazing curves at a fixed parameter -------------------

def min_q(x, omega, sigma, zeta, m=1, *, n=1.5, rtol=1e-12, method="DOP853"):
    """Lowest q over the orbit started at x (period m T): the values where q' turns from
    negative to positive (events, located by solve_ivp), in contact and in flight alike (the
    flight is integrated as the same ODE with F = 0, not in closed form), and the pieces' ends
    (:func:`piecewise`: restarts at the contact switches keep every piece smooth)."""
    def rhs(t, y):
        return [y[1], 1.0 + sigma * np.cos(omega * t) - 2.0 * zeta * y[1] - force(y[0], n)]

    def turn(t, y):
        return y[1]
    turn.direction = 1.0
    lowest = [float(x[0])]

    def piece(sol):
        if sol.t_events[1].size:
            lowest.append(float(np.min(sol.y_events[1][:, 0])))
        lowest.append(float(sol.y[0, -1]))
        if sol.status == 1:                 # ended on a switch: q = -n there
            lowest.append(-n)

    piecewise(rhs, x, 0.0, m * 2.0 * pi / omega, n=n, method=method, rtol=rtol, atol=rtol,
              events=(turn,), on_piece=piece, max_events=10_000)
    return min(lowest)


def _is_fixed_point(x, omega, sigma, zeta, m, rtol, n, tol=1e-9):
    """hybr can report failure at a point it cannot improve on: accept it when it maps onto
    itself to ``tol`` (1 + |x|)."""
    r = period_map(x, omega, sigma, zeta, m, rtol=rtol, atol=rtol, n=n) - np.asarray(x)
    return bool(np.all(np.isfinite(r)) and np.hypot(*r) <= tol * (1.0 + np.hypot(*x)))


def _line_params(fixed_name, fixed_value, free_name, free_value, others):
    p = dict(others)
    p[fixed_name] = fixed_value
    p[free_name] = free_value
    return p["omega"], p["sigma"], p["zeta"]


def flip_point(guess, bracket, *, fixed, free, params, m=1, rtol=1e-13, n=1.5, xtol=1e-13):
    """The flip of the period-m orbit on the line where ``fixed`` (a name of omega, sigma,
    zeta) keeps its value in ``params`` and ``free`` varies in ``bracket``: the zero of
    1 + tr M + det M by brentq, the orbit re-solved at every trial from the last one by
    :func:`shoot` (M from the variational equations at rtol = atol = ``rtol``: exact to the
    integration tolerance; the central or Richardson-extrapolated differences used before
    limited 3T and 5T flips with long flights to 1e-8..3e-7 in omega), to ``xtol`` in the
    free parameter (a test that checks to 1e-8 passes 1e-11: each brentq step is a shooting
    at rtol 1e-13, and a 5T flip took 12 of them to 1e-13, 5 to 1e-11). Returns (free value,
    orbit start point)."""
    state = {"x": np.asarray(guess, float)}

    def g(p):
        w, s, z = _line_params(fixed, params[fixed], free, p, params)
        try:
            x, M, _ = shoot(state["x"], w, s, z, m, n=n, rtol=rtol)
        except ArithmeticError as e:
            raise RuntimeError(f"oracle orbit failed at {free} = {p}: {e}") from None
        state["x"] = x
        return flip_function(M)
    root_p = brentq(g, *bracket, xtol=xtol, rtol=1e-15)
    return root_p, state["x"]


def grazing_point(guess, bracket, *, fixed, free, params, m=1, rtol=1e-12, n=1.5):
    """The grazing of the period-m orbit (min q = -n) on a line, as :func:`flip_point`."""
    state = {"x": np.asarray(guess, float)}

    def g(p):
        w, s, z = _line_params(fixed, params[fixed], free, p, params)
        x, ok = fixed_point(state["x"], w, s, z, m, rtol=rtol, atol=rtol, n=n)
        if not (ok or _is_fixed_point(x, w, s, z, m, rtol, n)):
            raise RuntimeError(f"oracle orbit failed at {free} = {p}")
        state["x"] = x
        return min_q(x, w, s, z, m, n=n, rtol=rtol) + n
    root_p = brentq(g, *bracket, xtol=1e-13, rtol=1e-15)
    return root_p, state["x"]


def fold_on_line(guess, *, fixed, free, params, m=1, half_width=0.05, rtol=1e-12, n=1.5,
               maximum=None):
    """The fold of the period-m orbit on a line (``fixed`` held, ``free`` varies): the extremum
    of the free parameter along the branch, the branch parametrised by q(0) = c (Phi(x) = x
    solved for (q'(0), free) at each c by scipy's root) and the extremum over c in
    guess[0] +- half_width by a bounded scalar search. ``maximum``: True for a fold where the
    branch turns back towards lower values (decided from the two ends when None). Returns
    (free value, orbit start point)."""
    from scipy.optimize import minimize_scalar

    state = {"v": float(guess[1]), "p": float(params[free])}

    def branch(c):
        def eqs(z):
            w, s, zz = _line_params(fixed, params[fixed], free, z[1], params)
            return period_map((c, z[0]), w, s, zz, m, rtol=rtol, atol=rtol, n=n) \
                - np.array([c, z[0]])
        sol = root(eqs, [state["v"], state["p"]], method="hybr", options={"xtol": 1e-13})
        res = eqs(sol.x)
        # hybr may report failure at a point it cannot improve on: accept a small residual
        if not (np.all(np.isfinite(res)) and np.max(np.abs(res)) <= 1e-9 * (1 + abs(c))):
            return np.nan
        state["v"], state["p"] = float(sol.x[0]), float(sol.x[1])
        return state["p"]
    c0 = float(guess[0])
    if maximum is None:
        p_mid = branch(c0)
        maximum = p_mid >= max(branch(c0 - half_width), branch(c0 + half_width))
        branch(c0)
    sign = -1.0 if maximum else 1.0
    def objective(c):
        p = branch(c)
        return sign * p if np.isfinite(p) else np.inf
    res = minimize_scalar(objective, bounds=(c0 - half_width, c0 + half_width),
                          method="bounded", options={"xatol": 1e-9})
    p = branch(float(res.x))
    return p, np.array([float(res.x), state["v"]])


def flip_curve_minimum(zeta, omega_bracket, sigma_bracket, guess, *, rtol=1e-11, n=1.5,
                       omega_xtol=1e-7):
    """(sigma*, omega*, x): the lowest point in sigma of the 1T flip curve at ``zeta`` (paper
    Eq. 26-27 by multiple scales), the oracle's own way: at each trial omega, the flip
    (multiplier -1 of the 1T orbit: :func:`shoot`, M from the variational equations at rtol =
    atol = ``rtol``) located in sigma within ``sigma_bracket`` by brentq (:func:`flip_point`,
    omega held); then scipy's bounded minimize_scalar over omega in ``omega_bracket`` (to
    ``omega_xtol``: sigma is flat at the minimum, so sigma* moves by sigma'' xtol^2 / 2, ~1e-11
    at zeta 0.005). ``guess``: the 1T orbit's start point near the bracket."""
    from scipy.optimize import minimize_scalar

    state = {"x": np.asarray(guess, float)}

    def sigma_flip(w):
        s, x = flip_point(state["x"], sigma_bracket, fixed="omega", free="sigma",
                          params={"omega": w, "sigma": sigma_bracket[0], "zeta": zeta},
                          rtol=rtol, n=n)
        state["x"] = x
        return s

    res = minimize_scalar(sigma_flip, bounds=omega_bracket, method="bounded",
                          options={"xatol": omega_xtol})
    sigma = sigma_flip(float(res.x))
    return sigma, float(res.x), state["x"]
