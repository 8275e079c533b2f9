"""A stable orbit's certified neighbourhood: where a census transient is shown to be on it, so
that it stops there instead of running until its points repeat (study.solve.census).

A stable orbit of period m is a fixed point x* of the m-period map Phi (the stroboscopic map
of paper Eq. 7 over m T, T = 2 pi / omega) with monodromy M, both multipliers inside the unit
circle. The quadratic Lyapunov function of the linearised map, V(x) = (x - x*)^T P (x - x*)
with M^T P M - P = -I (the discrete Lyapunov equation, lyapunov_form; P is positive definite because M
is stable), decreases over m periods by the factor kappa_lin = 1 - 1 / lambda_max(P) at worst:
V(M d) <= kappa_lin V(d). Near x* the map is its linearisation plus a remainder that grows like
|d|^2, so V decreases by a factor kappa (between kappa_lin and 1: KAPPA_SHARE of the margin
kept) on a neighbourhood V <= c. The certificate finds the largest such c on a ladder of levels
(each a factor LEVEL_STEP in V, 2 in radius): the m-period map is evaluated at DIRECTIONS points
of each of the rings V = c and V = c / 4 around x*, and the level holds when every one lands
at V(Phi(x)) <= kappa V(x). The level is also kept below every other known orbit's points
(OTHERS_SHARE of their V): a second fixed point inside would contradict the contraction.

The sampled rings are evidence, not a proof of the contraction between them: the remainder is
smooth in contact and across contact loss (the vector field is continuous at q = -n), and a
transient that enters the neighbourhood is recognised only after it has shown the predicted
contraction itself, m periods later (kernels.attractors.attractor_into). What this buys is
measured in BENCHMARKS.md (the census's periods with and without it) and its safety by the
brute-force completeness check (benchmarks/completeness.py).

Pure: numpy and scipy over the kernels' period map (no I/O).
"""
from __future__ import annotations

import math

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.attractors import (A, N_ATTRACTOR_FIELDS, N_CERT_FIELDS, NO_LABEL,
                                         attractor_batch_into, known_attractors)
from hertzmap.kernels.continuation import period_map_into
from hertzmap.kernels.model import Model
from hertzmap.kernels.shooting import N_FIELDS

#: points sampled on each ring around the orbit's start point
DIRECTIONS = 8
#: the rings sampled at a level c: V = c and V = c / 4 (radius 1 and 1/2)
RINGS = (1.0, 0.25)
#: kappa = 1 - KAPPA_SHARE (1 - kappa_lin): the decrease of V the neighbourhood must show,
#: a share of the linear margin (measured on the default scene's points: 0.5 certified
#: transients after 92 periods on average, 0.1 after 77)
KAPPA_SHARE = 0.25
#: the ladder of levels: each LEVEL_STEP times the last (2 in radius), from a radius of
#: FIRST_RADIUS (1 + |x*|), at most MAX_LEVELS steps either way
LEVEL_STEP = 4.0
FIRST_RADIUS = 0.05
MAX_LEVELS = 8
#: the certified level stays below this share of V at any other known orbit's point
OTHERS_SHARE = 0.25
#: the integrator tolerance of the sampled maps (the transients')
RTOL = 1e-8
#: the certificate's map is the orbit's m-period map iterated this many times (J m periods,
#: monodromy M^J): a larger neighbourhood contracts over J m periods than over m, but each
#: level costs J times the periods and a transient shows the contraction J m periods after it
#: enters (`python -m benchmarks.census_ab --compare iterations --study scenes/default.toml
#: --lines 16 --offset 5`, five lines: J = 2 ran 24 % fewer transient periods, 780,077 against
#: 1,030,150, the same attractors at every point, for census CPU 1.03x less, within the spread
#: of its ABBA pairs 0.85-1.28: not worth a longer verification, so J = 1)
ITERATIONS = 1


def _map(x, omega, sigma, zeta, m, n, model, out) -> bool:
    """Phi_{mT}(x) and its Jacobian into out (kernels.continuation.period_map_into)."""
    code = period_map_into(float(x[0]), float(x[1]), omega, sigma, zeta, int(m), n, model, RTOL,
                           RTOL, 200_000, out)
    return code == st.CONVERGED and bool(np.all(np.isfinite(out[:2])))


