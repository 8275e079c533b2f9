"""Every periodic response along one omega line at (sigma, zeta): the seeded sweeps, then the
branches beyond folds (paper section 3.2, Fig. 6-10).

1. **Sweeps.** Up the omega axis, then down (study.solve.point): at every point the seeds
   (linear 1T response, multiple-scales 2T response, flip eigenvectors) and the continuation of
   the previous point's orbits. Going down, only the orbits the way up did not reach by
   continuation are continued (the others would lead back to orbits already known): this
   follows the branches that end in a fold towards higher omega.
2. **Fold turning.** A branch that ends between two grid points, in a fold (a multiplier +1),
   turns back there into another branch (the unstable middle branch of the primary resonance,
   the unstable half of an isola), which no seed and no sweep reaches. The ends are the orbits
   with no continuation at the next grid point (matched point to point by their invariants
   min q and max q, one to one); from each, pseudo-arclength continuation in omega
   (kernels.continuation.arc_path) goes around the fold in a window of two grid steps and
   comes back;
   Newton at the grid points it crosses gives the orbits of the new branch, which are then
   followed along the line by natural continuation until that branch ends too (another fold:
   turned again) or joins a known orbit. Bounded: a few turns per line and period.

Orbits are kept once (study.orbit_rules identity rule).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from hertzmap.kernels import continuation as cont
from hertzmap.kernels import status as st
from hertzmap.kernels.model import Model
from hertzmap.study.orbit_rules import (CONTINUITY_SHARE, continuity_distance, fold_function,
                          match_neighbours, same_orbit)
from hertzmap.study.solve.census import attractor_starts, census, needs_second_census
from hertzmap.study.solve.certificate import LevelHints
from hertzmap.study.solve.point import merge_new_orbits, shoot_seeds_minimal, solve_point
from hertzmap.study.solve.seeds import mms_seeds

#: The exploratory seeds: the linear 1T response (where a 1T orbit is continued into the
#: point; always where none is) every LINEAR_SEED_STRIDE-th point of the up sweep, the
#: multiple-scales 2T response (most of the sweeps' cost: far from omega = 2 its Newton runs
#: often fail) every MMS_SEED_STRIDE-th. A branch they reach is continued both ways, and its
#: ends are traced through their folds. Measured on the default study's grid
#: (benchmarks/archive/census_comparison.py): the linear seed at every 8th point loses nothing; the
#: 2T seeds at every 2nd point lost an unstable 2T pair (10 orbits at sigma 0.9625, omega
#: 0.50-0.55, ending in a fold at 0.5514) that only the seed at an odd point reaches, and cost
#: 0.27x of the sweeps less; at every 4th point they lost short 2T segments (28 of 7832). What
#: matters is their spacing in omega, not in grid points: by default (MMS_SEED_STRIDE None) they
#: are shot every k-th point, k the largest with k steps <= MMS_SEED_SPACING (the default grid's
#: step: every point there; every 2nd on scenes/fine_map.toml's step of 0.005, where every
#: point cost 1.4x the line's search for the same stored orbits, 10 of its lines).
LINEAR_SEED_STRIDE = 8
MMS_SEED_STRIDE = None
MMS_SEED_SPACING = 0.0125
#: Grid points per line where the census runs whatever shooting found (besides the points with
#: no stable orbit): stable orbits that no seed reaches are found from there.
PROBE_POINTS = 4
#: Branch ends traced per line and period.
MAX_TURNS = 12
#: A trace stops after this many grid crossings in a row that give known orbits (or orbits of
#: a lower period: LineSearch.trace).
KNOWN_RUN = 2
#: A trace's steps change omega by at most this many grid steps (every grid point crossed is
#: solved for, whatever the steps)
TRACE_DP = 1.0
#: Continuation points per grid point a trace may take (steps are at most half a grid step in
#: omega; folds and steep stretches take more).
TRACE_POINTS_PER_STEP = 6
#: Legs (natural continuation, then pseudo-arclength through a fold) a trace may take.
MAX_LEGS = 4


@dataclass
class LineSearch:
    """The orbits of one omega line, per grid point (omega in the given order)."""

    omega: np.ndarray
    sigma: float
    zeta: float
    periods: tuple[int, ...]
    options: dict
    deadline: float | None = None
    per_point: list = field(default_factory=list)
    best_1t: list = field(default_factory=list)
    visited: np.ndarray | None = None
    traces: int = 0
    seconds: dict = field(default_factory=dict)
    attractors: dict = field(default_factory=dict)      # grid index -> census result

    def __post_init__(self):
        model = Model.of(self.options)
        self.system = cont.System(float(self.zeta), model.exponent, model.law, model.rtol)
        self.omega = np.asarray(self.omega, float)
        self.order = np.argsort(self.omega, kind="stable")
        self.rank = np.empty(self.omega.size, int)
        self.rank[self.order] = np.arange(self.omega.size)
        self.per_point = [[] for _ in self.omega]
        self.best_1t = [None] * self.omega.size
        self.visited = np.zeros(self.omega.size, bool)

    def out_of_time(self) -> bool:
        return self.deadline is not None and time.monotonic() > self.deadline

    @property
    def grid_step(self) -> float:
        """The line's omega step (0 for a single point)."""
        n = self.omega.size
        return (float(self.omega.max()) - float(self.omega.min())) / (n - 1) if n > 1 else 0.0

    # -- 1. the sweeps --------------------------------------------------------------------
    def mms_stride(self) -> int:
        """Every how many grid points the multiple-scales 2T seeds are shot (see
        MMS_SEED_SPACING)."""
        stride = self.options.get("mms_stride", MMS_SEED_STRIDE)
        if stride is not None:
            return int(stride)
        h = self.grid_step
        return max(1, int(MMS_SEED_SPACING / h + 1e-9)) if h > 0.0 else 1

    def sweep(self) -> None:
        t0 = time.perf_counter()
        mms = mms_seeds(self.omega, self.sigma, self.zeta) if 2 in self.periods else None
        mms_stride = self.mms_stride()
        for first_visit, order in ((True, self.order), (False, self.order[::-1])):
            prev = []
            for i in order:
                if self.out_of_time():
                    break
                last = self.rank[i] == self.omega.size - 1
                explore = first_visit and (
                    self.rank[i] % int(self.options.get("linear_stride", LINEAR_SEED_STRIDE)) == 0
                    or last)
                use_mms = first_visit and (
                    self.rank[i] % mms_stride == 0
                    or last)
                found, tries = solve_point(self.omega[i], self.sigma, self.zeta, self.periods,
                                           prev, self.options, first_visit,
                                           mms[i] if mms is not None and use_mms else (),
                                           explore)
                self.visited[i] = True
                merge_new_orbits(self.per_point[i], found)
                if tries and self.best_1t[i] is None:
                    self.best_1t[i] = min(tries, key=lambda s: (
                        s["status"] != st.CONVERGED,
                        s["residual"] if math.isfinite(s["residual"]) else math.inf))
                if first_visit:
                    prev = self.per_point[i]
                else:
                    prev = [s for s in self.per_point[i] if not s.get("continued_up")]
            if first_visit:
                for sols in self.per_point:
                    for s in sols:
                        s["continued_up"] = bool(s.get("continued"))
        self.seconds["sweep"] = time.perf_counter() - t0

    # -- 2. fold turning ------------------------------------------------------------------
    def branch_ends(self, period: int) -> list[tuple[int, dict, int]]:
        """(grid index, orbit, direction) of the orbits of ``period`` with no continuation at
        the next grid point in that direction (one-to-one matching by invariants, between
        orbits whose fold functions have the same sign), and the
        orbits at the two ends of the line whose fold function, extrapolated one grid step
        outwards, changes sign (a fold just beyond the line: its other branch crosses the
        line's end points)."""
        ends = []
        partner: dict[int, dict] = {}
        for a, b in zip(self.order[:-1], self.order[1:]):
            A = [s for s in self.per_point[a] if s["period"] == period]
            B = [s for s in self.per_point[b] if s["period"] == period]
            used_a, used_b = set(), set()
            for ia, ib in match_neighbours(A, B):
                used_a.add(ia)
                used_b.add(ib)
                partner[id(A[ia])] = B[ib]
                partner[id(B[ib])] = A[ia]
            ends += [(int(a), A[ia], +1) for ia in range(len(A)) if ia not in used_a]
            ends += [(int(b), B[ib], -1) for ib in range(len(B)) if ib not in used_b]
        if self.omega.size >= 2:
            for i, d in ((int(self.order[0]), -1), (int(self.order[-1]), +1)):
                for s in self.per_point[i]:
                    inner = partner.get(id(s))
                    if s["period"] != period or inner is None:
                        continue
                    g, g_in = fold_function(s), fold_function(inner)
                    if g * (2.0 * g - g_in) <= 0.0:
                        ends.append((i, s, d))
        return ends

    def neighbour(self, i: int, d: int) -> int | None:
        r = self.rank[i] + d
        return int(self.order[r]) if 0 <= r < self.omega.size else None

    def trace(self, i: int, sol: dict, d: int, past_fold: bool = False) -> int:
        """Follow the branch of ``sol`` (at grid point i) along the line from there in
        direction d, and solve at every grid point it crosses, within the line's window (one
        grid step beyond each end). Legs alternate:

        * natural continuation from grid point to grid point (Newton at the next omega from
          the secant prediction), while Newton converges onto the same branch (same period,
          the fold function's sign kept, invariants within the continuity rule's share);
        * where it does not (a fold ahead, a steep stretch), pseudo-arclength continuation in
          omega from the last point (through the fold: a turning branch comes back along its
          other half), until it has turned and given a new orbit beyond the fold; the next
          leg then goes the other way from there. With ``past_fold`` (an orbit of a period
          the line search does not follow, met by the census) the trace ends there instead:
          both halves of its fold are then known at the grid point next to it, which is all
          the curves' fold seeds need.

        Stops when KNOWN_RUN crossings in a row give orbits already known (the branch is
        retracing one) or orbits of a lower period dividing this one (past a flip, the path
        follows the branch of the orbit this one doubled from, as a double cover: a 16T path
        on scenes/fine_map.toml went round an 8T loop for its whole point budget), or the
        window is left. Returns the number of new orbits."""
        h = self.grid_step
        lo, hi = float(self.omega.min()) - h, float(self.omega.max()) + h
        self.traces += 1
        period = sol["period"]
        state = {"known": 0, "new": 0, "stop": False, "lower": 0}

        def record(k, g) -> bool:
            """Keep g at grid point k if new; False when the trace must stop."""
            if any(same_orbit(g, s) for s in self.per_point[k]):
                state["known"] += 1
                if state["known"] >= KNOWN_RUN:
                    state["stop"] = True
                    return False
            else:
                g["omega"] = self.omega[k]
                self.per_point[k].append(g)
                state["new"] += 1
                state["known"] = 0
            return True

        def shoot(k, x):
            got = [g for g in shoot_seeds_minimal(self.omega[k], self.sigma, self.zeta, period,
                                                  [x], self.options)
                   if g["status"] == st.CONVERGED]
            if got and got[0]["period"] < period:
                # its minimal period divides this one: the path has left the branch at a flip
                # of that orbit, onto the branch it doubled from (traced as a double cover)
                state["lower"] += 1
                return None
            state["lower"] = 0
            return got[0] if got else None

        def continues(a, b) -> bool:
            """b (at the next grid point) is on a's branch: study.orbit_rules' continuity rule, made
            strict for a step that must not cross a fold (any change of the fold function's
            sign stops it, with no floor: the pseudo-arclength leg then turns the fold) and
            scaled by the orbit it starts from."""
            return (fold_function(a) * fold_function(b) >= 0.0
                    and continuity_distance(a, b) <= CONTINUITY_SHARE * (1.0 + a["ptp"]))

        def natural(k, orbit, direction):
            """Grid point to grid point from ``orbit`` at k; returns where it stopped."""
            prev = None
            while not state["stop"] and not self.out_of_time():
                nxt = self.neighbour(k, direction)
                if nxt is None:
                    break
                x = np.asarray(orbit["x0"], float)
                if prev is not None:
                    x = x + (self.omega[nxt] - self.omega[k]) / (self.omega[k] - self.omega[prev[0]]) \
                        * (x - np.asarray(prev[1]["x0"], float))
                g = shoot(nxt, (float(x[0]), float(x[1])))
                if g is None or not continues(orbit, g):
                    break
                if not record(nxt, g):
                    break
                prev, k, orbit = (k, orbit), nxt, g
            return k, orbit

        k, orbit, direction = i, sol, d
        for _ in range(MAX_LEGS):
            k, orbit = natural(k, orbit, direction)
            if state["stop"] or self.out_of_time():
                break
            leg = {"turned": False, "end": None}

            def on_step(u_prev, u, start=k, x_start=orbit["x0"], direction=direction, leg=leg):
                if (u[2] - u_prev[2]) * direction < 0.0:
                    leg["turned"] = True
                for kk, x in path_crossings(np.array([u_prev, u]), self.omega):
                    if kk == start and _near(x, x_start, 1e-3):
                        continue        # the start point itself
                    g = shoot(kk, x)
                    if g is None:
                        if state["lower"] >= KNOWN_RUN:
                            return False        # following the lower period's branch
                        continue
                    new_before = state["new"]
                    if not record(kk, g):
                        return False
                    if leg["turned"] and state["new"] > new_before:
                        leg["end"] = (kk, g)        # a new orbit beyond the fold
                        return False
                return not self.out_of_time()

            cont.arc_path(self.system, np.asarray(orbit["x0"], float), float(self.omega[k]),
                          self.sigma, period, float(direction), lo, hi, ds=2.0 * h,
                          dp_max=TRACE_DP * h,
                          max_points=TRACE_POINTS_PER_STEP * self.omega.size, on_step=on_step)
            if leg["end"] is None or past_fold or state["stop"]:
                break
            (k, orbit), direction = leg["end"], -direction
        return state["new"]

    def turn_folds(self) -> None:
        """Trace every branch end through its fold and along what lies beyond (bounded per
        line and period)."""
        t0 = time.perf_counter()
        for period in self.periods:
            queue = self.branch_ends(period)
            # both halves of a fold already known at its last grid point: the stable side's fold
            # function (1 - mu1)(1 - mu2) is positive, the unstable side's negative
            known_pairs = set()
            for i, sol, d in queue:
                for i2, sol2, d2 in queue:
                    if i2 == i and d2 == d and sol2 is not sol \
                            and fold_function(sol) * fold_function(sol2) < 0.0:
                        known_pairs.add(id(sol))
            queue = [e for e in queue if id(e[1]) not in known_pairs]
            for i, sol, d in queue[:MAX_TURNS]:
                if self.out_of_time():
                    break
                self.trace(i, sol, d)
        self.seconds["fold turning"] = time.perf_counter() - t0

    # -- 3. the attractor census ------------------------------------------------------------
    def probe_points(self, count: int = PROBE_POINTS) -> set[int]:
        """``count`` grid points spread evenly along the line (both ends included)."""
        n = self.omega.size
        ranks = np.unique(np.round(np.linspace(0, n - 1, min(count, n))).astype(int))
        return {int(self.order[r]) for r in ranks}

    def run_census(self, mode: str, n_states: int, transient_periods: int,
                   record_periods: int, max_transient_periods: int | None = None,
                   point_steps: int = 2_000_000, lyapunov_error: float | None = None) -> None:
        """Transients from ``n_states`` initial states at the points ``mode`` names
        ("where-none-stable": those with no stable orbit when their turn comes, and the
        probe points spread along the line; "always": every point), in omega order. Orbits
        found there are followed along the line both ways (where they may be stable, or
        unstable) and their branch ends turned, so that a stable orbit that no seed reaches
        (an isola away from omega = 2) is found along the whole line from one probe, and a
        point whose stable orbit a neighbour's census found needs no transients of its own.
        Orbits of periods the line search does not follow (3T, 5T, ...) are followed too, each
        way to its first fold and just beyond (both halves there: the curves' fold seeds), so
        that a stable one is reported at every point of the line it attracts at, not only
        where the census ran."""
        if mode == "never":
            return
        t0 = time.perf_counter()
        probes = self.probe_points()
        # the certified levels of the point whose census ran last: each ladder's start
        levels = LevelHints()

        def census_at(i: int) -> list[dict]:
            """The census at grid point i, from its own states and its neighbours'
            attractors: its attractors kept, the orbits it found added; returns those."""
            found, new = census(self.omega[i], self.sigma, self.zeta, self.per_point[i],
                                self.options, n_states, transient_periods, record_periods,
                                max_transient_periods, point_steps, lyapunov_error,
                                self.neighbour_starts(i), levels)
            self.attractors[i] = found
            for sol in new:
                sol["omega"] = self.omega[i]
                self.per_point[i].append(sol)
            return new

        for i in self.order:
            if self.out_of_time():
                break
            if mode == "where-none-stable" and int(i) not in probes \
                    and any(s["stable"] for s in self.per_point[i]):
                continue
            new = census_at(int(i))
            # an orbit of a period the line search follows is traced along the line (and
            # beyond its folds); one of another period is followed while it attracts (the
            # unstable ones the census meets inside a chaotic set are stored where met)
            for sol in (s for s in new if s["period"] in self.periods or s["stable"]):
                for direction in (-1, +1):
                    self.trace(int(i), sol, direction,
                               past_fold=sol["period"] not in self.periods)
        # a trace from a later point may have found a stable orbit at a point whose census had
        # none to compare with and called its transients chaotic: the census again, knowing
        # it (its longer passes tell a chaotic attractor beside the orbit from long transients)
        for i, found in sorted(self.attractors.items()):
            if not needs_second_census(found, self.per_point[i], transient_periods,
                                       record_periods):
                continue
            census_at(i)
        self.seconds["census"] = time.perf_counter() - t0

    def neighbour_starts(self, i: int) -> list[tuple[float, float]]:
        """States on the attractors of grid point i's neighbours along the line, where their
        census ran (so far: the first sweep knows the lower one)."""
        return [x for d in (-1, +1) for j in [self.neighbour(i, d)]
                if j is not None and j in self.attractors
                for x in attractor_starts(self.attractors[j])]

    # -- results --------------------------------------------------------------------------
    def solutions(self, i: int) -> list[dict]:
        """The distinct converged orbits at grid point i, ordered by (period, ptp)."""
        return sorted(self.per_point[i], key=lambda s: (s["period"], s["ptp"]))


