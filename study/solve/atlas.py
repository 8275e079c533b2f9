"""The atlas: every stored orbit is continued into its grid neighbours along every swept axis,
until no point gains an orbit, so that the map does not depend on where the grid's seeds and
probes fell (an orbit exists on a connected region of parameter space bounded by its folds,
flips and the window; continuing it point to point fills that region).

Jacobi rounds over tiles (blocks of the grid, of any shape: the scheduler chooses them): round
r reads the stored orbits as they were after round r - 1 (the snapshot; round 1 reads the
grid's). At a tile, each orbit on offer (round 1: every grid orbit of the tile and its
one-point halo; later: the halo's orbits that round r - 1 added) is continued into its
neighbours in the tile: natural continuation, Newton shooting at the neighbour's (omega, sigma,
zeta) from the orbit's start point, at its period (study.solve.point.shoot_targets: the shots
of a pass in one kernel call; Newton gives up once its residual creeps: STALL_RATIO); a shot
that fails from an orbit far from its fold is tried again in two half steps (FAR_FROM_FOLD: the
fold-aware step). An orbit that the continuity rule already pairs with one of the neighbour's
(study.orbit_rules.match_neighbours) is not shot. A converged orbit new there by the identity rule
(study.orbit_rules.same_orbit) joins the point with ``atlas_round = r`` and is offered in turn to
its neighbours in the tile, until the tile gains nothing more; the halo gets it next round. The
point is written again (study.solve.point_state: every orbit, in slot order; the tile's arrays
grow where a point holds more than they have room for), its census attractors keep their
orbits (``attractor_solution`` follows them) and the crossings of its line are found again
(the traced curves' seeds see the new orbits).

Orbits are offered in a fixed order (source points sorted, their orbits in slot order, the
neighbours lower first along omega, sigma, zeta), so a tile's result depends on the snapshot
only: the same for any worker count or task order. The rounds stop when one adds nothing (a
fixed point). scheduler.stages.atlas_tasks runs them, resumably.

Pure: numpy over the kernels (no Dask, no I/O).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.study.orbit_rules import fold_function, match_neighbours, same_orbit
from hertzmap.study.schema import (ATTRACTOR_KINDS, ATTRACTOR_VARIABLES, BIFURCATION_KINDS,
                                   CROSSING_SLOTS, CROSSING_VARIABLES, ORBIT_VARIABLES,
                                   VARIABLES)
from hertzmap.study.solve.block import record_line
from hertzmap.study.solve.census import NEIGHBOUR_KINDS, census, first_pass_only
from hertzmap.study.solve.curve_seeds import line_crossings
from hertzmap.study.solve.point import shoot_targets
from hertzmap.study.solve.point_state import (RULE_FIELDS, _Lazy, stored_states,  # noqa: F401
                                              write_states)

#: The per-point variables the atlas rewrites besides the orbit slots (when stored).
POINT_NAMES = ("orbits_found", "attractor_solution")
#: Newton iterations of a continuation into a neighbour: one that exists there converges from
#: the neighbour's start point in a few; most shots that fail are at orbits that end between
#: the two points (past a fold or a flip), and a long Newton only spent time there
MAX_ITER = 10
#: A continuation's Newton gives up after two damped steps running that each leave the residual
#: above this share of the last (kernels.shooting.shoot_into's stall_ratio; the grid's searches
#: from seeds use 1: no decrease at all). From a neighbour's orbit, Newton either converges
#: fast or creeps: where the orbit ends between the two points, the residual settles on a
#: floor (a minimum of |P(x) - x| that is not a zero), and Newton crept there for all its
#: iterations, with line searches: most of the atlas's shooting work. Over the whole atlas
#: (benchmarks/archive/atlas_rules.py stall) the default scene's counts are identical and the
#: vibro-impact scene loses no stable orbit at any point.
STALL_RATIO = 0.9
#: A shot that failed from an orbit whose fold function (study.orbit_rules.fold_function) is at least
#: this far from zero is tried again in two half steps (the fold-aware step): no multiplier is
#: near +1, so the orbit does not end at a fold between the two points, and the step was too
#: long for Newton (orbits that change fast: long flights, contact loss). Nearer a fold the
#: orbit most often ends between the points, and a shorter step only costs. Measured: on the
#: default scene's first round, 887 shots of 3,940 failed, most near a fold (median |fold
#: function| 0.17); half steps recovered 8 (all with a fold function above 1); over the whole
#: atlas (benchmarks/archive/atlas_rules.py half_steps), the vibro-impact scene gains 39 orbits (15,009 ->
#: 15,048; 9 more points with a stable 12T orbit) for 9.6 % more shots, the default scene none
#: (its 8 arrive by later rounds) for 8 % more.
FAR_FROM_FOLD = 0.5


def atlas_names(stored: tuple[str, ...]) -> tuple[str, ...]:
    """The stored variables a tile of the atlas rewrites (of those a study stores)."""
    wanted = ORBIT_VARIABLES + POINT_NAMES + CROSSING_VARIABLES
    return tuple(n for n in stored if n in wanted)


@dataclass
class TileResult:
    """A tile after one round: its arrays (only the tile's cells, atlas_names), which points
    gained an orbit, and the work done."""

    arrays: dict[str, np.ndarray]
    changed: np.ndarray
    shots: int = 0
    added: int = 0


#: the slot variables a tile reads of its halo (its neighbours' orbits: their rules and start
#: points); the others are read, rewritten and written over the tile's own cells only
HALO_NAMES = RULE_FIELDS + ("q0", "v0")
#: what a census round reads of its halo besides: the neighbours' attractors, whose states
#: its transients also start from (neighbour_starts)
NEIGHBOUR_NAMES = ("attractor_kind", "strobe_q", "strobe_v", "attractor_period")


def neighbours(idx, shape):
    """The grid neighbours of idx (one step along each axis of more than one point), lower
    first, in axis order (omega, sigma, zeta)."""
    for axis in range(3):
        if shape[axis] < 2:
            continue
        for step in (-1, 1):
            nb = list(idx)
            nb[axis] += step
            if 0 <= nb[axis] < shape[axis]:
                yield tuple(nb)


def propagate_tile(region: dict[str, np.ndarray], lines: dict[str, np.ndarray],
                   own: tuple[slice, slice, slice], omega: np.ndarray, sigma: np.ndarray,
                   zeta: np.ndarray, round_: int, options: dict, level: float,
                   periods: tuple[int, ...], offer_own: bool = False,
                   unstable: str = "searched-periods") -> TileResult:
    """One round at one tile. ``region``: the stored slot and point variables over the tile
    and its one-point halo, as read from the snapshot; ``lines``: the tile's stored crossing
    variables (dims omega_block (1), sigma, zeta, crossing), if any; ``own``: the tile's cells
    within the region; omega, sigma, zeta: the region's axes; ``options``: the solver's
    (exponent, model, rtol, harmonics); ``level``: the contact-loss level (the crossings'
    grazing test); ``periods``: the periods the study searches; ``offer_own``: the tile's own
    orbits of the last round are offered too (after a census round: its orbits were not
    offered where they were found). Returns the tile's arrays (atlas_names) with the orbits
    this round adds."""
    options = dict(options, max_iter=MAX_ITER, stall_ratio=STALL_RATIO)
    shape = region["status"].shape[:3]
    states = stored_states(region, periods)
    lo = tuple(s.start for s in own)
    own_shape = tuple(s.stop - s.start for s in own)
    result = TileResult({}, np.zeros(own_shape, bool))
    mine = {tuple(a + b for a, b in zip(local, lo)) for local in np.ndindex(own_shape)}
    current = _Lazy(lambda idx: states[idx].orbits)
    added: dict[tuple, list[dict]] = {idx: [] for idx in mine}
    # what is offered to the neighbours first: round 1, every grid orbit; later, the halo's
    # orbits of the last round (the tile's own were offered inside it when they were added)
    last = ((region["status"] == st.CONVERGED) & (region["period"] > 0)
            & (region["atlas_round"] == round_ - 1)).any(axis=-1)
    fresh = {}
    for idx in map(tuple, np.argwhere(last).tolist()):
        if round_ == 1 or offer_own or idx not in mine:
            fresh[idx] = [o for o in current[idx] if o["atlas_round"] == round_ - 1
                          and continues(o, periods, unstable)]
    # the continuity pairing of two neighbours, computed once for both directions (until one
    # of them gains an orbit): (sizes, the paired orbits of the lower point, of the higher)
    pairing: dict[tuple, tuple] = {}

    def paired(src, p) -> set[int]:
        key = (src, p) if src < p else (p, src)
        sizes = (len(current[key[0]]), len(current[key[1]]))
        hit = pairing.get(key)
        if hit is None or hit[0] != sizes:
            pairs = match_neighbours(current[key[0]], current[key[1]])
            hit = pairing[key] = (sizes, {a for a, _ in pairs}, {b for _, b in pairs})
        return hit[1] if src == key[0] else hit[2]

    # the tile to its own fixed point: an orbit added here is offered to its neighbours in the
    # tile at once (those beyond it get it next round)
    while fresh:
        # the shots of this pass, in a fixed order, solved in one kernel call
        shots: list[tuple[tuple, tuple, dict]] = []
        for src in sorted(fresh):
            offered = {id(f) for f in fresh[src]}
            offer = [(ia, o) for ia, o in enumerate(current[src]) if id(o) in offered]
            for p in neighbours(src, shape):
                if p not in mine:
                    continue
                done = paired(src, p)
                shots += [(src, p, o) for ia, o in offer if ia not in done]
        at = lambda idx: (float(omega[idx[0]]), float(sigma[idx[1]]), float(zeta[idx[2]]))
        solved = shoot_targets([at(p) + (int(o["period"]), tuple(o["x0"]))
                                for _, p, o in shots], options)
        result.shots += len(shots) + _half_steps(shots, solved, at, options)
        gained: dict[tuple, list[dict]] = {}
        for (_, p, _), sol in zip(shots, solved):
            if sol["status"] != st.CONVERGED or sol["period"] < 1 \
                    or any(same_orbit(sol, k) for k in current[p]):
                continue
            sol["atlas_round"] = round_
            current[p].append(sol)
            added[p].append(sol)
            if continues(sol, periods, unstable):
                gained.setdefault(p, []).append(sol)
        fresh = gained
    changed = {}
    for idx in sorted(mine):
        if added[idx]:
            local = tuple(a - b for a, b in zip(idx, lo))
            result.changed[local] = True
            result.added += len(added[idx])
            changed[local] = states[idx]
    result.arrays = _tile_arrays(region, lines, own, changed, periods)
    if result.changed.any() and "crossing_kind" in result.arrays:
        before = stored_states(region, periods)
        _recount_crossings(result.arrays, own_shape, lo, result.changed,
                           _Lazy(lambda idx: before[idx].orbits), current, omega[own[0]],
                           level, periods)
    return result


def continues(orbit: dict, periods: tuple[int, ...], unstable: str) -> bool:
    """The atlas continues this orbit into its neighbours: a stable orbit always; an unstable
    one where ``unstable`` (search.continue_unstable, study.spec.CONTINUE_UNSTABLE) is "all"
    or its period is one the study searches (an unstable orbit of another period, met by the
    census in a chaotic set, is stored where it was met)."""
    return bool(orbit["stable"]) or unstable == "all" or int(orbit["period"]) in periods


def _tile_arrays(region, lines, own, changed, periods) -> dict[str, np.ndarray]:
    """The tile's arrays (its cells of the region's slot and point variables, and its lines)
    with the ``changed`` points ({tile cell: PointState}) written again: sized by the data,
    the slots grown where a point now holds more than the region had room for."""
    names = tuple(n for n in region if n in ORBIT_VARIABLES + POINT_NAMES
                  or n in ATTRACTOR_VARIABLES)
    tile = {n: region[n][own] for n in names}
    shape = tuple(s.stop - s.start for s in own)
    out = write_states(changed, shape, names, periods, source=region, base=tile)
    out.update({n: a.copy() for n, a in lines.items()})
    return out


def atlas_tile(region: dict[str, np.ndarray], lines: dict[str, np.ndarray],
               own: tuple[slice, slice, slice], omega: np.ndarray, sigma: np.ndarray,
               zeta: np.ndarray, round_: int, options: dict, level: float,
               periods: tuple[int, ...], *, offer_own: bool = False,
               census: dict | None = None, unstable: str = "searched-periods") -> TileResult:
    """One tile of one round, of either kind: a continuation round (propagate_tile) or, with
    the census's settings ``census``, a census round (census_tile). The one entry point the
    scheduler's tasks call."""
    if census is None:
        return propagate_tile(region, lines, own, omega, sigma, zeta, round_, options,
                              level, periods, offer_own=offer_own, unstable=unstable)
    return census_tile(region, lines, own, omega, sigma, zeta, round_, options, level,
                       periods, census)


