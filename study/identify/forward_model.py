"""The fit's forward model: what the model's stepped sweeps read at every measured frequency.

Paper Eq. 7 is dimensionless: omega = f / f0, sigma = force amplitude / N, and the transmitted
force's harmonics in N are N times the dimensionless contact force's (F/N) at omega (H1),
2 omega (H2) and omega / 2 (H1/2). So f0 only stretches the frequency axis: one model sweep up
and one down over a fine omega grid, at one (sigma, zeta) and contact exponent n, gives the
model at every measured frequency f for every f0, read at omega = f / f0.

The sweeps are study.solve.sweep.stepped_sweep's quasi-static sweeps (``follow_first``: a rig
that waits at every step until the response has settled): each step on the followed branch
by Newton shooting, a transient only where the branch ends, the jumps located by shooting to
JUMP_TOL. A measured point is compared with the branch the model's sweep is on at its
frequency in its direction (:meth:`ForwardModel.at`): within a branch's run of steps the
harmonics are interpolated linearly in omega; across a jump, a point before the jump's
location reads the branch left (its last step and the followed orbit at the jump's attracting
end, JUMP_TOL from it), a point after it the branch landed on (extrapolated back from its
first steps over less than a step, floored at 0).

Measured (benchmarks/identify_fit_time.py): at sigma 0.3, zeta 0.005 a step on a branch costs
~0.2 ms (two shots) against ~4 ms with a transient of ~500 forcing periods, so a pair of
sweeps of 617 steps each takes ~0.4 s of CPU; with FORWARD_STEP 0.0025 the readings at the
worked example's 400 frequencies are within 2.8e-3 of H1 of a model 5 times finer (7.4e-3 at
0.005, 3.8e-2 at 0.01: ``--resolution``).

Steps the kernels' records do not give the three harmonics of directly: an orbit of period
m > 2 (its stored harmonics stop at 4 omega / m) reads them over 2 m forcing periods of its
history (:func:`window_harmonics`), exactly; a step whose transient did not settle (just past a
flip or a fold, where the response approaches the new branch over thousands of periods) is
first shot from where its transient ended (the orbit it was approaching, when stable), else
read over WINDOW_PERIODS periods from there.

Pure: numpy and the kernels' Python API. No I/O, no Dask.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from hertzmap.kernels import api
from hertzmap.kernels import continuation as cont
from hertzmap.kernels.model import DEFAULT_LAW, DEFAULT_RTOL
from hertzmap.study.solve.sweep_runs import JUMP_KIND_CODES
from hertzmap.study.solve.sweep import stepped_sweep

__all__ = ["FORWARD_STEP", "JUMP_TOL", "REFINE", "SETTLE_PERIODS", "WINDOW_PERIODS", "SAMPLES",
           "ModelSweep", "ForwardModel", "forward_model", "window_harmonics", "omega_grid"]

#: the step of the model's sweeps in omega (module docstring: its interpolation error)
FORWARD_STEP = 0.0025
#: each model jump is located to this width in omega (about 3 mHz on the paper's rig)
JUMP_TOL = 1e-5
#: forcing periods a landing step's transient may take to settle (the sweeps output's default)
SETTLE_PERIODS = 4000
#: forcing periods a non-periodic response's harmonics are read over
WINDOW_PERIODS = 64
#: nodes added on each side of a jump, at 1/2, 1/4, ... of the last step (_refined)
REFINE = 5
#: samples per forcing period of a history the harmonics are integrated from (trapezoid rule
#: over whole periods: spectrally accurate on the smooth pieces; the force is C1 at contact
#: loss for n = 3/2)
SAMPLES = 256


def omega_grid(lo: float, hi: float, step: float = FORWARD_STEP) -> np.ndarray:
    """The model sweeps' omega values: ``step`` apart, from ``lo`` down to a multiple of the
    step through ``hi`` up to one (the same grid for every (sigma, zeta) of a fit)."""
    a = math.floor(lo / step)
    b = math.ceil(hi / step)
    return np.round(np.arange(a, b + 1) * step, 12)


def window_harmonics(omega: float, sigma: float, zeta: float, x0, periods: int, *,
                     exponent: float, model: str = DEFAULT_LAW) -> np.ndarray:
    """(H1, H2, H1/2): the amplitudes of F/N at omega, 2 omega and omega / 2 over ``periods``
    forcing periods from x0 = (q, q') at tau = 0: 2 |integral of F exp(-i k omega t / 2) dt| /
    (periods T), k = 2, 4, 1 (trapezoid rule on SAMPLES points a period). Exact (to the
    quadrature) for an orbit whose period divides ``periods`` (an even number for H1/2)."""
    T = 2.0 * math.pi / omega
    r = api.simulate(omega, sigma, zeta, x0, periods=periods, samples_per_period=SAMPLES,
                     exponent=exponent, model=model)
    t, F = r["t"], r["force"]
    if not np.all(np.isfinite(F)):
        return np.full(3, np.nan)
    w = np.full(t.size, 1.0)
    w[0] = w[-1] = 0.5
    dt = T / SAMPLES
    out = []
    for k in (2, 4, 1):
        c = np.sum(w * F * np.exp(-0.5j * k * omega * t)) * dt
        out.append(2.0 * abs(c) / (periods * T))
    return np.array(out)


@dataclass(frozen=True)
class ModelSweep:
    """One model sweep as the fit reads it (sweep order).

    omega: (k,) the nodes (the steps, and each jump's attracting end); harmonics: (k, 3) H1,
    H2, H1/2 of F/N there; period: (k,) of the response (0: not periodic); segment: (k,) the
    run of one branch each node is on (interpolation stays within one); gap_jump: (k,) for a
    node followed by another segment, the omega where the sweep leaves its segment (NaN
    else). root_end, root_start: (k,) the omega of the fold that ends the node's segment, of
    the flip its segment's branch (of twice the period) is born at (NaN: none): there the
    branch's harmonics go as the square root of the distance, and the segment is interpolated
    linearly in that square root (exact for the normal form's leading terms; linear in omega
    is 1 % of H1 off on the 2T branch a few steps from its fold at sigma 0.3, zeta 0.005).
    jumps: (j, 6) rows (value, accuracy, kind as study.products.stepped_sweeps.
    JUMP_KIND_CODES, from_period, to_period: the period landed on, after a landing the sweep
    did not settle on itself; located). direction: "up" or "down".
    """

    direction: str
    omega: np.ndarray
    harmonics: np.ndarray
    period: np.ndarray
    segment: np.ndarray
    gap_jump: np.ndarray
    root_end: np.ndarray
    root_start: np.ndarray
    jumps: np.ndarray

    def at(self, omega) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(harmonics (..., 3), period (...), segment (...), slope (..., 3)): the sweep's
        reading at each omega (any shape) on the branch it is on there (module docstring),
        the period of that response, the index of the run of one branch read (counted along
        the sweep: two forward models whose jumps are the same read a point on the same
        branch when they give it the same segment), and d harmonics / d omega of the piece
        read (along that branch: a Gauss-Newton step does not see the branch change)."""
        s = 1.0 if self.direction == "up" else -1.0
        x = s * self.omega
        q = s * np.asarray(omega, float)
        shape = q.shape
        q = q.ravel()
        v, seg, k = self.harmonics, self.segment, x.size
        i = np.clip(np.searchsorted(x, q, side="right") - 1, 0, k - 2)
        j = i + 1
        same = seg[i] == seg[j]
        # within a segment: linear in the square root of the distance to the nearer of its
        # fold (end) and its branch's birth (start), else in x
        end, start = s * self.root_end[i], s * self.root_start[i]
        to_end = np.where(np.isfinite(end), end - q, np.inf)
        to_start = np.where(np.isfinite(start), q - start, np.inf)
        use_end = np.isfinite(to_end) & (to_end <= to_start)
        use_start = np.isfinite(to_start) & ~use_end

        def coord(y):
            return np.where(use_end, -np.sqrt(np.maximum(end - y, 0.0)),
                            np.where(use_start, np.sqrt(np.maximum(y - start, 0.0)), y))

        cq, ci, cj = coord(q), coord(x[i]), coord(x[j])
        dc = np.where(cj != ci, cj - ci, 1.0)
        dc_dq = np.where(use_end, 0.5 / np.maximum(-cq, 1e-12),
                         np.where(use_start, 0.5 / np.maximum(cq, 1e-12), 1.0))
        per_c = (v[j] - v[i]) / dc[:, None]
        inside = v[i] + (cq - ci)[:, None] * per_c
        slope_in = per_c * dc_dq[:, None]
        jump = s * self.gap_jump[i]
        left = q < np.where(np.isfinite(jump), jump, 0.5 * (x[i] + x[j]))
        # a segment's end nodes extrapolated over less than a step: from the node and its
        # neighbour in the segment (constant for a segment of one node)
        prev = np.clip(i - 1, 0, k - 1)
        has_prev = (seg[prev] == seg[i]) & (i > 0)
        span_l = np.where(has_prev, x[i] - x[prev], 1.0)
        slope_l = np.where(has_prev[:, None], (v[i] - v[prev]) / span_l[:, None], 0.0)
        nxt = np.clip(j + 1, 0, k - 1)
        has_next = (seg[nxt] == seg[j]) & (j + 1 < k)
        span_r = np.where(has_next, x[nxt] - x[j], 1.0)
        slope_r = np.where(has_next[:, None], (v[nxt] - v[j]) / span_r[:, None], 0.0)
        from_left = v[i] + (q - x[i])[:, None] * slope_l
        raw_right = v[j] + (q - x[j])[:, None] * slope_r
        from_right = np.maximum(raw_right, 0.0)
        slope_r = np.where(raw_right > 0.0, slope_r, 0.0)
        use_left = (~same & left)[:, None]
        out = np.where(same[:, None], inside, np.where(use_left, from_left, from_right))
        slope = np.where(same[:, None], slope_in, np.where(use_left, slope_l, slope_r))
        on_i = same | left
        period = np.where(on_i, self.period[i], self.period[j])
        segment = np.where(on_i, seg[i], seg[j])
        # back to omega: d/d omega = s d/dx
        return (out.reshape(*shape, 3), period.reshape(shape), segment.reshape(shape),
                (s * slope).reshape(*shape, 3))


@dataclass(frozen=True)
class ForwardModel:
    """The model's quasi-static sweeps at (sigma, zeta, exponent): ``sweeps`` by direction
    (:class:`ModelSweep`); steps: their steps in all; seconds: the wall time."""

    sigma: float
    zeta: float
    exponent: float
    sweeps: dict[str, ModelSweep]
    steps: int
    seconds: float

    def at(self, omega, direction: str):
        """:meth:`ModelSweep.at` of the sweep in ``direction``."""
        return self.sweeps[direction].at(omega)


def _harmonics(o, sigma: float, zeta: float, exponent: float, model: str) -> np.ndarray:
    """(H1, H2, H1/2) of an orbit: from its stored harmonics (period 1, 2), else read over 2 m
    periods of its history."""
    fh = o.force_harmonics
    # study.solve.sweep.force_components for one orbit of period 1 or 2 (H1 at k = m, H2 at
    # k = 2 m, H1/2 at k = m / 2 of the harmonics k omega / m), without its array machinery
    h = (np.array([fh[0], fh[1], 0.0]) if o.period == 1 else
         np.array([fh[1], fh[3], fh[0]]) if o.period == 2 else np.full(3, np.nan))
    if o.period > 2 or not np.all(np.isfinite(h)):
        h = window_harmonics(o.omega, sigma, zeta, o.x0, 2 * o.period, exponent=exponent,
                             model=model)
    return h


def _refined(orbit, w_from: float, w_to: float, sigma: float, zeta: float, exponent: float,
             model: str) -> list[tuple[float, np.ndarray]]:
    """Nodes of ``orbit``'s branch between w_from (where the orbit is) and w_to (less than a
    step away), at w_from + (w_to - w_from) (1 - 2^-k), k = 1..REFINE: a branch's harmonics
    near a fold, or near the flip where a 2T branch is born, go as the square root of the
    distance to it, which a step's chord misses (by 10 % of H1/2 over the last step before
    the 2T fold at sigma 0.3, zeta 0.005). Each node the branch continued by shooting from
    the last; stops at the first that fails or is not a stable orbit of the same minimal
    period."""
    out = []
    o = orbit
    if w_to == w_from:
        return out
    for k in range(1, REFINE + 1):
        w = w_from + (w_to - w_from) * (1.0 - 2.0 ** -k)
        nxt = api.shoot(w, sigma, zeta, o.period, o.x0, exponent=exponent, model=model)
        if not (nxt.converged and nxt.stable and nxt.minimal_period == orbit.period):
            break
        out.append((w, _harmonics(nxt, sigma, zeta, exponent, model)))
        o = nxt
    return out


def _model_sweep(sweep, sigma: float, zeta: float, exponent: float, model: str) -> ModelSweep:
    """The nodes of one study.solve.sweep.Sweep (module docstring)."""
    steps = sweep.steps
    k = len(steps)
    period = np.array([s.period for s in steps], int)
    orbits = [s.orbit for s in steps]
    harm = np.full((k, 3), np.nan)
    located = {j.step_index: j for j in sweep.jumps if j.located}
    for idx, s in enumerate(steps):
        if orbits[idx] is None:
            # a step whose transient did not settle: the last step's orbit continued (its
            # branch, when it is stable here: the quasi-static rule, after a landing the sweep
            # itself did not make), else the orbit its transient was approaching; right after
            # a located jump the branch left is not landed on again (the step can lie within
            # the jump's bracket of a fold, where Newton still finds its orbit)
            last = orbits[idx - 1] if idx > 0 else None
            o = None
            if last is not None and idx not in located:
                o = api.shoot(s.omega, s.sigma, s.zeta, last.period, last.x0,
                              exponent=exponent, model=model)
                if not (o.converged and o.stable and o.minimal_period == last.period):
                    o = None
            orbits[idx] = o or _landing(s, steps, idx, last, exponent, model,
                                        left=idx in located)
        o = orbits[idx]
        if o is not None:
            period[idx] = o.period
            harm[idx] = _harmonics(o, sigma, zeta, exponent, model)
        else:
            period[idx] = 0
            harm[idx] = window_harmonics(s.omega, sigma, zeta, s.end, WINDOW_PERIODS,
                                         exponent=exponent, model=model)
    # segments: a located jump starts a new one; so does a change of period
    segment = np.zeros(k, int)
    for idx in range(1, k):
        segment[idx] = segment[idx - 1] + int(idx in located or period[idx] != period[idx - 1])
    w_, h_, p_, s_, g_ = [], [], [], [], []
    root_end: dict[int, float] = {}
    root_start: dict[int, float] = {}

    def node(w, h, p, seg):
        w_.append(float(w))
        h_.append(np.asarray(h, float))
        p_.append(int(p))
        s_.append(int(seg))
        g_.append(np.nan)

    for idx, s in enumerate(steps):
        new = idx > 0 and segment[idx] != segment[idx - 1]
        j = located.get(idx) if new else None
        if new and orbits[idx] is not None and j is not None:
            # the branch landed on, continued back towards the jump
            back = _refined(orbits[idx], s.value, j.value, sigma, zeta, exponent, model)
            for w, h in reversed(back):
                node(w, h, period[idx], segment[idx])
            # a branch born at the flip (its subharmonic -> 0 there as the square root of the
            # distance: the nearest refined node's is ~0.18 of the step's), not one landed on
            # across a subcritical flip
            if (j.kind == "flip" and period[idx] == 2 * j.from_period and back
                    and back[-1][1][2] < 0.5 * harm[idx][2]):
                root_start[segment[idx]] = j.value
        node(s.value, harm[idx], period[idx], segment[idx])
        if idx + 1 < k and segment[idx + 1] != segment[idx]:
            jn = located.get(idx + 1)
            if jn is not None and jn.from_orbit is not None and orbits[idx] is not None:
                # the branch left, continued to the jump's attracting end
                fo = jn.from_orbit
                for w, h in _refined(orbits[idx], s.value, jn.before, sigma, zeta, exponent,
                                     model):
                    node(w, h, period[idx], segment[idx])
                if fo.period == period[idx] and jn.before != s.value:
                    node(jn.before, _harmonics(fo, sigma, zeta, exponent, model), period[idx],
                         segment[idx])
                g_[-1] = jn.value
                if jn.kind == "fold":
                    root_end[segment[idx]] = jn.value
            else:
                g_[-1] = 0.5 * (s.value + steps[idx + 1].value)
    # the jumps between two segments (an unlocated jump across a step that did not settle,
    # which the landing found on the branch of the steps around it, is not one)
    rows = [(j.value, j.accuracy, JUMP_KIND_CODES[j.kind], j.from_period,
             int(period[j.step_index]), j.located)
            for j in sweep.jumps
            if j.located or segment[j.step_index] != segment[j.step_index - 1]]
    # strictly along the sweep: a refined node at a step's own value (a jump bracketed at
    # the step itself) is dropped, keeping its gap's jump
    x = np.array(w_) * (1.0 if sweep.direction == "up" else -1.0)
    keep = np.r_[True, np.diff(x) > 0.0]
    gap = np.array(g_)
    for i in np.flatnonzero(~keep):
        if np.isfinite(gap[i]):
            gap[i - 1] = gap[i]
    segs = np.array(s_)[keep]
    return ModelSweep(direction=sweep.direction, omega=np.array(w_)[keep],
                      harmonics=np.array(h_).reshape(-1, 3)[keep], period=np.array(p_)[keep],
                      segment=segs, gap_jump=gap[keep],
                      root_end=np.array([root_end.get(g, np.nan) for g in segs]),
                      root_start=np.array([root_start.get(g, np.nan) for g in segs]),
                      jumps=np.array(rows, float).reshape(-1, 6))


def _landing(step, steps, idx: int, last, exponent: float, model: str, left: bool = False):
    """The stable orbit a step that did not settle was approaching, or None: shot from where
    its transient ended (and from the next step's orbit), of the period of the next periodic
    step, twice the last one's
    (``last``: the orbit of the step before, or None), the last one's, 1 or 2. Just past a
    flip of the last step's orbit (period m) the transient leaves the now unstable m T orbit
    along the flip's eigenvector towards the 2m T orbit born there, a distance ~ sqrt(past the
    flip) away, which Newton from the transient's end may miss for the m T orbit: the 2m T
    solve also starts from points along that eigenvector and that departure. ``left``: the
    last step's branch was left at a located jump: its orbit here (Newton from the last one)
    is not a landing."""
    guesses: dict[int, list] = {}
    nxt = steps[idx + 1] if idx + 1 < len(steps) else None
    if nxt is not None and nxt.period:
        guesses.setdefault(nxt.period, []).append(step.end)
        if nxt.orbit is not None:       # the next step's orbit, continued back a step
            guesses[nxt.period].append(nxt.orbit.x0)
    if last is not None:
        m = last.period
        starts = [step.end]
        base = api.shoot(step.omega, step.sigma, step.zeta, m, last.x0,
                         exponent=exponent, model=model)
        if base.converged:
            # along the flip's eigenvector (the monodromy's, kernels.continuation), and along
            # the transient's departure
            _, M, code = cont.System(step.zeta, exponent, model, DEFAULT_RTOL,
                                     api.DEFAULT_MAX_STEPS).map(base.x0, step.omega,
                                                                step.sigma, m)
            away = step.end - base.x0
            size = float(np.hypot(*away))
            directions = [cont.flip_eigenvector(M)] if code == 0 else []
            directions += [away / size] if size > 0.0 else []
            starts += [base.x0 + sign * r * e for e in directions
                       for r in (0.003, 0.01, 0.03, 0.1, 0.3, 1.0) for sign in (1.0, -1.0)]
        guesses.setdefault(2 * m, []).extend(starts)
        guesses.setdefault(m, []).append(step.end)
    for m in (1, 2):
        guesses.setdefault(m, []).append(step.end)
    branch = None
    if left and last is not None:
        branch = api.shoot(step.omega, step.sigma, step.zeta, last.period, last.x0,
                           exponent=exponent, model=model)
        branch = branch if branch.converged else None
    for m, starts in guesses.items():
        if m > 16:
            continue
        for x in starts:
            o = api.shoot(step.omega, step.sigma, step.zeta, m, x, exponent=exponent,
                          model=model)
            if not (o.converged and o.stable and o.minimal_period == m):
                continue
            if (branch is not None and m == branch.period
                    and np.hypot(*(o.x0 - branch.x0)) <= 1e-3 * (1.0 + np.hypot(*o.x0))):
                continue            # the branch left at the jump
            return o
    return None


def forward_model(sigma: float, zeta: float, omega: np.ndarray, *, exponent: float,
                  directions=("up", "down"), model: str = DEFAULT_LAW,
                  settle_periods: int = SETTLE_PERIODS, jump_tol: float = JUMP_TOL
                  ) -> ForwardModel:
    """The model's quasi-static stepped sweeps at (sigma, zeta) over the omega grid ``omega``
    (module docstring), one per direction, each from rest at its first step, read as
    :class:`ModelSweep`. Dimensionless (paper Eq. 7)."""
    t0 = time.perf_counter()
    sweeps = {}
    steps = 0
    for d in directions:
        sw = stepped_sweep("omega", omega, {"sigma": float(sigma), "zeta": float(zeta)}, d,
                           exponent=float(exponent), model=model,
                           settle_periods=int(settle_periods), jump_tol=float(jump_tol),
                           follow_first=True)
        sweeps[d] = _model_sweep(sw, float(sigma), float(zeta), float(exponent), model)
        steps += len(sw.steps)
    return ForwardModel(sigma=float(sigma), zeta=float(zeta), exponent=float(exponent),
                        sweeps=sweeps, steps=steps, seconds=time.perf_counter() - t0)