def path_crossings(path: np.ndarray, omega_grid) -> list[tuple[int, tuple]]:
    """(grid index, guess x) where a continuation path (rows q, q', omega) crosses a grid omega
    (linear interpolation between consecutive points)."""
    out = []
    for k in range(len(path) - 1):
        a, b = path[k, 2], path[k + 1, 2]
        lo, hi = min(a, b), max(a, b)
        for i in np.nonzero((omega_grid >= lo) & (omega_grid <= hi))[0]:
            th = 0.0 if b == a else (omega_grid[i] - a) / (b - a)
            x = path[k, :2] + th * (path[k + 1, :2] - path[k, :2])
            out.append((int(i), (float(x[0]), float(x[1]))))
    return out


def _near(x, y, tol=1e-6) -> bool:
    x, y = np.asarray(x, float), np.asarray(y, float)
    return float(np.hypot(*(x - y))) <= tol * (1.0 + float(np.hypot(*y)))


def grid_crossings(branch, omega_grid):
    """(grid index, guess x) where a branch crosses a grid omega (linear interpolation between
    consecutive continuation points)."""
    w = branch.points["omega"]
    q, v = branch.points["q0"], branch.points["v0"]
    out = []
    for k in range(len(w) - 1):
        a, b = w[k], w[k + 1]
        lo, hi = min(a, b), max(a, b)
        for i in np.nonzero((omega_grid >= lo) & (omega_grid <= hi))[0]:
            th = 0.0 if b == a else (omega_grid[i] - a) / (b - a)
            out.append((int(i), (q[k] + th * (q[k + 1] - q[k]), v[k] + th * (v[k + 1] - v[k]))))
    return out