def _half_steps(shots, solved, at, options) -> int:
    """Shots that failed from an orbit far from a fold (FAR_FROM_FOLD) tried again in two half
    steps: Newton at the edge's midpoint from the orbit's start point, then at the neighbour
    from the midpoint's orbit. ``solved`` takes the second step's solutions in place. Returns
    the shots made."""
    again = [i for i, ((_, _, o), sol) in enumerate(zip(shots, solved))
             if sol["status"] != st.CONVERGED and abs(fold_function(o)) >= FAR_FROM_FOLD]
    if not again:
        return 0
    mid = lambda src, p: tuple(0.5 * (a + b) for a, b in zip(at(src), at(p)))
    half = shoot_targets([mid(*shots[i][:2]) + (int(shots[i][2]["period"]),
                                                tuple(shots[i][2]["x0"])) for i in again],
                         options)
    on = [(i, h) for i, h in zip(again, half)
          if h["status"] == st.CONVERGED and h["period"] == shots[i][2]["period"]]
    full = shoot_targets([at(shots[i][1]) + (int(h["period"]), tuple(h["x0"])) for i, h in on],
                         options)
    for (i, _), sol in zip(on, full):
        solved[i] = sol
    return len(again) + len(on)


def census_points(arrays: dict[str, np.ndarray], transient_periods: int,
                  record_periods: int) -> np.ndarray:
    """The points (bool over the arrays' omega, sigma, zeta) whose census must run again
    (study.solve.census.needs_second_census's rule over stored arrays: the atlas continued a
    stable orbit to a point whose census called transients chaotic after their first pass)."""
    first_pass = ((arrays["attractor_kind"] == ATTRACTOR_KINDS["non_periodic"])
                  & first_pass_only(arrays["attractor_periods_run"], transient_periods,
                                    record_periods)).any(axis=-1)
    stable = (arrays["stable"] & (arrays["status"] == st.CONVERGED)).any(axis=-1)
    return first_pass & stable


