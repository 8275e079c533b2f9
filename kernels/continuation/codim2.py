"""Points located on a traced curve (kernels.continuation.curve): zeros of a test function
between two vertices (codimension-2 points), extrema of a parameter along the curve (its
turning points and cusps: by the bounded search of kernels.continuation.extremum), and the
end of a 2T curve on the 1T orbit, each on the curve's extended system and chord corrector
(kernels.continuation.extended_system). Dimensionless.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hertzmap.kernels.continuation.core import illinois_bracket, illinois_trial
from hertzmap.kernels.continuation.extended_system import chord_correct
from hertzmap.kernels.continuation.extremum import bounded_extremum

#: codimension-2 points along a curve
CODIM2_KINDS = ("cusp", "fold_flip", "fold_grazing", "flip_grazing")
#: the extremum search's tolerance in the chord's parameter th (a share of the chord)
EXTREMUM_XTOL = 1e-9


@dataclass
class Codim2Point:
    """A codimension-2 point on a traced curve, with its evidence: ``value`` is the other test
    function (or, for a cusp, the curve tangent's component along the parameter direction it
    had before) at the point, ``left``/``right`` its values at the two vertices that bracket it
    (opposite signs). ``accuracy``: the bracket's final width in the curve's parameters (for
    "fold_flip", the spread of the extrapolation)."""

    kind: str                # CODIM2_KINDS
    period: int
    omega: float
    sigma: float
    zeta: float
    x0: np.ndarray
    multipliers: np.ndarray
    value: float
    left: float
    right: float
    accuracy: float
    vertex: int = -1         # index of its vertex in Curve.vertices

    def as_dict(self):
        return {"kind": self.kind, "period": self.period, "omega": self.omega,
                "sigma": self.sigma, "zeta": self.zeta, "q0": float(self.x0[0]),
                "v0": float(self.x0[1]), "multipliers": [complex(z) for z in self.multipliers],
                "value": self.value, "left": self.left, "right": self.right,
                "accuracy": self.accuracy, "vertex": self.vertex}


def locate_zero(system, ua, ub, ga, gb, gfun, J=None, max_iter=30):
    """Zero of gfun(u, F, aux, J) between two vertices: Illinois regula falsi on the chord,
    each trial point corrected onto the curve on the hyperplane normal to the chord (with
    ``J`` kept, or a Jacobian built at each trial when gfun needs it fresh). Returns
    (u, F, aux, J, g, width in the parameters) or None."""
    c = ub - ua
    nc = float(np.linalg.norm(c))
    if nc == 0.0 or not (np.isfinite(ga) and np.isfinite(gb)) or ga * gb > 0.0:
        return None
    normal = c / nc
    ta, tb = 0.0, 1.0
    side = 0
    best = None
    wp = float(np.linalg.norm(c[2:]))
    for _ in range(max_iter):
        th = illinois_trial(ta, tb, ga, gb)
        r = chord_correct(system, ua + th * c, normal, J=J)
        if r is None:
            return best
        u, F, aux, Jt, _ = r
        g = gfun(u, F, aux, Jt)
        if not np.isfinite(g):
            return best
        if g == 0.0:
            return (u, F, aux, Jt, g, 0.0)
        ta, tb, ga, gb, side = illinois_bracket(th, g, ta, tb, ga, gb, side)
        # the bracket's width, or the secant's estimate |g / g'| where smaller
        slope = abs(gb - ga) / (wp * (tb - ta)) if tb > ta and wp > 0.0 else 0.0
        width = wp * (tb - ta)
        if slope > 0.0:
            width = min(width, abs(g) / slope)
        best = (u, F, aux, Jt, g, width)
        if (tb - ta) * nc <= 1e-13 * (1.0 + np.linalg.norm(u)):
            break
    return best


def locate_extremum(system, ua, ub, J, d, maximum):
    """The point of the curve between ua and ub (vertices two apart, bracketing it) where
    d . (a, b) is extremal: the curve's points on the hyperplanes normal to the chord
    through ua + th (ub - ua), th in [0, 1], with the shared bounded search over th
    (kernels.continuation.extremum.bounded_extremum, to EXTREMUM_XTOL in th: the extremal
    value is then exact to ~1e-18 times the curvature). Returns (u, F, aux) or None."""
    c = ub - ua
    normal = c / np.linalg.norm(c)

    def value_at(th):
        r = chord_correct(system, ua + th * c, normal, J=J)
        return None if r is None else (float(r[0][2:] @ d), r)

    # the chord's parameter th in [0, 1]: the window centred on 0.5, half-width 0.5
    found = bounded_extremum(value_at, 0.5, 0.5, xtol=EXTREMUM_XTOL, max_iter=80,
                             maximum=maximum)
    if found is None:
        return None
    u, F, aux, _, _ = found.point
    return u, F, aux


def end_on_1t_orbit(recs, us):
    """Extrapolate a 2T curve to where it meets the 1T orbit: the parameters are even
    functions of the 2T orbit's distance a from the 1T orbit, and |Phi_T(x) - x| = 2|a| +
    O(a^3), so p = p0 + c1 A + c2 A^2 with A = |Phi_T(x) - x|^2 (least squares over the
    vertices closest to the 1T orbit). Returns (u_end, accuracy) or None."""
    asym = np.array([r["asym"] for r in recs])
    ok = np.isfinite(asym)
    if ok.sum() < 3:
        return None
    idx = np.nonzero(ok)[0]
    idx = idx[np.argsort(asym[idx])][:8]
    if len(idx) < 3:
        return None
    A = asym[idx] ** 2
    U = np.array([us[i] for i in idx])
    end = np.empty(4)
    spread = 0.0
    deg = 3 if len(idx) >= 7 else (2 if len(idx) >= 4 else 1)
    for j in range(4):
        y = U[:, j]
        if j < 2:      # the 1T orbit's start point: the mean of x and its T-shift
            y = np.array([us[i][j] + 0.5 * recs[i]["_shift"][j] for i in idx])
        c_hi = np.polyfit(A, y, deg)
        # the spread: the same fit one degree lower, over the closest points
        c_lo = np.polyfit(A[:-1], y[:-1], deg - 1) if deg > 1 else c_hi
        end[j] = c_hi[-1]
        if j >= 2:
            spread = max(spread, abs(c_hi[-1] - c_lo[-1]))
    return end, spread
