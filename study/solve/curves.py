"""Traced bifurcation curves of a study: seeds from its located points, one trace per curve.

A study with the ``curves`` output locates fold, flip and grazing points along its omega lines
(the ``bifurcations`` output, study.solve.block ``locate=True``). Each located point lies on a
curve of its kind in every plane of two swept parameters:

* (omega, sigma) at each zeta of the grid, when omega and sigma are swept;
* (omega, zeta) at each sigma, when omega and zeta are swept;
* (sigma, zeta) at each omega of the grid, when sigma and zeta are swept (the point is moved to
  the nearest grid omega by the trace's start corrector, with sigma free).

A fold point seeds a fold curve (1T or 2T orbits: multiplier +1), a flip point a flip curve (of
1T orbits, 1T -> 2T; of 2T orbits, 2T -> 4T: multiplier -1 of the 2T monodromy), a grazing point
a grazing curve (min q = -n, paper Eq. 7; stable and unstable orbits alike). A curve is traced
by two-parameter continuation (kernels.continuation.trace_curve) across the study's window in
its plane, both ways, through turning points and contact loss, until it leaves the window,
closes, or (2T) ends on the 1T orbit.

One seed per curve: seeds are taken in a fixed order (:func:`curve_seeds`) and a seed that lies
on a curve already traced from an earlier seed is skipped (:func:`covers`), so the curves kept
depend on the located points only, not on which trace finished first.

Pure (numpy and kernels, no Dask, no store): the scheduler ships :func:`trace_seed` to its
workers and decides the order of commits (scheduler.curve_tasks).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import xarray as xr

from kernels import continuation as cont
from study.schema import BIFURCATION_KINDS

#: The planes of two parameters a curve can be traced in (code 1, 2, 3 in the stored product).
PLANES = (("omega", "sigma"), ("omega", "zeta"), ("sigma", "zeta"))
#: Located kind (study.schema BIFURCATION_KINDS) -> curve kind (kernels.continuation).
_CURVE_OF_KIND = {code: kind for kind, code in BIFURCATION_KINDS.items()}

#: Trace settings: vertices at most 1 % of the window apart in each parameter, 1500 vertices a
#: side at most (a curve crossing the window takes 100-400).
TRACE_OPTIONS = {"ds": 0.01, "ds_min": 1e-7, "ds_max": 0.05, "dp_frac": 0.01, "max_points": 1500}

#: A seed lies on a traced curve when its parameters are within this fraction of the window of
#: the curve's polyline, and its orbit within COVER_STATE (1 + |x|) of the interpolated orbit
#: (or, for 2T orbits, of its T-shift).
COVER_PARAMS = 2e-3
COVER_STATE = 2e-2


@dataclass(frozen=True)
class Seed:
    """A located point as the start of a curve in one plane. ``index`` is its place in the
    study's seed order; ``fixed`` the value of the plane's third parameter."""

    index: int
    plane: tuple[str, str]
    fixed: float
    kind: str                 # "fold", "flip" or "grazing"
    period: int
    omega: float
    sigma: float
    zeta: float
    q0: float
    v0: float

    def params(self) -> dict[str, float]:
        """(omega, sigma, zeta) of the trace's start: the point's, with the third parameter of
        the plane at ``fixed``."""
        p = {"omega": self.omega, "sigma": self.sigma, "zeta": self.zeta}
        third = [n for n in ("omega", "sigma", "zeta") if n not in self.plane][0]
        p[third] = self.fixed
        return p

    def as_dict(self) -> dict:
        return asdict(self)


def swept_planes(axes: dict[str, np.ndarray]) -> list[tuple[str, str]]:
    """The planes of PLANES whose two parameters have two or more values in ``axes``."""
    return [p for p in PLANES if len(axes[p[0]]) >= 2 and len(axes[p[1]]) >= 2]


def window(axes: dict[str, np.ndarray], plane: tuple[str, str]) -> dict[str, tuple[float, float]]:
    """The study's range of each parameter of ``plane``: where its curves are traced."""
    return {p: (float(np.min(axes[p])), float(np.max(axes[p]))) for p in plane}


def located_points(ds: xr.Dataset) -> list[dict]:
    """The located points of a study's results (``bifurcation_*`` variables; from
    study.products.open_store or ``xr.open_zarr``), as dicts (kind, period, omega, sigma,
    zeta, q0, v0, line = (sigma index, zeta index)), ordered by line, then omega."""
    if "bifurcation_kind" not in ds:
        return []
    order = ("omega_block", "sigma", "zeta", "bifurcation")
    kind = ds["bifurcation_kind"].transpose(*order).values
    get = {n: ds[f"bifurcation_{n}"].transpose(*order).values
           for n in ("omega", "period", "q0", "v0")}
    sg, zt = ds["sigma"].values, ds["zeta"].values
    out = []
    for k in range(zt.size):
        for j in range(sg.size):
            pts = []
            for b, slot in np.argwhere(kind[:, j, k] > 0):
                code = int(kind[b, j, k, slot])
                w = float(get["omega"][b, j, k, slot])
                if code not in _CURVE_OF_KIND or not np.isfinite(w):
                    continue
                pts.append(dict(kind=_CURVE_OF_KIND[code], period=int(get["period"][b, j, k, slot]),
                                omega=w, sigma=float(sg[j]), zeta=float(zt[k]),
                                q0=float(get["q0"][b, j, k, slot]),
                                v0=float(get["v0"][b, j, k, slot]), line=(j, k)))
            pts.sort(key=lambda d: (d["omega"], d["kind"], d["period"]))
            out += pts
    return out