def census_tile(region: dict[str, np.ndarray], lines: dict[str, np.ndarray],
                own: tuple[slice, slice, slice], omega: np.ndarray, sigma: np.ndarray,
                zeta: np.ndarray, round_: int, options: dict, level: float,
                periods: tuple[int, ...], search: dict) -> TileResult:
    """A census round at one tile (after the atlas's fixed point): the census
    (study.solve.census.census) again at each census_points point, now knowing its orbits
    (the stable ones the atlas brought; its longer passes tell a chaotic attractor beside
    them from long transients). Its attractors replace the point's; an orbit it finds joins
    the point with ``atlas_round = round_`` (the next round continues it). ``region``: the
    tile's stored slot, point and attractor variables (``own`` covers it); ``search``: the
    census's settings (n_states, transient_periods, record_periods, max_transient_periods,
    point_steps). Returns the tile's arrays (atlas_names) where points were revisited."""
    states = stored_states(region, periods)
    lo = tuple(s.start for s in own)
    own_shape = tuple(s.stop - s.start for s in own)
    result = TileResult({}, np.zeros(own_shape, bool))
    need = census_points({n: region[n][own] for n in region}, search["transient_periods"],
                         search["record_periods"])
    changed = {}
    gained = np.zeros(own_shape, bool)
    for local in map(tuple, np.argwhere(need)):
        idx = tuple(int(a + b) for a, b in zip(local, lo))
        state = states[idx]
        w = float(omega[idx[0]])
        found, new = census(w, float(sigma[idx[1]]), float(zeta[idx[2]]), state.orbits,
                            options, **search, neighbour_starts=neighbour_starts(region, idx))
        for sol in new:
            sol["atlas_round"] = round_
        state.orbits = state.orbits + new
        state.attractors = found
        state.n_states = int(search["n_states"])
        state.omega = w
        changed[local] = state
        result.changed[local] = True
        result.shots += 1
        result.added += len(new)
        gained[local] = bool(new)
    result.arrays = _tile_arrays(region, lines, own, changed, periods)
    if gained.any() and "crossing_kind" in result.arrays:
        before = stored_states(region, periods)
        now = _Lazy(lambda idx: states[idx].orbits)
        _recount_crossings(result.arrays, own_shape, lo, gained,
                           _Lazy(lambda idx: before[idx].orbits), now, omega[own[0]], level,
                           periods)
    return result