_NOTHING_KNOWN = known_attractors((), (), (), ())


def _maps(xs: np.ndarray, omega, sigma, zeta, m, n, model) -> np.ndarray:
    """Phi_{mT} of each row of xs (k, 2) in one call of the census's kernel (m periods of
    transient, no detection can fire in that time, no tangent integration); NaN rows where an
    integration failed."""
    k = xs.shape[0]
    rows = np.empty((k, N_ATTRACTOR_FIELDS))
    orbits = np.empty((k, N_FIELDS))
    strobes = np.empty((k, 1, 2))
    attractor_batch_into(omega, sigma, zeta, np.ascontiguousarray(xs[:, 0]),
                         np.ascontiguousarray(xs[:, 1]), n, model, int(m) - 1, 1, False, 0, 1,
                         1e-300, 1, RTOL, RTOL, RTOL, 200_000, False, *_NOTHING_KNOWN, NO_LABEL,
                         rows, orbits, strobes)
    out = rows[:, [A["q_end"], A["v_end"]]]
    failed = ~np.isin(rows[:, A["status"]], (st.UNSETTLED, st.UNCONFIRMED, st.CONVERGED))
    out[failed] = np.nan                 # integrator failures (kernels.status)
    return out


class LevelHints:
    """The certified levels of the last grid point along a line (its census's certificates),
    the ladder's start for the same orbit at the next point (certify's ``start``): an orbit's
    level changes little from one grid point to the next, so the ladder there tests the
    neighbour's level and the one above it. A hint that misses costs ladder steps, never a
    wrong certificate: every level is tested on the orbit's own map."""

    #: a hint is the orbit's when its x* is within this share of (1 + |x0|) of the orbit's
    NEAR = 0.5

    def __init__(self):
        self.rows: list[np.ndarray] = []

    def start(self, orbit: dict) -> float | None:
        """The level of the nearest certified orbit of the same period, if near enough."""
        m = int(orbit["period"]) * ITERATIONS
        x0 = np.asarray(orbit["x0"], float)
        best, level = self.NEAR * (1.0 + float(np.hypot(*x0))), None
        for row in self.rows:
            if int(row[7]) != m:
                continue
            d = float(np.hypot(row[0] - x0[0], row[1] - x0[1]))
            if d <= best:
                best, level = d, float(row[5])
        return level

    def keep(self, rows) -> None:
        """A point's certificates: the hints of the next point."""
        self.rows = [np.asarray(r, float) for r in rows]


def lyapunov_form(M: np.ndarray) -> np.ndarray | None:
    """The symmetric P with M^T P M - P = -I (the discrete Lyapunov equation of a 2 x 2 M),
    solved as three linear equations in (p11, p12, p22); None when they are singular (a
    multiplier on the unit circle)."""
    (a, b), (c, d) = np.asarray(M, float)
    # (M^T P M)_{ij} for P = [[x, y], [y, z]], the three independent entries
    A3 = np.array([[a * a - 1.0, 2.0 * a * c, c * c],
                   [a * b, a * d + b * c - 1.0, c * d],
                   [b * b, 2.0 * b * d, d * d - 1.0]])
    try:
        x, y, z = np.linalg.solve(A3, [-1.0, 0.0, -1.0])
    except np.linalg.LinAlgError:
        return None
    return np.array([[x, y], [y, z]])


def orbit_points(orbit: dict, omega: float, sigma: float, zeta: float, options: dict
                 ) -> np.ndarray | None:
    """The orbit's m stroboscopic points (its start point, then each period's image), (m, 2);
    None when an integration fails."""
    law = Model.of(options)
    n, model = law.exponent, law.code
    out = np.empty(6)
    x = np.array(orbit["x0"], float)
    pts = [x]
    for _ in range(int(orbit["period"]) - 1):
        if not _map(x, omega, sigma, zeta, 1, n, model, out):
            return None
        x = out[:2].copy()
        pts.append(x)
    return np.array(pts)