def curve_seeds(ds: xr.Dataset) -> list[Seed]:
    """The seeds of every curve of a study, in a fixed order: for each swept plane (PLANES
    order), each value of its third parameter (increasing), the located points line by line
    (the points of one line lie on different curves, so consecutive seeds rarely share a
    curve), by omega. A study without two swept axes has none."""
    axes = {n: np.sort(ds[n].values) for n in ("omega", "sigma", "zeta")}
    points = located_points(ds)
    seeds: list[Seed] = []
    for plane in swept_planes(axes):
        third = [n for n in ("omega", "sigma", "zeta") if n not in plane][0]
        for fixed in axes[third]:
            for d in points:
                if third == "omega":
                    # the grid omega nearest the point: its (sigma, zeta) curves pass nearby
                    near = float(axes["omega"][np.argmin(np.abs(axes["omega"] - d["omega"]))])
                    if near != fixed:
                        continue
                elif d[third] != fixed:
                    continue
                seeds.append(Seed(len(seeds), plane, float(fixed), d["kind"], d["period"],
                                  d["omega"], d["sigma"], d["zeta"], d["q0"], d["v0"]))
    return seeds


def trace_seed(seed: Seed, bounds: dict[str, tuple[float, float]], *, exponent: float = 1.5,
               model: str = "hertz", rtol: float = 1e-10, options: dict | None = None) -> dict:
    """Trace the curve through ``seed`` across ``bounds`` ({param: (lo, hi)} of its plane).

    Returns a plain dict (picklable, no xarray): ``seed`` (its dict), ``status`` (backward,
    forward end names, kernels.continuation.BRANCH_STATUS), ``vertices`` (kernels.continuation
    VERTEX_FIELDS -> arrays, plus ``multipliers`` (n, 2) complex, largest modulus first),
    ``codim2`` (list of dicts, Codim2Point.as_dict) and ``maps`` (period maps integrated).
    Never raises for a failed trace: the status says so (start_fail: the seed did not converge
    onto the curve).
    """
    opts = dict(TRACE_OPTIONS, **(options or {}))
    p = seed.params()
    curve = cont.trace_curve((seed.q0, seed.v0), p["omega"], p["sigma"], p["zeta"],
                             kind=seed.kind, period=seed.period, pair=seed.plane,
                             bounds=bounds, exponent=exponent, model=model, rtol=rtol, **opts)
    vert = {k: np.asarray(curve.vertices.get(k, np.zeros(0)), float)
            for k in cont.VERTEX_FIELDS}          # a failed trace: every field, empty
    n = len(vert["omega"])
    mult = np.full((n, 2), complex(np.nan, np.nan))
    for i in range(n):
        M = np.array([[vert["m11"][i], vert["m12"][i]], [vert["m21"][i], vert["m22"][i]]])
        if np.all(np.isfinite(M)):
            mu = np.linalg.eigvals(M).astype(complex)
            mult[i] = mu[np.argsort(-np.abs(mu), kind="stable")]
    vert["multipliers"] = mult
    return {"seed": seed.as_dict(), "status": curve.status_names, "vertices": vert,
            "codim2": [c.as_dict() for c in curve.codim2], "maps": int(curve.maps),
            "seconds": float(curve.seconds)}


def _t_shift(seed: Seed, exponent: float, model: str, rtol: float):
    """The T-shift Phi_T(x0) of a 2T seed's start point (the same orbit, started half a period
    later), or None."""
    p = seed.params()
    system = cont.System(p["zeta"], exponent, model, rtol)
    phi, _, code = system.map((seed.q0, seed.v0), p["omega"], p["sigma"], 1)
    return phi if code == 0 else None


def covers(traced: dict, seed: Seed, bounds: dict[str, tuple[float, float]], *,
           exponent: float = 1.5, model: str = "hertz", rtol: float = 1e-10) -> bool:
    """True when ``seed`` lies on the curve ``traced`` (a :func:`trace_seed` result): same
    plane, third parameter, kind and period; its parameters within COVER_PARAMS of the window
    of the curve's polyline; its orbit's start point (or, for a 2T orbit, its T-shift) within
    COVER_STATE (1 + |x|) of the start point interpolated at the nearest place on the curve."""
    s = traced["seed"]
    if (tuple(s["plane"]) != tuple(seed.plane) or s["fixed"] != seed.fixed
            or s["kind"] != seed.kind or s["period"] != seed.period):
        return False
    V = traced["vertices"]
    if len(V.get("omega", ())) < 2:
        return False
    a, b = seed.plane
    scale = np.array([max(bounds[a][1] - bounds[a][0], 1e-12),
                      max(bounds[b][1] - bounds[b][0], 1e-12)])
    P = np.column_stack([V[a], V[b]]) / scale
    p = np.array([seed.params()[a], seed.params()[b]]) / scale
    d = P[1:] - P[:-1]
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    th = np.clip(np.einsum("ij,ij->i", p - P[:-1], d) / dd, 0.0, 1.0)
    foot = P[:-1] + th[:, None] * d
    dist = np.hypot(*(foot - p).T)
    near = np.nonzero(dist <= COVER_PARAMS)[0]
    if near.size == 0:
        return False
    x = np.array([seed.q0, seed.v0])
    targets = [x]
    if seed.period == 2:
        shift = _t_shift(seed, exponent, model, rtol)
        if shift is not None:
            targets.append(shift)
    for i in near:
        xi = np.array([V["q0"][i] + th[i] * (V["q0"][i + 1] - V["q0"][i]),
                       V["v0"][i] + th[i] * (V["v0"][i + 1] - V["v0"][i])])
        for t in targets:
            if np.hypot(*(xi - t)) <= COVER_STATE * (1.0 + np.hypot(*t)):
                return True
    return False