def neighbour_starts(region: dict[str, np.ndarray], idx: tuple) -> list[tuple[float, float]]:
    """States on the attractors stored at the grid neighbours of ``region``'s point ``idx``
    along every axis (the snapshot's), as study.solve.census.attractor_starts takes them: the
    last stroboscopic point of each chaotic attractor, the last m (its phases) of each periodic
    one of period m."""
    kinds, q, v, periods = (region[n] for n in NEIGHBOUR_NAMES)
    wanted = [ATTRACTOR_KINDS[k] for k in NEIGHBOUR_KINDS]
    out = []
    for at in neighbours(idx, kinds.shape[:3]):
        for slot in np.flatnonzero(np.isin(kinds[at], wanted)):
            m = max(1, int(periods[at + (slot,)]))
            for x in zip(q[at + (slot, slice(-m, None))].tolist(),
                         v[at + (slot, slice(-m, None))].tolist()):
                if np.all(np.isfinite(x)):
                    out.append(x)
    return out


def _crossing_records(out, j, k) -> list[dict]:
    """The crossings stored for line (j, k) of the tile, as records (line_crossings')."""
    kinds = {code: name for name, code in BIFURCATION_KINDS.items()}
    fields = [n.removeprefix("crossing_") for n in CROSSING_VARIABLES
              if n not in ("crossing_count", "crossing_kind")]
    return [dict(kind=kinds[int(code)], **{f: out[f"crossing_{f}"][0, j, k, c].item()
                                           for f in fields})
            for c, code in enumerate(out["crossing_kind"][0, j, k]) if code > 0]