def certify(orbit: dict, omega: float, sigma: float, zeta: float, options: dict,
            others: np.ndarray = np.empty((0, 2)), start: float | None = None
            ) -> np.ndarray | None:
    """The certified neighbourhood of a stable orbit (module docstring) as a row of
    kernels.attractors' C_* columns (x*, P, level, kappa, m), or None (an unstable orbit, a
    failed integration, or no level passes). ``others``: points (k, 2) the neighbourhood must
    keep clear of (the other orbits' points, this orbit's other phases). ``start``: a level
    near which the ladder's walk starts (a neighbouring grid point's certified level of the
    same orbit, LevelHints: the walk then tests two rungs where it tests four from rung 0, and
    ends on the same rung wherever the rungs that hold are those below one); None: rung 0."""
    if not orbit.get("stable") or orbit.get("status", st.CONVERGED) != st.CONVERGED \
            or int(orbit["period"]) < 1:
        return None
    m = int(orbit["period"]) * ITERATIONS
    law = Model.of(options)
    n, model = law.exponent, law.code
    x0 = np.array(orbit["x0"], float)
    M = orbit.get("monodromy")
    if M is not None:
        M = np.linalg.matrix_power(np.asarray(M, float).reshape(2, 2), ITERATIONS)
    else:
        out = np.empty(6)
        if not _map(x0, omega, sigma, zeta, m, n, model, out):
            return None
        M = out[2:6]
    M = np.asarray(M, float).reshape(2, 2)
    if not np.all(np.isfinite(M)) or np.max(np.abs(np.linalg.eigvals(M))) >= 1.0:
        return None
    P = lyapunov_form(M)
    if P is None:
        return None
    lam = np.linalg.eigvalsh(P)
    if not (np.all(np.isfinite(lam)) and lam[0] > 0.0):
        return None
    kappa = 1.0 - KAPPA_SHARE / lam[1]              # 1 - share x (1 - kappa_lin)
    # the sampled directions: d = sqrt(V) L^-T u, unit u, with P = L L^T
    L = np.linalg.cholesky(P)
    theta = 2.0 * math.pi * np.arange(DIRECTIONS) / DIRECTIONS
    unit = np.linalg.solve(L.T, np.stack([np.cos(theta), np.sin(theta)]))      # (2, K)
    V = lambda d: float(d @ P @ d)
    cap = math.inf
    for p in np.asarray(others, float).reshape(-1, 2):
        if np.all(np.isfinite(p)):
            cap = min(cap, OTHERS_SHARE * V(p - x0))

    def holds(c: float, rings) -> bool:
        """Every sampled point of the rings V = c ring lands at V <= kappa c ring."""
        d = np.concatenate([(math.sqrt(c * ring) * unit).T for ring in rings])
        y = _maps(x0 + d, omega, sigma, zeta, m, n, model) - x0
        ratio = np.einsum("ki,ij,kj->k", y, P, y) / np.repeat(np.asarray(rings) * c, DIRECTIONS)
        return bool(np.all(ratio <= kappa))                  # NaN (a failure) never holds

    # the ladder's rungs: the level whose smallest semi-axis is FIRST_RADIUS (1 + |x*|) (or the
    # cap of the other orbits, if lower) times LEVEL_STEP^k, |k| <= MAX_LEVELS; from rung 0 up
    # while the rungs hold, or down to the first that holds. A start level (a neighbour's)
    # starts the walk at the rung nearest it instead: where the rungs that hold are those
    # below some rung (the usual case), the walk ends on the same rung either way
    c0 = min((FIRST_RADIUS * (1.0 + float(np.hypot(*x0)))) ** 2 * lam[1], cap)
    if not c0 > 0.0:
        return None
    k = 0
    if start is not None and math.isfinite(start) and start > 0.0:
        k = int(round(math.log(start / c0) / math.log(LEVEL_STEP)))
        k = max(-MAX_LEVELS, min(MAX_LEVELS, k))
        while k > 0 and c0 * LEVEL_STEP ** k > cap:
            k -= 1
    if holds(c0 * LEVEL_STEP ** k, RINGS):
        while k < MAX_LEVELS and c0 * LEVEL_STEP ** (k + 1) <= cap \
                and holds(c0 * LEVEL_STEP ** (k + 1), RINGS):
            k += 1
    else:
        while True:
            k -= 1
            if k < -MAX_LEVELS:
                return None
            if holds(c0 * LEVEL_STEP ** k, RINGS):
                break
    c = c0 * LEVEL_STEP ** k
    row = np.empty(N_CERT_FIELDS)
    row[:] = (x0[0], x0[1], P[0, 0], P[0, 1], P[1, 1], c, kappa, m)
    return row
