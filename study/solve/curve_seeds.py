"""Traced bifurcation curves of a study: seeds from its grid, one trace per curve.

**Seeds.** A fold, flip or grazing curve that crosses the grid shows where a test function of
the stored orbits changes sign between two neighbouring grid points, along any swept axis
(:func:`crossings`, between the orbits matched by the continuity rule of study.orbit_rules):

* flip: 1 + tr M + det M = (1 + mu1)(1 + mu2) of two matched orbits of one period (1T -> 2T,
  2T -> 4T, ... mT -> 2mT);
* grazing: min q + n (paper Eq. 7; min q - q_c for the Taylor model) of two matched orbits;
* fold: a branch that ends between the two points (its orbits have no continuation at the
  neighbour), either as a pair of orbits with close invariants and fold functions
  (1 - mu1)(1 - mu2) of opposite signs (both halves of the fold: the line search turns every
  fold it meets), or as one orbit with a multiplier within END_MULTIPLIER of +1 (and not the
  2T orbit ending on the 1T orbit at its flip: a branch point, the flip curve's); one with a
  multiplier near -1 ends in a flip.

Each such grid cell (a pair of neighbouring grid points, the edge between them) is a seed: the
curve's start point estimated on the edge (the test function interpolated linearly; a fold at
the edge's midpoint), with the start point x of the nearer orbit; kernels.continuation's start
corrector puts it on the curve, holding the edge's constant parameter. Along omega the
crossings come from every orbit the line search found (``crossing_*`` per line, recorded by the
block solver: study.solve.block ``crossings=True``); across lines and blocks from the stored
slots (``min_q``, ``max_q``, ``multipliers``: the "measures" output). The cost does not grow
with anything but the grid's reading: no continuation in the grid's tasks.

In every plane of two swept parameters:

* (omega, sigma) at each zeta of the grid, when omega and sigma are swept;
* (omega, zeta) at each sigma, when omega and zeta are swept;
* (sigma, zeta) at each omega of the grid, when sigma and zeta are swept.

**One trace per curve.** Seeds are taken in a fixed order (:func:`curve_seeds`) and a seed that
lies on a curve already traced from an earlier seed is skipped (:func:`covers`: same kind,
period and plane, the curve within COVER_CELLS grid steps of the seed's crossing, its orbit's
invariants within the continuity rule's share), so the curves kept depend on the grid only,
not on which trace finished first. A trace that converges onto a curve already traced from an
earlier seed is dropped (:meth:`SeedBook.duplicate_of`: its start within LANDS_CELLS of
the earlier curve, invariants within LANDS_SHARE); a seed whose trace fails to start marks the seeds
within FAILED_CELLS of it (same kind and period) as tried.

**Completeness** (:meth:`SeedBook.outcomes`): after tracing, every seed (every grid cell whose test
function changes sign) is covered by a traced curve or reported with the reason it is not
(stored in ``products/traced_curves``: ``seed_outcome``).

Pure (numpy and kernels, no Dask, no store): the scheduler ships :func:`trace_seed` to its
workers and decides the order of commits (scheduler.stages.curve_tasks).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import xarray as xr

from hertzmap.kernels import continuation as cont
from hertzmap.kernels import status as st
from hertzmap.kernels.model import DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL
from hertzmap.kernels.continuation import extended_system
from hertzmap.study.orbit_rules import (CONTINUITY_SHARE, continuity_distance, flip_function, fold_function,
                          match_neighbours)
from hertzmap.study.schema import BIFURCATION_KINDS
from hertzmap.study.spec import AXES

#: The planes of two parameters a curve can be traced in (code 1, 2, 3 in the stored product).
PLANES = (("omega", "sigma"), ("omega", "zeta"), ("sigma", "zeta"))
#: Kind code (study.schema BIFURCATION_KINDS) -> curve kind (kernels.continuation).
KIND_OF_CODE = {code: kind for kind, code in BIFURCATION_KINDS.items()}

#: Trace settings: vertices at most 1 % of the window apart in each parameter, 1500 vertices a
#: side at most (a curve crossing the window takes 100-400). The step is an arclength in
#: (q, q', and the two parameters): ds_max 0.5 lets it follow orbits whose start point moves by
#: tens across the window (the census's 3T orbits with long flights: with 0.05 their fold
#: curves stopped at 1500 vertices, a fifth of the way); the parameters' steps stay within
#: dp_frac, and the curves' ends and extrema moved by <= 2e-8 (the default scene).
TRACE_OPTIONS = {"ds": 0.01, "ds_min": 1e-7, "ds_max": 0.5, "dp_frac": 0.01, "max_points": 1500}

#: An orbit of a period the line search does not follow (met by the census) with no
#: continuation at the neighbouring grid point ends there in a fold (a flip) when a multiplier
#: lies this close to +1 (-1).
END_MULTIPLIER = 0.25
#: Two orbits ending between two grid points (no continuation at the neighbour), of one period,
#: with fold functions of opposite signs and invariants within this share of (1 + ptp), are the
#: two halves of a fold.
FOLD_PAIR_SHARE = 1.0
#: A seed lies on a traced curve when the curve passes within this many grid steps (each
#: parameter in units of its grid step) of the seed's estimated crossing, with invariants
#: (min q, max q) within the continuity rule's share of the seed orbit's.
COVER_CELLS = 1.0
#: A trace's start lies on an earlier curve (the trace is a duplicate) within this many grid
#: steps, invariants within LANDS_SHARE (1 + ptp). The curve's invariants between two vertices
#: are interpolated linearly: near the isola's join with the 1T orbit they vary like the root
#: of the distance to it, and a start on the curve there differed from the interpolation by
#: 1e-3 (1 + ptp) with the vertices of ds_max 0.5 (the default scene).
LANDS_CELLS = 0.05
LANDS_SHARE = 1e-2
#: Seeds of one kind and period within this many grid steps of a seed whose trace failed to
#: start (and invariants within the share) are not tried again: a curve the corrector cannot
#: reach costs a few failed starts, not one per grid cell.
FAILED_CELLS = 3.0


@dataclass(frozen=True)
class Seed:
    """A grid cell where a test function changes sign, as the start of a curve in one plane.
    ``index`` is its place in the study's seed order; ``fixed`` the value of the plane's third
    parameter; (omega, sigma, zeta) the estimated crossing (the trace's start), (q0, v0) the
    start point of the nearer orbit; ``hold`` the parameter held by the start corrector (the
    cell's constant one); (min_q, max_q) the orbit's invariants at the crossing, known to
    ``spread`` (their change across the cell, or between a fold's two halves)."""

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
    hold: str = ""
    min_q: float = math.nan
    max_q: float = math.nan
    spread: float = 0.0

    def params(self) -> dict[str, float]:
        """(omega, sigma, zeta) of the trace's start: the crossing's, with the third parameter
        of the plane at ``fixed``."""
        p = {"omega": self.omega, "sigma": self.sigma, "zeta": self.zeta}
        third = [n for n in AXES if n not in self.plane][0]
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


def grid_steps(axes: dict[str, np.ndarray], plane: tuple[str, str]) -> dict[str, float]:
    """The grid step of each parameter of ``plane`` (the largest spacing of its values): the
    unit of the coverage tests."""
    return {p: float(np.max(np.diff(np.sort(np.asarray(axes[p], float)))))
            if len(axes[p]) >= 2 else 1.0 for p in plane}


# -- sign changes between neighbouring grid points -----------------------------------------------
def _nearest_multiplier(orbit, target: float) -> float:
    return float(np.min(np.abs(np.asarray(orbit["multipliers"]) - target)))


def _branch_point(orbit, others) -> bool:
    """The orbit (period m) is near an orbit of a period dividing m at the same grid point:
    it ends on it (the flip of the shorter orbit), not in a fold."""
    m = orbit["period"]
    return any(o["period"] < m and m % o["period"] == 0
               and continuity_distance(o, orbit) <= CONTINUITY_SHARE * (1.0 + o["ptp"])
               for o in others)


def crossings(A: list, B: list, level: float, searched=None) -> list[dict]:
    """The test functions' sign changes between two neighbouring grid points P and Q, whose
    orbits are ``A`` and ``B`` (mappings with period, x0, min_q, max_q, ptp, multipliers):
    dicts kind, period, theta (the crossing's estimated place on the edge, 0 at P, 1 at Q),
    orbit (the seed's orbit: of the nearer point), min_q, max_q (the invariants at the
    crossing, interpolated) and spread (their change across the edge). ``level``: the
    contact-loss level (min q of a grazing orbit). ``searched``: the periods the line search
    follows (both halves of their folds are found); an orbit of another period (met by the
    census, stable) that ends with a multiplier near +1 or -1 ends in a fold or a flip.
    Ordered: matched pairs (flip, grazing) in A's order, then the ends at P, then at Q."""
    out = []
    pairs = match_neighbours(A, B)
    for ia, ib in sorted(pairs):
        a, b = A[ia], B[ib]
        for kind, fa, fb in (("flip", flip_function(a), flip_function(b)),
                             ("grazing", a["min_q"] - level, b["min_q"] - level)):
            if not (np.isfinite(fa) and np.isfinite(fb)) or fa * fb >= 0.0:
                continue
            th = fa / (fa - fb)
            out.append(dict(kind=kind, period=a["period"], theta=th,
                            orbit=a if th <= 0.5 else b,
                            min_q=a["min_q"] + th * (b["min_q"] - a["min_q"]),
                            max_q=a["max_q"] + th * (b["max_q"] - a["max_q"]),
                            spread=continuity_distance(a, b)))
    for X, used in ((A, {p[0] for p in pairs}), (B, {p[1] for p in pairs})):
        ends = [i for i in range(len(X)) if i not in used]
        # both halves of a fold: one period, fold functions of opposite signs, the closest
        # pairs first (near a fold the halves' invariants differ like the root of the
        # distance to it: more than the continuity rule allows between neighbours)
        cand = sorted((continuity_distance(X[i], X[j]), i, j) for i in ends for j in ends
                      if i < j and X[i]["period"] == X[j]["period"]
                      and fold_function(X[i]) * fold_function(X[j]) < 0.0)
        done = set()
        for d, i, j in cand:
            x, y = X[i], X[j]
            if i in done or j in done or d > FOLD_PAIR_SHARE * (1.0 + max(x["ptp"], y["ptp"])):
                continue
            done |= {i, j}
            o = x if abs(fold_function(x)) <= abs(fold_function(y)) else y
            if o["period"] == 1:          # one start point per orbit: the halves' mean
                o = dict(o, x0=tuple(0.5 * (np.asarray(x["x0"]) + np.asarray(y["x0"]))))
            out.append(dict(kind="fold", period=o["period"], theta=0.5, orbit=o,
                            min_q=0.5 * (x["min_q"] + y["min_q"]),
                            max_q=0.5 * (x["max_q"] + y["max_q"]), spread=d))
        for i in ends:
            o = X[i]
            if i in done or (searched is not None and o["period"] in searched):
                continue
            if _nearest_multiplier(o, 1.0) <= END_MULTIPLIER and not _branch_point(o, X):
                kind = "fold"
            elif _nearest_multiplier(o, -1.0) <= END_MULTIPLIER:
                kind = "flip"
            else:
                continue
            out.append(dict(kind=kind, period=o["period"], theta=0.5, orbit=o,
                            min_q=o["min_q"], max_q=o["max_q"], spread=0.0))
    return out


def line_crossings(omega, per_point: list, level: float, searched=None,
                   edges=None) -> list[dict]:
    """The crossings (:func:`crossings`) between consecutive grid points of one omega line
    (``per_point``: the orbits at each point, omega in any order), as records: kind, period,
    omega (the estimated crossing), q0, v0 (the start point of the nearer orbit), min_q, max_q,
    spread; ordered by omega, kind, period. ``edges``: the indices e of the edges (between
    the e-th and (e+1)-th points in omega order) to look at; every edge by default."""
    omega = np.asarray(omega, float)
    order = np.argsort(omega, kind="stable")
    pairs = list(zip(order[:-1], order[1:]))
    out = []
    for a, b in (pairs if edges is None else [pairs[e] for e in sorted(edges)]):
        for c in crossings(per_point[a], per_point[b], level, searched):
            w = float(omega[a] + c["theta"] * (omega[b] - omega[a]))
            x = c["orbit"]["x0"]
            out.append(dict(kind=c["kind"], period=int(c["period"]), omega=w,
                            q0=float(x[0]), v0=float(x[1]),
                            min_q=float(c["min_q"]), max_q=float(c["max_q"]),
                            spread=float(c["spread"])))
    out.sort(key=lambda d: (d["omega"], BIFURCATION_KINDS[d["kind"]], d["period"]))
    return out


#: The stored variables the seeds are read from (with the lines' CROSSING_VARIABLES).
SEED_SOURCES = ("period", "status", "q0", "v0", "multipliers", "min_q", "max_q", "ptp")


def grid_orbits(ds: xr.Dataset) -> np.ndarray:
    """The stored converged orbits of a study's results, as an object array (omega, sigma,
    zeta) of lists of mappings (period, x0, min_q, max_q, ptp, multipliers), axes sorted."""
    ds = ds.sortby(list(AXES))
    get = {n: ds[n].transpose("omega", "sigma", "zeta", "solution", ...).values
           for n in SEED_SOURCES}
    shape = get["period"].shape[:3]
    out = np.empty(shape, object)
    ok = (get["status"] == st.CONVERGED) & (get["period"] > 0)
    for idx in np.ndindex(shape):
        out[idx] = [dict(period=int(get["period"][idx + (s,)]),
                         x0=(float(get["q0"][idx + (s,)]), float(get["v0"][idx + (s,)])),
                         min_q=float(get["min_q"][idx + (s,)]),
                         max_q=float(get["max_q"][idx + (s,)]),
                         ptp=float(get["ptp"][idx + (s,)]),
                         multipliers=get["multipliers"][idx + (s,)])
                    for s in np.nonzero(ok[idx])[0]]
    return out


def _stored_line_crossings(ds: xr.Dataset):
    """The ``crossing_*`` records of each line (sigma index, zeta index) of a results Dataset
    (axes sorted), and the set of (omega block, sigma index, zeta index) whose crossings were
    recorded (``crossing_count`` >= 0: a block whose time budget ran out has none); (None,
    empty set) when the store has none."""
    if "crossing_kind" not in ds:
        return None, set()
    order = ("omega_block", "sigma", "zeta", "crossing")
    get = {n: ds[f"crossing_{n}"].transpose(*order).values
           for n in ("kind", "period", "omega", "q0", "v0", "min_q", "max_q", "spread")}
    if "crossing_count" in ds:
        count = ds["crossing_count"].transpose(*order[:3]).values
        recorded = {tuple(int(i) for i in b) for b in np.argwhere(count >= 0)}
    else:
        recorded = {tuple(int(i) for i in b) for b in np.ndindex(get["kind"].shape[:3])}
    out: dict[tuple[int, int], list[dict]] = {}
    for b, j, k, slot in np.argwhere(get["kind"] > 0):
        d = {n: get[n][b, j, k, slot] for n in get}
        out.setdefault((int(j), int(k)), []).append(dict(
            kind=KIND_OF_CODE[int(d["kind"])], period=int(d["period"]), omega=float(d["omega"]),
            q0=float(d["q0"]), v0=float(d["v0"]), min_q=float(d["min_q"]),
            max_q=float(d["max_q"]), spread=float(d["spread"])))
    return out, recorded


def _omega_blocks(ds: xr.Dataset, n_omega: int) -> np.ndarray:
    """The omega chunk (task block) of each grid omega, in sorted order (one block when the
    store says nothing)."""
    c = ds.attrs.get("hertzmap_chunk_shape")
    size = int(c[0]) if c else n_omega
    # the store's chunks follow the study's omega order, which may be decreasing
    w = ds["omega"].values
    rank = np.argsort(np.argsort(w, kind="stable"), kind="stable")
    blocks = np.arange(n_omega) // max(size, 1)
    out = np.empty(n_omega, int)
    out[rank] = blocks
    return out


def curve_seeds(ds: xr.Dataset, level: float, periods=None) -> list[Seed]:
    """The seeds of every curve of a study (a results Dataset with the stored orbits and
    measures, and the lines' ``crossing_*`` records when stored), in a fixed order: for each
    swept plane (PLANES order), each value of its third parameter (increasing), the grid's
    lines of the plane's second parameter (increasing): the crossings along the line (by its
    first parameter), then those between it and the next line. Along omega inside a block the
    line's records are used (every orbit the line search found, stored or not), elsewhere the
    stored slots. ``level``: the contact-loss level (kernels.model.contact_loss_level);
    ``periods``: those the line search followed (the study's [search] periods)."""
    axes = {n: np.sort(np.asarray(ds[n].values, float)) for n in AXES}
    planes = swept_planes(axes)
    if not planes:
        return []
    srt = ds.sortby(list(AXES))
    orbits = grid_orbits(srt)
    lines, recorded = _stored_line_crossings(srt)
    blocks = _omega_blocks(ds, axes["omega"].size)
    seeds: list[Seed] = []

    def add(plane, fixed, params, x, hold, c):
        seeds.append(Seed(len(seeds), plane, float(fixed), c["kind"], int(c["period"]),
                          float(params["omega"]), float(params["sigma"]),
                          float(params["zeta"]), float(x[0]), float(x[1]), hold,
                          float(c["min_q"]), float(c["max_q"]), float(c["spread"])))

    for plane in planes:
        a_name, b_name = plane
        third = [n for n in AXES if n not in plane][0]
        ia, ib, ic = AXES.index(a_name), AXES.index(b_name), AXES.index(third)
        for kc, fixed in enumerate(axes[third]):
            for jb in range(axes[b_name].size):
                line = [0, 0, 0]
                line[ib], line[ic] = jb, kc
                # along the line (edges of the plane's first parameter), then to the next line
                for edge_axis, hold in ((ia, b_name), (ib, a_name)):
                    if edge_axis == ib and jb == axes[b_name].size - 1:
                        continue
                    found = _edge_crossings(orbits, axes, line, ia, edge_axis, blocks, recorded,
                                            lines, level, periods)
                    for _, _, period, c, params in found:
                        add(plane, fixed, params, c["orbit"]["x0"], hold, c)
    return seeds


def _edge_crossings(orbits, axes, line, ia, edge_axis, blocks, recorded, lines, level,
                    periods) -> list[tuple]:
    """The crossings on the grid cells of one line of a plane (``line``: the grid index of the
    line's other two parameters; ``ia``: the axis along it) whose edges run along
    ``edge_axis`` (the line's own axis, or to the next line), sorted by place, kind and
    period: (place, kind code, period, crossing, its parameters). Along omega inside a block
    whose line search recorded its crossings, those records stand for the stored slots."""
    edge_name = AXES[edge_axis]
    found = []
    for i0 in range(axes[AXES[ia]].size - (1 if edge_axis == ia else 0)):
        P = list(line)
        P[ia] = i0
        Q = list(P)
        Q[edge_axis] += 1
        P, Q = tuple(P), tuple(Q)
        if (edge_axis == 0 and blocks[P[0]] == blocks[Q[0]]
                and (int(blocks[P[0]]), P[1], P[2]) in recorded):
            continue        # from the line's own records, below
        for c in crossings(orbits[P], orbits[Q], level, periods):
            params = {n: axes[n][P[AXES.index(n)]] for n in AXES}
            params[edge_name] = (axes[edge_name][P[edge_axis]] + c["theta"]
                                 * (axes[edge_name][Q[edge_axis]] - axes[edge_name][P[edge_axis]]))
            found.append((params[edge_name], BIFURCATION_KINDS[c["kind"]], c["period"], c,
                          params))
    if edge_axis == 0 and lines is not None:
        j, k = line[1], line[2]
        for d in lines.get((j, k), []):
            params = {"omega": d["omega"], "sigma": axes["sigma"][j], "zeta": axes["zeta"][k]}
            found.append((d["omega"], BIFURCATION_KINDS[d["kind"]], d["period"],
                          dict(d, orbit={"x0": (d["q0"], d["v0"])}), params))
    found.sort(key=lambda t: t[:3])
    return found


def curve_kernels() -> list:
    """The numba entry points a trace calls (kernels._jit kernels): the extended system, its
    corrector and the period map (the T-shift of a 2T point). A study that asks for curves
    compiles them in its workers' warm-up, beside the grid's
    (study.solve.block.entry_kernels), not after the grid."""
    return [extended_system.curve_system_into, extended_system._chord_into,
            cont.period_map_into]


def trace_seed(seed: Seed, bounds: dict[str, tuple[float, float]], *,
               exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
               rtol: float = DEFAULT_RTOL, options: dict | None = None) -> dict:
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
                             bounds=bounds, exponent=exponent, model=model, rtol=rtol,
                             hold=seed.hold or None, **opts)
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


def _same_family(traced: dict, seed: Seed) -> bool:
    s = traced["seed"]
    return (tuple(s["plane"]) == tuple(seed.plane) and s["fixed"] == seed.fixed
            and s["kind"] == seed.kind and s["period"] == seed.period)


def _near_polyline(V: dict, plane, point: dict, steps: dict) -> tuple[np.ndarray, np.ndarray,
                                                                        np.ndarray]:
    """Distances (in grid steps) from ``point`` to each segment of the polyline of vertices
    ``V`` in ``plane``, the segments' start indices and the feet's places on them (0..1)."""
    a, b = plane
    scale = np.array([max(steps[a], 1e-300), max(steps[b], 1e-300)])
    P = np.column_stack([V[a], V[b]]) / scale
    p = np.array([point[a], point[b]]) / scale
    d = P[1:] - P[:-1]
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    th = np.clip(np.einsum("ij,ij->i", p - P[:-1], d) / dd, 0.0, 1.0)
    foot = P[:-1] + th[:, None] * d
    return np.hypot(*(foot - p).T), np.arange(len(d)), th


def _invariants_match(V: dict, i: np.ndarray, th: np.ndarray, min_q: float, max_q: float,
                      share: float, spread: float = 0.0) -> np.ndarray:
    """Whether the orbit interpolated at the feet (segments ``i``, places ``th``) has invariants
    (min q, max q) within ``share`` (1 + ptp) + ``spread`` of (min_q, max_q); true where either
    is unknown."""
    lo = V["min_q"][i] + th * (V["min_q"][i + 1] - V["min_q"][i])
    hi = V["max_q"][i] + th * (V["max_q"][i + 1] - V["max_q"][i])
    dist = np.abs(lo - min_q) + np.abs(hi - max_q)
    tol = share * (1.0 + abs(max_q - min_q)) + spread
    return ~(dist > tol)          # NaN (unknown invariants): no evidence against


def covers(traced: dict, seed: Seed, steps: dict[str, float], *, cells: float = COVER_CELLS,
           share: float = CONTINUITY_SHARE) -> bool:
    """True when ``seed`` lies on the curve ``traced`` (a :func:`trace_seed` result, or a stored
    part read back): same plane, third parameter, kind and period; the curve's polyline within
    ``cells`` grid steps (``steps``: {param: step} of the plane) of the seed's crossing, with
    the orbit there (interpolated between the vertices) matching the seed's by the continuity
    rule (invariants min q, max q within ``share`` (1 + ptp), plus the seed's spread)."""
    if not _same_family(traced, seed):
        return False
    V = traced["vertices"]
    if len(V.get("omega", ())) < 2:
        return False
    dist, i, th = _near_polyline(V, seed.plane, seed.params(), steps)
    near = dist <= cells
    if not near.any():
        return False
    return bool(np.any(_invariants_match(V, i[near], th[near], seed.min_q, seed.max_q, share,
                                         seed.spread)))


def start_vertex(result: dict) -> dict | None:
    """The corrected start of a trace (its vertex flagged ``seed``): parameters and invariants,
    or None for a failed trace."""
    V = result["vertices"]
    flags = np.asarray(V.get("flag", ()), float).astype(int)
    k = np.nonzero(flags & cont.VERTEX_SEED)[0]
    if k.size == 0:
        return None
    k = int(k[0])
    return {n: float(V[n][k]) for n in ("omega", "sigma", "zeta", "min_q", "max_q")}


def start_seed(result: dict) -> Seed | None:
    """The corrected start of a trace as a seed (its parameters and invariants there), or None
    for a failed trace."""
    v = start_vertex(result)
    if v is None:
        return None
    return Seed(**dict(result["seed"], plane=tuple(result["seed"]["plane"]),
                       min_q=v["min_q"], max_q=v["max_q"], spread=0.0,
                       **{n: v[n] for n in AXES}))


def near_failure(failed: Seed, seed: Seed, steps: dict[str, float]) -> bool:
    """True when ``seed`` is of the same family as the seed ``failed`` (whose trace did not
    start), within FAILED_CELLS grid steps of it, with invariants within the continuity rule's
    share: it is not tried again."""
    if (tuple(failed.plane) != tuple(seed.plane) or failed.fixed != seed.fixed
            or failed.kind != seed.kind or failed.period != seed.period):
        return False
    a, b = seed.plane
    pf, ps = failed.params(), seed.params()
    d = math.hypot((pf[a] - ps[a]) / steps[a], (pf[b] - ps[b]) / steps[b])
    if d > FAILED_CELLS:
        return False
    inv = abs(failed.min_q - seed.min_q) + abs(failed.max_q - seed.max_q)
    return not inv > (CONTINUITY_SHARE * (1.0 + abs(seed.max_q - seed.min_q)) + failed.spread
                      + seed.spread)


class SeedBook:
    """The curve stage's decisions, in seed order, and its completeness check (pure: the
    scheduler ships the traces and commits them through it; tests drive it directly).

    Seeds are decided one by one in their order: a seed is **skipped** when it lies on a curve
    kept so far (:func:`covers`) or near an earlier seed whose trace did not cover it
    (:func:`near_failure`: a failed start, a duplicate or a trace that went elsewhere); else its
    trace is **committed** (:meth:`commit`): kept as a curve, kept as a failed start (no
    vertices), or -- when its start lies on a curve kept from an earlier seed -- recorded as a
    duplicate of that seed (no vertices). The decisions depend on the seeds and the traces only,
    never on which trace finished first; a resumed run replays its committed traces through
    :meth:`commit` and decides the same."""

    def __init__(self, seeds: list[Seed], axes: dict[str, np.ndarray]):
        self.seeds = seeds
        self.steps = {plane: grid_steps(axes, plane) for plane in swept_planes(axes)}
        self.records: dict[int, dict] = {}      # seed index -> its committed trace
        self.kept: list[int] = []               # seeds whose trace is a curve, in order
        self.untraced: list[int] = []           # seeds tried whose trace did not cover them
        self._checked: dict[int, tuple[int, int]] = {}   # skip's memo: (kept, untraced) seen

    @staticmethod
    def family(seed: Seed) -> tuple:
        """Seeds of one family (plane, third parameter, kind, period) may lie on one curve."""
        return (tuple(seed.plane), seed.fixed, seed.kind, seed.period)

    def _steps(self, seed: Seed) -> dict[str, float]:
        return self.steps[tuple(seed.plane)]

    def covering(self, seed: Seed, start: int = 0) -> int:
        """The first kept curve (as the index of its seed; from the ``start``-th kept) that
        covers ``seed``, or -1."""
        steps = self._steps(seed)
        for i in self.kept[start:]:
            if covers(self.records[i], seed, steps):
                return i
        return -1

    def near_untraced(self, seed: Seed, start: int = 0) -> int:
        """The first seed before ``seed`` (from the ``start``-th untraced) tried without
        covering itself and near it (same family), or -1."""
        steps = self._steps(seed)
        for i in self.untraced[start:]:
            if i < seed.index and near_failure(self.seeds[i], seed, steps):
                return i
        return -1

    def skip(self, index: int) -> bool:
        """True when seed ``index`` needs no trace (given the commits so far). Memoised: the
        kept curves and the untraced seeds only grow, so a seed is checked against each once
        (the scheduler asks about every undecided seed after each commit)."""
        seed = self.seeds[index]
        k0, u0 = self._checked.get(index, (0, 0))
        if k0 < 0:
            return True
        hit = self.covering(seed, k0) >= 0 or self.near_untraced(seed, u0) >= 0
        self._checked[index] = (-1, -1) if hit else (len(self.kept), len(self.untraced))
        return hit

    def may_cover(self, trace: dict, seed: Seed) -> bool:
        """Whether a trace not committed yet (an earlier seed's of the same family, finished
        and waiting for its turn) would make ``seed`` skipped once committed: it covers
        it, or did not cover its own seed and is near it. The stage ships ``seed`` ahead of its
        turn only if not: a seed of a family whose trace went elsewhere lies on another
        curve, and is traced beside it instead of after it."""
        own = self.seeds[int(trace["seed"]["index"])]
        steps = self._steps(seed)
        if covers(trace, seed, steps):
            return True
        return not covers(trace, own, steps) and near_failure(own, seed, steps)

    def duplicate_of(self, trace: dict) -> int:
        """The seed of a kept curve that ``trace`` started on (a duplicate), or -1."""
        if len(trace["vertices"].get("omega", ())) < 2:
            return -1
        start = start_seed(trace)
        if start is None:
            return -1
        steps = self._steps(start)
        for i in self.kept:
            if covers(self.records[i], start, steps, cells=LANDS_CELLS, share=LANDS_SHARE):
                return i
        return -1

    def commit(self, trace: dict, duplicate_of: int | None = None) -> int:
        """Record the trace of its seed (the next undecided one in order). ``duplicate_of``:
        as stored (a resumed commit), else decided here. Returns it (-1: not a duplicate)."""
        index = int(trace["seed"]["index"])
        seed = self.seeds[index]
        if duplicate_of is None:
            duplicate_of = self.duplicate_of(trace)
        trace = dict(trace, duplicate_of=int(duplicate_of))
        self.records[index] = trace
        if duplicate_of < 0 and len(trace["vertices"].get("omega", ())) >= 2:
            self.kept.append(index)
            if not covers(trace, seed, self._steps(seed)):
                self.untraced.append(index)
        else:
            self.untraced.append(index)
        return int(duplicate_of)

    def curve_ids(self) -> dict[int, int]:
        """Seed index -> curve id (position in dim ``curve``: the committed traces that are not
        duplicates, in seed order)."""
        ids = [i for i in sorted(self.records) if self.records[i]["duplicate_of"] < 0]
        return {i: c for c, i in enumerate(ids)}

    def outcomes(self) -> list[dict]:
        """Every seed with the curve covering it and what became of it (the completeness
        check; products/traced_curves ``seed_*``): dicts kind, period, plane, fixed, omega,
        sigma, zeta (the seed's crossing), curve (the covering curve's id, -1 none), outcome
        (traced, covered, start_fail, on_earlier_curve, off_seed, near_untraced), ref (a curve
        id or a seed index, as the outcome says)."""
        ids = self.curve_ids()
        out = []
        for s in self.seeds:
            own = self.records.get(s.index)
            cover = self.covering(s)
            curve, ref = (ids[cover] if cover >= 0 else -1), -1
            if own is not None and s.index in self.kept and covers(own, s, self._steps(s)):
                outcome, curve = "traced", ids[s.index]
            elif cover >= 0:
                outcome = "covered"
            elif own is not None and own["duplicate_of"] >= 0:
                outcome, ref = "on_earlier_curve", ids[own["duplicate_of"]]
            elif own is not None and s.index in self.kept:
                outcome, ref = "off_seed", ids[s.index]
            elif own is not None:
                outcome, ref = "start_fail", ids[s.index]
            else:
                outcome, ref = "near_untraced", self.near_untraced(s)
            p = s.params()
            out.append(dict(kind=s.kind, period=s.period, plane=tuple(s.plane), fixed=s.fixed,
                            omega=p["omega"], sigma=p["sigma"], zeta=p["zeta"], curve=curve,
                            outcome=outcome, ref=ref))
        return out
