"""The subharmonic thresholds as functions of damping (issue 33), by continuation.

* **sigma*(zeta)**: the lowest point of the 1T flip curve in the (omega, sigma) plane at fixed
  zeta, above which the subharmonic resonance is always excited (paper Eq. 26-27: by multiple
  scales 36 zeta / (1 + 16 zeta^2 / 9), 36 zeta as zeta -> 0; the rig measured
  (sigma*/zeta)_exp ~ 40 at zeta = 0.005).
* **sigma**(zeta)**: the lowest point of the isola's 2T fold curve (paper Fig. 8-9): below it
  no isola.
* **the join**: where the isola's 2T fold curve ends on the 1T flip curve (a fold_flip point:
  the isola joins the flip-born branch), when it does at that zeta.

**Extremum condition.** On a curve (Phi_{mT}(x) - x = 0, g = 0; g the flip or fold function of
the period-m monodromy: kernels.continuation's extended system) the curve's sigma at fixed
omega, sigma_c(omega), is the extended system solved by the chord corrector with omega held
(three equations, three unknowns q, q', sigma; warm-started from the nearest omega solved). The
lowest point is where d sigma_c / d omega = 0, found as the minimum of sigma_c over omega by
the bounded search of kernels.continuation.extremum (Brent, recentred when the minimum is on
the window's edge: :func:`curve_minimum`), not as the zero of a difference-Jacobian tangent
(which moved sigma** by 1e-6: docs/curves.md): sigma is flat there, so its value is exact to
the corrector's tolerance (|du| <= 1e-11). **Accuracy**: in sigma, the change of sigma_c at the
minimum when the integrator's tolerance is divided by ACCURACY_RTOL_FACTOR; in omega, the
half-width of the interval over which sigma_c stays within that accuracy of its minimum
(sqrt(2 accuracy / sigma_c''), the curvature from three points).

**Continued in zeta** (:func:`continue_minimum`): the minimum is a point of codimension 2 in
(omega, sigma, zeta) (a curve point with d sigma / d omega = 0) followed in zeta by the
extremum continuation of kernels.continuation.extremum (natural-parameter steps: the core's
secant then quadratic predictor of (q, q', omega, sigma) in zeta, the minimum found again at
each zeta around the predicted omega, the step adapted by the core's rule to the predictor's
miss in sigma), landing on every zeta asked for (the study's grid values). The curves
sigma*(zeta), sigma**(zeta) are these vertices. What stays here is the physics: which curve
each threshold is, where its search starts (multiple scales), how wide it is, the accuracy
estimate and the isola's join.

Pure (numpy, scipy and kernels; no xarray, no Dask). Dimensionless (paper Eq. 7 / 11).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from hertzmap.kernels import continuation as cont
from hertzmap.kernels.continuation.extended_system import CurveSystem, chord_correct
from hertzmap.kernels.continuation.extremum import bounded_extremum, continue_extremum
from hertzmap.kernels.model import DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL
from hertzmap.kernels.periodic_orbit import shoot
from hertzmap.study.analytic import multiple_scales as mms

#: The thresholds and the curve whose lowest point each is: (kind, period).
THRESHOLD_CURVES = {"star": ("flip", 1), "double_star": ("fold", 2)}
#: Brent's tolerance in omega for the minimum of sigma_c (the value of sigma there moves by
#: sigma_c'' xatol^2 / 2 ~ 1e-15).
OMEGA_XTOL = 1e-9
#: The accuracy in sigma is the change of the minimum's sigma when the integrator's rtol is
#: multiplied by this.
ACCURACY_RTOL_FACTOR = 1e-2
#: sigma_c'' from three points this far apart in omega (relative to the search's half-width).
CURVATURE_SHARE = 0.05
#: A minimum on the edge of the search's window (kernels.continuation.extremum.EDGE_SHARE) is
#: searched again in the window recentred there, at most RECENTRE times.
RECENTRE = 4
#: Continuation in zeta (kernels.continuation.extremum.continue_extremum): at least
#: MIN_VERTICES vertices over the range (the step at most its 1/MIN_VERTICES), at most
#: MAX_VERTICES a side.
MIN_VERTICES = 40
MAX_VERTICES = 400


@dataclass
class CurveMinimum:
    """The lowest point of a fold or flip curve in (omega, sigma) at ``zeta``: the orbit's start
    point (q0, v0), the accuracies (see the module's docstring), sigma_c'' there
    (``curvature``) and the period maps it took."""

    zeta: float
    omega: float
    sigma: float
    q0: float
    v0: float
    sigma_accuracy: float
    omega_accuracy: float
    curvature: float
    maps: int = 0

    def u(self) -> np.ndarray:
        return np.array([self.q0, self.v0, self.omega, self.sigma])

    def as_dict(self) -> dict:
        return asdict(self)


class _SigmaOnCurve:
    """sigma_c(omega): the curve's sigma at fixed omega (the extended system's corrector with
    omega held), each solve warm-started from the nearest omega solved before."""

    _HOLD_OMEGA = np.array([0.0, 0.0, 1.0, 0.0])

    def __init__(self, kind, period, zeta, exponent, model, rtol, max_steps):
        self.system = CurveSystem(kind, period, ("omega", "sigma"), zeta, exponent, model, rtol,
                                   max_steps)
        self.solved: dict[float, np.ndarray] = {}

    def seed(self, u) -> bool:
        r = chord_correct(self.system, np.asarray(u, float), self._HOLD_OMEGA, max_iter=30)
        if r is not None:
            self.solved[float(r.u[2])] = r.u.copy()
        return r is not None

    def point(self, omega: float) -> tuple[float, np.ndarray] | None:
        """(sigma_c(omega), the curve's point (q0, v0, omega, sigma) there), or None."""
        known = np.array(list(self.solved))
        u = self.solved[float(known[np.argmin(np.abs(known - omega))])].copy()
        u[2] = omega
        r = chord_correct(self.system, u, self._HOLD_OMEGA, max_iter=30)
        if r is None:
            return None
        self.solved[float(omega)] = r.u.copy()
        return float(r.u[3]), self.solved[float(omega)]

    def __call__(self, omega: float) -> float:
        """sigma_c(omega), +inf where the corrector does not reach the curve."""
        found = self.point(omega)
        return math.inf if found is None else found[0]


def curve_minimum(kind: str, period: int, zeta: float, start, *, half_width: float,
                  exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW, rtol: float = DEFAULT_RTOL,
                  max_steps: int = 10**6) -> CurveMinimum | None:
    """The lowest point in sigma of the ``kind`` ("fold" or "flip") curve of period-``period``
    orbits in (omega, sigma) at ``zeta``, searched within ``half_width`` of the omega of
    ``start`` = (q0, v0, omega, sigma), a point near the curve (recentred when the minimum is
    on the search's edge: kernels.continuation.extremum.bounded_extremum). None when the
    corrector does not reach the curve or the minimum stays on the edge."""
    sig = _SigmaOnCurve(kind, period, zeta, exponent, model, rtol, max_steps)
    if not sig.seed(start):
        return None
    lowest = bounded_extremum(sig.point, float(np.asarray(start, float)[2]), half_width,
                              xtol=OMEGA_XTOL, max_iter=200, recentre=RECENTRE)
    if lowest is None:
        return None
    w, u = lowest.at, lowest.point
    d = CURVATURE_SHARE * half_width
    s_lo, s_hi = sig(w - d), sig(w + d)
    curvature = (s_lo + s_hi - 2.0 * u[3]) / d**2
    fine = _SigmaOnCurve(kind, period, zeta, exponent, model, rtol * ACCURACY_RTOL_FACTOR,
                         max_steps)
    s_fine = fine(w) if fine.seed(u) else math.nan
    acc = abs(s_fine - u[3]) if math.isfinite(s_fine) else math.nan
    acc_w = (math.sqrt(2.0 * acc / curvature) if curvature > 0.0 and math.isfinite(acc)
             else math.nan)
    return CurveMinimum(float(zeta), w, float(u[3]), float(u[0]), float(u[1]), acc,
                        max(acc_w, OMEGA_XTOL), float(curvature),
                        sig.system.maps + fine.system.maps)


def flip_start(zeta: float, *, exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
               rtol: float = DEFAULT_RTOL, max_steps: int = 10**6):
    """A point near the 1T flip curve's lowest point at ``zeta``: omega = 2, sigma of paper
    Eq. 26 (multiple scales), the 1T orbit there shot from the static equilibrium (q = 0).
    (q0, v0, omega, sigma), or None."""
    sigma = float(mms.sigma_star(zeta, "paper"))
    o = shoot(2.0, sigma, zeta, 1, (0.0, 0.0), exponent=exponent, model=model, rtol=rtol,
              max_steps=max_steps)
    return (float(o.x0[0]), float(o.x0[1]), 2.0, sigma) if o.converged else None


def star_half_width(zeta: float) -> float:
    """The half-width in omega of the search for sigma*: the flip curve's U is ~ 4 zeta wide
    at twice its lowest sigma (paper Eq. 25b: sigma2 ~ 18 sqrt((omega - 2)^2 + 4 zeta^2))."""
    return max(2.0 * float(zeta), 2e-3)


#: The half-width in omega of the search for sigma**: the isola's fold curve is broad at its
#: lowest point (sigma rises by ~0.3 over 1 in omega at zeta 0.01).
DOUBLE_STAR_HALF_WIDTH = 0.05


@dataclass
class ZetaCurve:
    """A minimum continued in zeta: its vertices (CurveMinimum, zeta increasing) and how each
    end stopped ("range": the end of the range asked; "lost": the minimum was not found
    again with the shortest step; "max_vertices": MAX_VERTICES on that side)."""

    vertices: list
    status: tuple = ("range", "range")
    maps: int = 0


def continue_minimum(kind: str, period: int, start: CurveMinimum, zeta_range, *,
                     land_on=(), half_width=None, exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
                     rtol: float = DEFAULT_RTOL, max_steps: int = 10**6) -> ZetaCurve:
    """Continue the lowest point ``start`` of a ``kind`` curve in zeta, both ways across
    ``zeta_range`` = (lo, hi), landing on every zeta of ``land_on`` in the range (the study's
    grid values): kernels.continuation.extremum.continue_extremum, the minimum found again at
    each zeta by :func:`curve_minimum` around the predicted omega. ``half_width``: a function
    of zeta, the search's half-width (default :func:`star_half_width` for the flip,
    DOUBLE_STAR_HALF_WIDTH for a fold), widened to 3 times the predicted move of omega. Returns
    a :class:`ZetaCurve` (vertices in increasing zeta, ``start`` among them)."""
    lo, hi = (float(z) for z in zeta_range)
    if not lo <= start.zeta <= hi:
        raise ValueError(f"start.zeta = {start.zeta} is outside zeta_range ({lo}, {hi})")
    if half_width is None:
        half_width = star_half_width if kind == "flip" else (lambda z: DOUBLE_STAR_HALF_WIDTH)

    def minimum_at(zeta, u_pred, u_last):
        # the window reaches three times as far as the predictor moved omega
        found = curve_minimum(kind, period, zeta, u_pred,
                              half_width=max(half_width(zeta), 3.0 * abs(u_pred[2] - u_last[2])),
                              exponent=exponent, model=model, rtol=rtol, max_steps=max_steps)
        return None if found is None else (found.u(), found)

    path = continue_extremum(minimum_at, (start.zeta, start.u(), start), (lo, hi),
                             min_vertices=MIN_VERTICES, max_vertices=MAX_VERTICES,
                             land_on=land_on, value_index=3)
    return ZetaCurve(path.found, path.status, sum(v.maps for v in path.found) - start.maps)


@dataclass
class Join:
    """Where the isola's 2T fold curve ends on the 1T flip curve (fold_flip), with the spread
    of its extrapolation onto the 1T orbit (``accuracy``, in omega and sigma)."""

    zeta: float
    omega: float
    sigma: float
    accuracy: float
    maps: int = 0


#: The isola's fold curve is traced from its lowest point towards the flip curve within these
#: bounds (omega up to the subharmonic resonance's side beyond 2, sigma up to where the paper's
#: maps stop).
JOIN_BOUNDS = {"omega": 2.6, "sigma": 3.0}
#: The trace starts this far in omega to the right of sigma** (sigma then rises along it; from
#: 1e-2 the start corrector failed at zeta 0.0025, where the orbit moves fast with omega).
JOIN_START_OFFSET = 1e-3


def isola_join(lowest: CurveMinimum, *, exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
               rtol: float = DEFAULT_RTOL, max_steps: int = 10**6) -> Join | None:
    """The isola's join with the flip-born branch at ``lowest.zeta``: its 2T fold curve traced
    (kernels.continuation.trace_curve) from just right of its lowest point (``lowest``, sigma**)
    towards higher omega until it ends on the 1T orbit, where its end is extrapolated (the
    fold_flip point). None when the curve leaves the bounds or fails before that (the isola
    does not join the flip-born branch there)."""
    curve = cont.trace_curve(
        (lowest.q0, lowest.v0), lowest.omega + JOIN_START_OFFSET, lowest.sigma, lowest.zeta,
        kind="fold", period=2, pair=("omega", "sigma"), hold="omega", both_ways=False,
        direction=1.0, exponent=exponent, model=model, rtol=rtol, max_steps=max_steps,
        bounds={"omega": (lowest.omega, JOIN_BOUNDS["omega"]),
                "sigma": (0.0, JOIN_BOUNDS["sigma"])},
        ds_max=0.5, max_points=1500)
    joins = [p for p in curve.codim2 if p.kind == "fold_flip"]
    if not joins:
        return None
    p = joins[0]
    return Join(float(p.zeta), float(p.omega), float(p.sigma), float(p.accuracy),
                int(curve.maps))


def star_threshold(zetas, *, exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
                   rtol: float = DEFAULT_RTOL) -> tuple[ZetaCurve | None, str]:
    """sigma*(zeta) over the range of ``zetas`` (landing on each): the lowest point of the 1T
    flip curve found at the middle zeta from the multiple-scales estimate (:func:`flip_start`),
    continued both ways (:func:`continue_minimum`). Returns the curve (None when the minimum
    was not found) and how its ends stopped, or why there is none."""
    zetas = np.sort(np.asarray(zetas, float))
    kw = dict(exponent=exponent, model=model, rtol=rtol)
    z_mid = float(zetas[len(zetas) // 2])
    start = flip_start(z_mid, **kw)
    lowest = curve_minimum("flip", 1, z_mid, start, half_width=star_half_width(z_mid),
                           **kw) if start is not None else None
    if lowest is None:
        return None, "no 1T flip minimum near omega = 2 at zeta = %g" % z_mid
    curve = continue_minimum("flip", 1, lowest, (zetas[0], zetas[-1]), land_on=zetas, **kw)
    return curve, " ".join(curve.status)


def double_star_threshold(zetas, start, *, exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
                          rtol: float = DEFAULT_RTOL) -> tuple[ZetaCurve | None, list, str]:
    """sigma**(zeta) over the range of ``zetas`` (landing on each) and the isola's join traced
    from each of its vertices (:func:`isola_join`). ``start``: (zeta, (q0, v0, omega, sigma)),
    a point near the isola's lowest point (the traced isola's refined lowest vertex:
    study.products.damping.isola_start), or None. Returns the curve (None when there is
    none), the joins [(zeta, Join or None)] and how the curve's ends stopped, or why there is
    no curve."""
    zetas = np.sort(np.asarray(zetas, float))
    kw = dict(exponent=exponent, model=model, rtol=rtol)
    if start is None:
        return None, [], ("no traced isola fold curve (the curves output traces it where the grid "
                          "holds the isola's lowest point)")
    z0, u0 = start
    low2 = curve_minimum("fold", 2, z0, u0, half_width=DOUBLE_STAR_HALF_WIDTH, **kw)
    if low2 is None:
        return None, [], f"the traced isola's lowest vertex at zeta = {z0:g} did not refine"
    curve = continue_minimum("fold", 2, low2, (zetas[0], zetas[-1]), land_on=zetas, **kw)
    joins = [(p.zeta, isola_join(p, **kw)) for p in curve.vertices]
    return curve, joins, " ".join(curve.status)