def _same_crossing(a, b) -> bool:
    return (a["kind"] == b["kind"] and a["period"] == b["period"]
            and abs(a["omega"] - b["omega"]) <= 1e-9 * (1.0 + abs(a["omega"])))


def _recount_crossings(out, own_shape, lo, changed, before, now, omega, level, periods):
    """The crossings of every (sigma, zeta) line of the tile that gained an orbit: those the
    grid recorded (found with every orbit it met, stored or not), and those that the line's
    orbits as the round leaves them add (study.solve.curve_seeds.line_crossings, before and after:
    only the new ones join). A line whose crossings were not recorded (-1) stays so."""
    w = np.asarray(omega, float)
    # a point's orbits enter the crossings of its two edges only: those edges are looked at
    rank = np.empty(w.size, int)
    rank[np.argsort(w, kind="stable")] = np.arange(w.size)
    for j, k in sorted({(int(j), int(k)) for _, j, k in zip(*np.nonzero(changed))}):
        if out["crossing_count"][0, j, k] < 0:
            continue
        edges = {e for i in np.nonzero(changed[:, j, k])[0] for e in (rank[i] - 1, rank[i])
                 if 0 <= e < w.size - 1}
        pts = [(lo[0] + i, lo[1] + j, lo[2] + k) for i in range(own_shape[0])]
        was = line_crossings(w, [before[p] for p in pts], level, periods, edges)
        new = [r for r in line_crossings(w, [now[p] for p in pts], level, periods, edges)
               if not any(_same_crossing(r, q) for q in was)]
        records = _crossing_records(out, j, k)
        records += [r for r in new if not any(_same_crossing(r, q) for q in records)]
        records.sort(key=lambda d: (d["omega"], BIFURCATION_KINDS[d["kind"]], d["period"]))
        for n in CROSSING_VARIABLES:
            out[n][0, j, k] = VARIABLES[n].fill
        record_line(out, CROSSING_VARIABLES, CROSSING_SLOTS, j, k, records)
