"""Fold, flip and grazing curves in any two of (omega, sigma, zeta) (paper section 3.2, Fig. 7-10;
the study's "curves" output): ``trace_curve``.

A curve is the solution set of its extended system (kernels.continuation.extended_system:
Phi_{mT}(x) - x = 0 and the fold, flip (of the period-m monodromy: m = 2 gives the 2T -> 4T
flips) or grazing test function g = 0, exact M and forward differences, chord corrector: ~9-16
period maps a vertex), followed by the core's pseudo-arclength step (kernels.continuation.core)
both ways to the window's edge, through turning points and contact loss. On the way the sign
changes of the other two test functions (codimension-2 points, with the values on both sides),
the cusps of fold curves and the extrema of each parameter are located (kernels.continuation.
codim2) and inserted as vertices; a 2T curve that reaches the 1T orbit ends there,
extrapolated onto it (where the isola's fold curve meets the 1T flip curve). Every loop is
bounded; a failure is a status, never an exception. Dimensionless (paper Eq. 7 / 11).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from hertzmap.kernels.records import VERTEX
from hertzmap.kernels.continuation.codim2 import (Codim2Point, end_on_1t_orbit,
                                                  locate_extremum, locate_zero)
from hertzmap.kernels.continuation.core import (BOUNDARY, BRANCH_POINT, BRANCH_STATUS, CLOSED,
                                                MAX_POINTS, START_FAIL, STEP_FAIL, adapt_step,
                                                flip_function, floquet_multipliers, null_vector,
                                                predict_correct, tangent)
from hertzmap.kernels.continuation.extended_system import (CURVE_KINDS, CURVE_PARAMS,
                                                           CurveSystem, chord_correct)
from hertzmap.kernels.model import DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL
from hertzmap.kernels.periodic_orbit import DEFAULT_MAX_STEPS, shoot

#: vertex flags (bit mask): why a vertex is where it is
VERTEX_SEED = 1          # the corrected start point of the trace
VERTEX_EXTREMUM = 2      # a turning point of a parameter along the curve (refined: dp/ds = 0)
VERTEX_EDGE = 4          # on the window's edge (the curve leaves there)
VERTEX_END = 8           # the extrapolated end where a 2T curve meets the 1T orbit
VERTEX_CODIM2 = 16       # a located codimension-2 point (also in Curve.codim2)
VERTEX_FLAGS = ((VERTEX_SEED, "seed"), (VERTEX_EXTREMUM, "parameter_extremum"),
                (VERTEX_EDGE, "window_edge"), (VERTEX_END, "meets_1T_orbit"),
                (VERTEX_CODIM2, "codim2_point"))

# A 2T curve this close to the 1T orbit (|Phi_T(x) - x| / (1 + |x|)) ends there: the extended
# system's smallest singular value falls like |Phi_T(x) - x|^2 towards the 1T orbit (1.5e-4 at
# 0.05 on the isola's fold curve, zeta 0.01), and the end point is extrapolated from the
# vertices further out (codim2.end_on_1t_orbit)
MEET_1T_ASYM = 3e-2

#: a vertex's fields, from the vertex record (kernels.records.VERTEX)
VERTEX_FIELDS = VERTEX.columns


@dataclass
class Curve:
    """A traced fold / flip / grazing curve in the (pair[0], pair[1]) plane, the third parameter
    at ``fixed``. ``vertices``: VERTEX_FIELDS -> 1-D arrays in order along the curve (the
    backward half reversed, then the forward half); ``status``: (backward, forward) end codes
    (BRANCH_STATUS; CLOSED on both for a closed curve); ``maps``: period maps integrated."""

    kind: str
    period: int
    pair: tuple
    fixed: float
    status: tuple = (START_FAIL, START_FAIL)
    vertices: dict = field(default_factory=dict)
    codim2: list = field(default_factory=list)
    maps: int = 0
    seconds: float = 0.0

    def __len__(self):
        return len(self.vertices.get("omega", ()))

    @property
    def status_names(self):
        return tuple(BRANCH_STATUS[s] for s in self.status)


class _Tracer:
    """Traces one curve from a start point both ways (see :func:`trace_curve`)."""

    def __init__(self, system, bounds, ds, ds_min, ds_max, dp_frac, max_points):
        self.sys = system
        self.lo = np.array([bounds[0][0], bounds[1][0]], float)
        self.hi = np.array([bounds[0][1], bounds[1][1]], float)
        self.dp_max = dp_frac * np.maximum(self.hi - self.lo, 1e-9)
        self.ds, self.ds_min, self.ds_max = float(ds), float(ds_min), float(ds_max)
        self.max_points = int(max_points)
        self.m = system.m
        self.kind = CURVE_KINDS[system.kind_code]
        self.others = [k for k in ("fold", "flip", "grazing") if k != self.kind]
        self._phases = None

    # -- one vertex ----------------------------------------------------------------------------
    def record(self, u, F, aux, step, iterations, flag):
        tr = aux[0] + aux[3]
        det = aux[0] * aux[3] - aux[1] * aux[2]
        w, s, z = self.sys.params(u)
        rec = dict(omega=w, sigma=s, zeta=z, q0=u[0], v0=u[1], m11=aux[0], m12=aux[1],
                   m21=aux[2], m22=aux[3], min_q=aux[4], max_q=aux[6], fold=1.0 - tr + det,
                   flip=1.0 + tr + det, grazing=aux[4] - self.sys.level, asym=np.nan,
                   step=step, residual=float(np.max(np.abs(F))), iterations=iterations,
                   arclength=np.nan, flag=flag)
        if self.m == 2:
            half = self.sys.shift(u)
            if half is not None:
                rec["asym"] = float(np.hypot(*(half - u[:2])))
                rec["_shift"] = half - u[:2]
        return rec

    def multipliers(self, rec):
        M = np.array([[rec["m11"], rec["m12"]], [rec["m21"], rec["m22"]]])
        mu = floquet_multipliers(M)
        return mu[np.argsort(-np.abs(mu))]

    def to_edge(self, u_prev, u_new, J):
        """The point where the curve leaves the window between two vertices: corrected onto
        the edge it crosses first (the edge's parameter held at the bound). None on failure."""
        c = u_new - u_prev
        best = None
        for j in range(2):
            for bound in (self.lo[j], self.hi[j]):
                a, b = u_prev[2 + j] - bound, u_new[2 + j] - bound
                if a * b < 0.0 or (b == 0.0 and a != 0.0):
                    th = a / (a - b)
                    if best is None or th < best[0]:
                        best = (th, j, bound)
        if best is None:
            return None
        th, j, bound = best
        guess = u_prev + th * c
        guess[2 + j] = bound
        normal = np.zeros(4)
        normal[2 + j] = 1.0
        r = chord_correct(self.sys, guess, normal, J=J)
        if r is None:
            r = chord_correct(self.sys, guess, normal)
        return r

    def phases(self, u0) -> list:
        """The start orbit's other phases, Phi_{kT}(x0) for k = 1 .. m - 1 at the start's
        parameters (the T-shift of a 2T start point, ...): each is the start point of the same
        orbit seen from tau = kT, on another copy of the curve (it solves the same extended
        system); a side that reaches one has gone round the whole curve in the parameters and
        would go round it again, up to m times, so it ends there, closed. Computed once per
        start (m - 1 period maps; for m = 2 the T-shift the 2T start already has)."""
        if self._phases is None:
            self._phases = []
            x = np.array(u0, float)
            for _ in range(1, self.m):
                y = self.sys.shift(x)
                if y is None:
                    break
                self._phases.append(y)
                x = np.array([y[0], y[1], u0[2], u0[3]])
        return self._phases

    def inside(self, u):
        return bool(np.all(u[2:] >= self.lo) and np.all(u[2:] <= self.hi))

    # -- one direction -------------------------------------------------------------------------
    def side(self, u0, t0, J0, rec0):
        """Vertices (records) from the start point (excluded) along t0, the codimension-2 points
        met, and the end status."""
        recs, us, special = [], [], []
        u, t, J, prev = u0, t0, J0, rec0
        h = self.ds
        s_total = 0.0
        status = MAX_POINTS
        start_targets = [u0[:2]] + self.phases(u0)
        while len(recs) < self.max_points:
            tp = np.abs(t[2:])
            cap = np.min(np.where(tp > 0, self.dp_max / np.maximum(tp, 1e-300), np.inf))
            if self.m == 2 and np.isfinite(prev.get("asym", np.nan)):
                # steps no longer than a fifth of the distance to the 1T orbit: a 2T curve
                # that ends there leaves ~10 vertices at asym 0.03..0.3 for the extrapolation
                cap = min(cap, 0.2 * prev["asym"])
            h = max(self.ds_min, min(h, cap, self.ds_max))
            # the Jacobian is built at each prediction (the last vertex's, Broyden-updated, saved
            # 4 maps a vertex but took 6-12 corrections each and lost the isola's fold curve)
            step, tn, h = predict_correct(
                lambda u_pred, normal: chord_correct(self.sys, u_pred, normal), u, t, h, self.ds_min)
            if step is None:
                status = STEP_FAIL
                if self.m == 2 and len(recs) >= 3:
                    asym = [r["asym"] for r in [rec0] + recs]
                    if np.isfinite(asym[-1]) and asym[-1] <= 0.05 * np.nanmax(asym):
                        status = BRANCH_POINT      # stuck next to the 1T orbit
                break
            un, Fn, auxn, Jn, it = step
            dist = float(np.linalg.norm(un - u))
            rec = self.record(un, Fn, auxn, dist, it, 0)
            # a 2T curve that reaches the 1T orbit (or crosses it: x - Phi_T(x) turns over)
            if self.m == 2 and "_shift" in rec and "_shift" in prev:
                a, b = prev["_shift"], rec["_shift"]
                crossed = (a @ b) < -0.5 * np.linalg.norm(a) * np.linalg.norm(b)
                scale = 1.0 + np.hypot(*un[:2])
                if crossed or rec["asym"] <= MEET_1T_ASYM * scale:
                    if not crossed:
                        recs.append(rec)
                        us.append(un)
                        s_total += dist
                    status = BRANCH_POINT
                    break
            edge = None
            if not self.inside(un):
                edge = self.to_edge(u, un, Jn)
                if edge is None:
                    status = BOUNDARY
                    break
                un, Fn, auxn, Jn, it = edge
                dist = float(np.linalg.norm(un - u))
                rec = self.record(un, Fn, auxn, dist, it, VERTEX_EDGE)
            inserts = self.specials(u, un, prev, rec, Jn, special)
            for th, r_ins, u_ins in sorted(inserts, key=lambda z: z[0]):
                r_ins["step"] = float(np.linalg.norm(u_ins - (us[-1] if us else u)))
                recs.append(r_ins)
                us.append(u_ins)
            s_total += dist
            recs.append(rec)
            us.append(un)
            if edge is not None:
                status = BOUNDARY
                break
            # back at the start (or its T-shift): a closed curve
            if s_total > 3.0 * h and len(recs) > 3:
                closed = False
                for target in start_targets:
                    d = np.hypot(*(un[:2] - target)) + np.hypot(*(un[2:] - u0[2:]))
                    if d <= 0.75 * h and s_total > 4.0 * d:
                        closed = True
                if closed:
                    status = CLOSED
                    break
            u, t, J, prev = un, tn, Jn, rec
            # the chord corrector takes 3-4 iterations on an easy step (its Jacobian is the
            # predicted point's): grow then, shrink when it needs many more
            h = adapt_step(h, it, self.ds_max, h_min=self.ds_min, easy=4, hard=7)
        return recs, us, special, status

    def specials(self, ua, ub, ra, rb, Jb, special):
        """Codimension-2 points between two consecutive vertices (sign changes of the other two
        test functions): located, recorded in ``special`` and returned as vertices to insert
        (fraction along the chord, record, u)."""
        out = []
        chord = ub - ua
        # the other test functions: a sign change is a codimension-2 point
        for other in self.others:
            ga, gb = ra[other], rb[other]
            if not (np.isfinite(ga) and np.isfinite(gb)) or ga * gb > 0.0:
                continue
            names = sorted((self.kind, other), key=("fold", "flip", "grazing").index)
            name = "_".join(names)
            idx = {"fold": 0, "flip": 1, "grazing": 2}[other]

            def g_other(u, F, aux, J, idx=idx):
                tr = aux[0] + aux[3]
                det = aux[0] * aux[3] - aux[1] * aux[2]
                return (1.0 - tr + det, 1.0 + tr + det, aux[4] - self.sys.level)[idx]
            loc = locate_zero(self.sys, ua, ub, ga, gb, g_other, J=Jb)
            if loc is None:
                continue
            u, F, aux, _, g, width = loc
            rec = self.record(u, F, aux, np.nan, 0, VERTEX_CODIM2)
            th = float((u - ua) @ chord / (chord @ chord))
            rec["_codim2"] = Codim2Point(name, self.m, rec["omega"], rec["sigma"], rec["zeta"],
                                         u[:2].copy(), self.multipliers(rec), float(g),
                                         float(ga), float(gb), float(width))
            special.append(rec["_codim2"])
            out.append((th, rec, u))
        return out

    def turning_points(self, recs, us):
        """The curve's parameter extrema and (fold curves) cusps, refined and inserted as
        vertices: a post-pass over the assembled curve. An extremum of a parameter lies where
        its values at three consecutive vertices k-1, k, k+1 turn (p_k above or below both):
        it is located as the extremum of that parameter over the curve between k-1 and k+1,
        not as a zero of the tangent (the tangent comes from a difference Jacobian ~1e-4 off:
        that moved sigma** by 1e-6, and the tangent's sign change by two vertices, where the
        extremal value itself is exact to the integrator's accuracy). On a fold curve, a cusp
        is where the parameter increments reverse ((p_k - p_k-1) . (p_k+1 - p_k) < 0) and
        the curve's tangent has no parameter component left at the extremum of p . d (d the
        direction before it). Returns the new (recs, us)."""
        inserts = []            # (k, after k?, record, u)
        n = len(recs)
        P = np.array([[r[CURVE_PARAMS[self.sys.pa]], r[CURVE_PARAMS[self.sys.pb]]] for r in recs])
        for k in range(1, n - 1):
            if any(recs[i]["flag"] & (VERTEX_EDGE | VERTEX_END) for i in (k - 1, k, k + 1)):
                continue
            d1, d2 = P[k] - P[k - 1], P[k + 1] - P[k]
            ua, uk, ub = us[k - 1], us[k], us[k + 1]
            cusp = self.kind == "fold" and d1 @ d2 < 0.0
            todo = []
            if cusp:
                todo.append(("cusp", d1 / np.linalg.norm(d1), True))
            else:
                for j in range(2):
                    if d1[j] * d2[j] < 0.0:
                        e = np.zeros(2)
                        e[j] = 1.0
                        todo.append(("extremum", e, d1[j] > 0.0))
            if not todo:
                continue
            r = self.sys(uk, True)
            if r is None:
                continue
            J = r[1]
            for what, d, maximum in todo:
                loc = locate_extremum(self.sys, ua, ub, J, d, maximum)
                if loc is None:
                    continue
                u, F, aux = loc
                after = bool((u - uk) @ (ub - ua) > 0.0)
                if what == "extremum":
                    inserts.append((k, after, self.record(u, F, aux, np.nan, 0, VERTEX_EXTREMUM),
                                    u))
                    continue
                rj = self.sys(u, True)
                t = tangent(rj[1], (ub - ua) / np.linalg.norm(ub - ua)) if rj is not None \
                    else None
                if t is None or np.linalg.norm(t[2:]) > 1e-2:
                    continue                    # a sharp smooth turn, not a cusp
                rec = self.record(u, F, aux, np.nan, 0, VERTEX_CODIM2 | VERTEX_EXTREMUM)
                rec["_codim2"] = Codim2Point("cusp", self.m, rec["omega"], rec["sigma"],
                                             rec["zeta"], u[:2].copy(), self.multipliers(rec),
                                             float(t[2:] @ d), float(d1 @ d), float(d2 @ d),
                                             1e-9 * float(np.linalg.norm(P[k + 1] - P[k - 1])))
                inserts.append((k, after, rec, u))
        if not inserts:
            return recs, us
        out_r, out_u = [], []
        by_k = {}
        for k, after, rec, u in inserts:
            by_k.setdefault(k, []).append((after, rec, u))
        for k in range(n):
            before = [(r_, u_) for a, r_, u_ in by_k.get(k, []) if not a]
            later = [(r_, u_) for a, r_, u_ in by_k.get(k, []) if a]
            for r_, u_ in before:
                out_r.append(r_)
                out_u.append(u_)
            out_r.append(recs[k])
            out_u.append(us[k])
            for r_, u_ in later:
                out_r.append(r_)
                out_u.append(u_)
        return out_r, out_u


def trace_curve(x0, omega, sigma, zeta, *, kind, period=1, pair=("omega", "sigma"),
                bounds=None, exponent=DEFAULT_EXPONENT, model=DEFAULT_LAW, rtol=DEFAULT_RTOL,
                max_steps=DEFAULT_MAX_STEPS, ds=0.01, ds_min=1e-7, ds_max=0.2,
                dp_frac=0.01, max_points=1500, both_ways=True, direction=1.0,
                hold=None) -> Curve:
    """Trace the ``kind`` curve ("fold", "flip" or "grazing") of period-``period`` orbits in the
    plane of ``pair`` (two of "omega", "sigma", "zeta"; the third held at its given value) from
    a point near it: the orbit through x0 = (q, q') at (omega, sigma, zeta).

    The start is corrected onto the curve with ``hold`` held (default pair[1]; then, failing
    that, the other parameter of the pair: a start between two grid points of a line of
    ``hold``'s value is corrected along that line); the
    curve is followed both ways (``both_ways``; else along increasing pair[1] for direction
    +1) until it leaves ``bounds`` ({param: (lo, hi)} for the pair; the last vertex is put on
    the edge), closes, ends on the 1T orbit (a 2T curve: its end is extrapolated), or fails.
    Vertices are at most ``dp_frac`` of the window apart in each parameter. Along the way the
    sign changes of the other two test functions (codimension-2 points), the cusps of fold
    curves and the extrema of each parameter are located and inserted as vertices.
    Every loop is bounded; a failure is a status, never an exception. Dimensionless (paper
    Eq. 7 / 11); returns a :class:`Curve`.
    """
    t_start = time.perf_counter()
    pair = tuple(pair)
    if len(pair) != 2 or pair[0] == pair[1] or any(p not in CURVE_PARAMS for p in pair):
        raise ValueError(f"pair must be two distinct names of {CURVE_PARAMS}, got {pair!r}")
    if kind not in CURVE_KINDS:
        raise ValueError(f"kind must be one of {CURVE_KINDS}, got {kind!r}")
    p0 = {"omega": float(omega), "sigma": float(sigma), "zeta": float(zeta)}
    fixed_name = [p for p in CURVE_PARAMS if p not in pair][0]
    default = {"omega": (1e-3, 10.0), "sigma": (0.0, 10.0), "zeta": (0.0, 10.0)}
    bounds = dict(bounds or {})
    bnd = (tuple(bounds.get(pair[0], default[pair[0]])), tuple(bounds.get(pair[1], default[pair[1]])))
    system = CurveSystem(kind, period, pair, p0[fixed_name], exponent, model, rtol, max_steps)
    curve = Curve(kind=kind, period=int(period), pair=pair, fixed=p0[fixed_name])
    tracer = _Tracer(system, bnd, ds, ds_min, ds_max, dp_frac, max_points)
    u0 = np.array([x0[0], x0[1], p0[pair[0]], p0[pair[1]]], float)
    start = None
    if hold is not None and hold not in pair:
        raise ValueError(f"hold must be one of {pair!r}, got {hold!r}")
    for held in ((2, 3) if hold == pair[0] else (3, 2)):
        normal = np.zeros(4)
        normal[held] = 1.0
        start = chord_correct(system, u0, normal, max_iter=30)
        if start is not None:
            break
    if start is None:
        curve.maps = system.maps
        curve.seconds = time.perf_counter() - t_start
        return curve
    u, F, aux, J, it = start
    r = system(u, True)
    if r is not None:
        J = r[1]
    t = null_vector(J)
    if (t[3] if abs(t[3]) > 1e-12 else t[2]) * direction < 0:
        t = -t
    rec0 = tracer.record(u, F, aux, 0.0, it, VERTEX_SEED)
    fwd, fus, fsp, fst = tracer.side(u, t, J, rec0)
    if fst == CLOSED or not both_ways:
        bwd, bus, bsp, bst = [], [], [], fst if fst == CLOSED else START_FAIL
    else:
        bwd, bus, bsp, bst = tracer.side(u, -t, J, rec0)
    recs, us = tracer.turning_points(bwd[::-1] + [rec0] + fwd, bus[::-1] + [u] + fus)
    ends = []
    for side_recs, side_us, side_status, at_start in ((bwd, bus, bst, True),
                                                      (fwd, fus, fst, False)):
        if side_status != BRANCH_POINT or period != 2:
            continue
        ex = end_on_1t_orbit([rec0] + side_recs, [u] + side_us)
        if ex is None:
            continue
        ue, spread = ex
        ends.append((at_start, ue, spread))
    for at_start, ue, spread in ends:
        w, s_, z = system.params(ue)
        o = shoot(w, s_, z, 1, (ue[0], ue[1]), exponent=system.n, model=model, rtol=rtol,
                  max_iter=20, max_steps=max_steps)
        last = recs[0] if at_start else recs[-1]
        o_last = shoot(last["omega"], last["sigma"], last["zeta"], 1, (ue[0], ue[1]),
                       exponent=system.n, model=model, rtol=rtol, max_iter=20,
                       max_steps=max_steps)
        system.maps += o.newton_iterations + o_last.newton_iterations + 2
        g_end = flip_function(o.monodromy) if o.converged else np.nan
        g_last = flip_function(o_last.monodromy) if o_last.converged else np.nan
        # the 2T fold curve ends on the 1T flip curve where the flip is degenerate (the 2T
        # branch born there turns back at once); a 2T grazing curve ends where the 1T flip
        # curve meets the 1T grazing curve
        other = {"fold": "fold_flip", "grazing": "flip_grazing"}.get(kind, "fold_flip")
        x_end = o.x0 if o.converged else ue[:2]
        M = o.monodromy if o.converged else np.full((2, 2), np.nan)
        M2 = M @ M          # the end vertex is the 1T orbit: its monodromy over 2T is M^2
        tr2, det2 = np.trace(M2), np.linalg.det(M2)
        pt = Codim2Point(other, int(period), w, s_, z, np.array(x_end, float),
                         o.multipliers if o.converged else np.full(2, np.nan, complex),
                         float(g_end), float(g_last), np.nan, float(spread))
        rec = dict(omega=w, sigma=s_, zeta=z, q0=x_end[0], v0=x_end[1], m11=M2[0, 0],
                   m12=M2[0, 1], m21=M2[1, 0], m22=M2[1, 1],
                   min_q=o.min_q if o.converged else np.nan,
                   max_q=o.max_q if o.converged else np.nan, fold=1.0 - tr2 + det2,
                   flip=1.0 + tr2 + det2,
                   grazing=(o.min_q - system.level) if o.converged else np.nan, asym=0.0,
                   step=np.nan, residual=o.residual, iterations=o.newton_iterations,
                   arclength=np.nan, flag=VERTEX_END | VERTEX_CODIM2, _codim2=pt)
        recs = [rec] + recs if at_start else recs + [rec]
    vert = {k: np.asarray([r[k] for r in recs], float) for k in VERTEX_FIELDS}
    codim2 = []
    for i, r in enumerate(recs):
        if "_codim2" in r:
            r["_codim2"].vertex = i
            codim2.append(r["_codim2"])
    # step and arclength along the final vertex list, in (q, q', a, b)
    pts = np.column_stack([vert["q0"], vert["v0"], vert[pair[0]], vert[pair[1]]])
    d = np.r_[0.0, np.linalg.norm(np.diff(pts, axis=0), axis=1)]
    vert["step"] = d
    vert["arclength"] = np.cumsum(d)
    curve.vertices = vert
    curve.codim2 = codim2
    curve.status = (bst, fst)
    curve.maps = system.maps
    curve.seconds = time.perf_counter() - t_start
    return curve
