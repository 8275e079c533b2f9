"""Dense basin maps by label reuse on the stroboscopic map (issue 52; docs/basins.md): every
state's label is its own transient's fate, the transient stopped as soon as what earlier
transients found makes that fate plain (study.solve.basin_grid runs one whole census
transient per state: the brute force).

The grid of initial states (q, q') at tau = 0 is cut into cells whose centres are the map's
states (as in basin_grid). The steps, each a pure function of a spec so that the scheduler runs
the costly ones as tasks on a cluster (scheduler.stages.basin_tasks; ``run`` of cell_basin_map):

1. **The attractors** (:func:`probe_tile`, :func:`known_orbits`, :func:`certificates`): the
   stable orbits the caller knows (a store's at the point, by their start points) and those the
   census's transients from a PROBE_GRID over the box reach, each once (same_cycle), with a
   certified neighbourhood at every phase of its orbit (study.solve.certificate; SEED_SHARE of
   the certified level, a factor 2 in radius in reserve).
2. **The evidence** (:func:`evidence_grid`): per cell, the attractor the states seen in it
   reached (a cell's own state, and every cell a transient passed through; CONFLICT where two
   attractors were seen), on the map's cells extended to the orbits' points.
3. **Rounds of tiles** (:func:`round_tiles`, :func:`reuse_tile`, :func:`merge_evidence`):
   ROUNDS coarse-to-fine rounds (every 8th cell along each axis, then every 4th, 2nd, all),
   each cut into tiles of ROWS_PER_TILE rows; a tile's transients
   (kernels.label_reuse.reuse_into) start from the evidence of the rounds before and stop in
   a uniform block of evidence (REUSE_RADIUS cells each side, VISITS periods) or once they show
   a certified neighbourhood's contraction, at most SETTLE_PERIODS; the tiles' evidence is
   joined after each round. No label is taken from a mixed neighbourhood: a state near a
   boundary is integrated until its own fate is plain.
4. **What that did not settle** (:func:`census_tile`, :func:`resolve_open`,
   :func:`join_resolved`): the census's own transient (study.solve.census.run_transients:
   period detection, shooting, recognition on the certified neighbourhoods) for
   transient_periods + record_periods: a stable orbit the probe missed becomes a new attractor;
   transients that never settle are ``unsettled`` (or ``non_periodic``, the census's Lyapunov
   test, where no stable orbit exists), failures ``failed``, as in basin_grid.
5. :func:`assemble`: a basin_grid.BasinMap (labels, attractors, entropies as the brute
   force's), with ``method`` per cell: REUSED (step 3) or CENSUS (step 4); SEED (a state
   labelled for lying in a certified neighbourhood) is not used: every state's transient shows
   the contraction itself.

The tiles are fixed by the grid and a task is a pure function of its spec, so the map does not
depend on the number of workers or the order the tasks finish in. Why not Hsu's cell mapping
with set-valued images, and how exact the map is: docs/basins.md (measured with
benchmarks/basins_agreement.py).
"""
from __future__ import annotations

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.attractors import A, N_ATTRACTOR_FIELDS, C_LEVEL
from hertzmap.kernels.label_reuse import (CONFLICT, FAILED, OPEN, UNSEEN,
                                         reuse_into)
from hertzmap.kernels.records import STROBE_POINTS
from hertzmap.kernels.shooting import N_FIELDS
from hertzmap.study.basin_entropy import BOX_SIDE
from hertzmap.study.solve import basin_grid
from hertzmap.study.solve.basin_grid import BasinBlock, BasinMap, basin_block, grid_axes, merge_blocks
from hertzmap.study.solve.census import run_transients, strobe_points, transient_settings
from hertzmap.study.solve.certificate import certify, orbit_points
from hertzmap.study.solve.point import solutions_from_rows
from hertzmap.study.solve.recognition import KnownAttractors
from hertzmap.study.solve.seeds import TRANSIENT_BOX

#: the probe grid of census transients that finds the attractors (cells along q, along q')
PROBE_GRID = (16, 16)
#: the share of a certified level V <= c taken (a factor 2 in radius held in reserve)
SEED_SHARE = 0.25
#: cells each side of the block of uniform evidence a transient stops in
REUSE_RADIUS = 1
#: consecutive periods in such blocks before it stops
VISITS = 1
#: rows of cells per tile of a round (a task)
ROWS_PER_TILE = 100
#: states per task of step 5
CENSUS_CHUNK = 256
#: the evidence grid reaches out to the orbits' points with this margin (a share of the box),
#: at most EVIDENCE_REACH times the box along each axis
EVIDENCE_MARGIN = 0.1
EVIDENCE_REACH = 3.0
#: coarse-to-fine rounds: round r computes every 2^(ROUNDS - 1 - r)-th cell along each axis
ROUNDS = 4
#: the most periods a state's own trajectory is followed to a certain cell (step 4)
SETTLE_PERIODS = 300
#: the integrator's steps per period at most (as the census's)
MAX_STEPS = 200_000
#: per-cell method codes (``BasinMap.method``)
SEED, REUSED, CENSUS = 0, 1, 2
METHODS = {SEED: "seed", REUSED: "reused", CENSUS: "census"}


def _model(options: dict) -> tuple[float, int, float]:
    """(exponent, law code, the transients' rtol) of the solver's options."""
    n, code, t_rtol, _ = transient_settings(options)
    return float(n), int(code), float(t_rtol)


def box_of(q_range, v_range, grid) -> np.ndarray:
    """The kernels' grid geometry (kernels.cell_mapping B_* columns)."""
    (q0, q1), (v0, v1), (nq, nv) = q_range, v_range, grid
    return np.array([q0, v0, (q1 - q0) / nq, (v1 - v0) / nv], float)


def same_cycle(sol: dict, orbit: dict, tol: float = 1e-6) -> bool:
    """Whether the stable orbit ``sol`` (period, x0) is ``orbit`` (period, ``phases``: its m
    stroboscopic points): the same period and x0 within tol (1 + |x0|) of one of its points
    (any phase: shooting may start an orbit at any of its points)."""
    x0 = np.asarray(sol["x0"], float)
    return int(sol["period"]) == int(orbit["period"]) and bool(
        np.min(np.hypot(*(np.asarray(orbit["phases"]) - x0).T)) <= tol * (1 + np.hypot(*x0)))


def known_orbits(omega: float, sigma: float, zeta: float, options: dict, orbits=(),
                 probes=()) -> list[dict]:
    """The stable orbits the map starts from, each once (same_cycle), with ``phases`` (its m
    stroboscopic points), ``strobe`` and ``count`` 0: ``orbits`` (solution dicts with period,
    x0, stable; a store's at the point) and those of the probe blocks ``probes`` (the census's
    transients from a coarse grid over the box: :func:`probe_tile`)."""
    found: list[dict] = []
    candidates = [s for s in orbits if s.get("stable")
                  and s.get("status", st.CONVERGED) == st.CONVERGED]
    candidates += [s for b in probes for s in b.orbits]
    for sol in candidates:
        if any(same_cycle(sol, o) for o in found):
            continue
        pts = orbit_points(sol, omega, sigma, zeta, options)
        if pts is not None and np.all(np.isfinite(pts)):
            found.append(dict(sol, phases=pts, strobe=sol.get("strobe", pts), count=0))
    return found


def probe_tile(spec: dict) -> dict:
    """A block of the probe grid (a task): basin_grid.basin_block of the spec's point, states
    and options."""
    w, s, z = spec["point"]
    return {"block": basin_block(w, s, z, spec["q"], spec["v"], spec["options"],
                                 spec["transient_periods"], spec["record_periods"])}


def certificates(orbits: list[dict], omega: float, sigma: float, zeta: float, options: dict
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The certified neighbourhoods of every phase of each orbit (rows of kernels.attractors'
    C_* columns, the level at SEED_SHARE of the certified one) and each row's label (the
    orbit's index in ``orbits``). An orbit whose neighbourhood cannot be certified has none:
    its cells are integrated."""
    phases = [np.asarray(o["phases"], float) for o in orbits]
    rows, labels = [], []
    for label, (sol, pts) in enumerate(zip(orbits, phases)):
        others = np.concatenate([p for k, p in enumerate(phases) if k != label] + [pts])
        for phase, x in enumerate(pts):
            keep = np.ones(len(others), bool)
            keep[len(others) - len(pts) + phase] = False          # not its own point
            row = certify({"x0": x, "period": int(sol["period"]), "stable": True},
                          omega, sigma, zeta, options, others[keep])
            if row is not None:
                row = row.copy()
                row[C_LEVEL] *= SEED_SHARE
                rows.append(row)
                labels.append(label)
    return (np.ascontiguousarray(np.array(rows, float).reshape(-1, 8)),
            np.ascontiguousarray(np.array(labels, np.int64)))


def round_cells(grid, round_: int, rounds: int = ROUNDS) -> np.ndarray:
    """The flat indices (row-major, rows along q') of the cells first computed in round
    ``round_`` (0-based) of ``rounds``: every 2^(rounds - 1 - round_)-th cell along each axis,
    less those of the earlier rounds (coarse to fine)."""
    nq, nv = grid
    stride = 1 << (rounds - 1 - round_)
    ii, jj = np.meshgrid(np.arange(nv), np.arange(nq), indexing="ij")
    mine = (ii % stride == 0) & (jj % stride == 0)
    if round_ > 0:
        coarser = stride * 2
        mine &= ~((ii % coarser == 0) & (jj % coarser == 0))
    return np.flatnonzero(mine.reshape(-1))


def evidence_grid(q_range, v_range, grid, orbits: list[dict], reach: float = EVIDENCE_REACH
                  ) -> tuple[np.ndarray, tuple[int, int], tuple[int, int]]:
    """The grid of evidence: the map's cells, extended by whole cells of the same size to cover
    the orbits' stroboscopic points with a margin of EVIDENCE_MARGIN of the box (transients
    that leave the box on their way to an orbit out there find evidence there too), at most
    ``reach`` times the box along each axis. Returns its geometry (kernels.label_reuse B_*
    columns), its shape (rows along q', columns along q) and the offset (rows, columns) of
    the map's cell (0, 0) in it."""
    nq, nv = grid
    (q0, q1), (v0, v1) = q_range, v_range
    hq, hv = (q1 - q0) / nq, (v1 - v0) / nv
    pts = np.concatenate([np.asarray(o["phases"], float).reshape(-1, 2) for o in orbits]
                         + [np.empty((0, 2))])
    pad_q, pad_v = EVIDENCE_MARGIN * (q1 - q0), EVIDENCE_MARGIN * (v1 - v0)
    lo_q = max(min(q0, *(pts[:, 0] - pad_q)), q0 - (reach - 1) / 2 * (q1 - q0)) if len(pts) \
        else q0
    hi_q = min(max(q1, *(pts[:, 0] + pad_q)), q1 + (reach - 1) / 2 * (q1 - q0)) if len(pts) \
        else q1
    lo_v = max(min(v0, *(pts[:, 1] - pad_v)), v0 - (reach - 1) / 2 * (v1 - v0)) if len(pts) \
        else v0
    hi_v = min(max(v1, *(pts[:, 1] + pad_v)), v1 + (reach - 1) / 2 * (v1 - v0)) if len(pts) \
        else v1
    left, right = int(np.ceil((q0 - lo_q) / hq)), int(np.ceil((hi_q - q1) / hq))
    down, up = int(np.ceil((v0 - lo_v) / hv)), int(np.ceil((hi_v - v1) / hv))
    box = np.array([q0 - left * hq, v0 - down * hv, hq, hv])
    return box, (nv + down + up, nq + left + right), (down, left)


def to_evidence(cells: np.ndarray, grid, shape, offset) -> np.ndarray:
    """The flat indices on the evidence grid of the map's cells (flat indices)."""
    nq, _ = grid
    cells = np.asarray(cells, np.int64)
    return (cells // nq + offset[0]) * shape[1] + cells % nq + offset[1]


def reuse_cells(omega: float, sigma: float, zeta: float, options: dict, q_range, v_range,
                grid, evidence: np.ndarray, evidence_box: np.ndarray, cells: np.ndarray,
                cert: np.ndarray, cert_label: np.ndarray, radius: int = REUSE_RADIUS,
                visits: int = VISITS, budget: int = SETTLE_PERIODS) -> dict:
    """The transients of the map's cells ``cells`` (flat indices, in that order) stopping on
    the evidence (kernels.label_reuse.reuse_into), on a copy of ``evidence`` (its grid
    ``evidence_box``: evidence_grid): a tile of a round. Returns ``label`` (OPEN, FAILED or an
    orbit's index), ``periods`` and the evidence it added (``changed``: flat indices on the
    evidence grid, ``values``)."""
    nq, nv = grid
    q, v = grid_axes(q_range, v_range, grid)
    cells = np.asarray(cells, np.int64)
    own = np.array(evidence, np.int16, copy=True)
    n, code, rtol = _model(options)
    k = len(cells)
    label = np.empty(k, np.int64)
    periods = np.empty(k, np.int64)
    reuse_into(float(omega), float(sigma), float(zeta), n, code, rtol, MAX_STEPS,
               np.ascontiguousarray(q[cells % nq]), np.ascontiguousarray(v[cells // nq]),
               int(budget), own, np.asarray(evidence_box, float), int(radius), int(visits),
               np.ascontiguousarray(cert, float).reshape(-1, 8),
               np.ascontiguousarray(cert_label, np.int64), label, periods, np.empty((k, 2)))
    changed = np.flatnonzero(own.reshape(-1) != np.asarray(evidence).reshape(-1))
    return {"label": label, "periods": periods, "changed": changed,
            "values": own.reshape(-1)[changed]}


def merge_evidence(evidence: np.ndarray, tiles: list[dict]) -> np.ndarray:
    """The evidence (flat int16) after a round: each tile's additions joined (a cell given two
    labels by two tiles, or one against what it held, is CONFLICT)."""
    out = np.array(evidence, np.int16, copy=True).reshape(-1)
    before = out.copy()
    for t in tiles:
        idx, val = t["changed"], t["values"].astype(np.int16)
        held = out[idx]
        fresh = before[idx] == UNSEEN
        take = fresh & ((held == UNSEEN) | (held == val))
        out[idx] = np.where(take, val, CONFLICT)
    return out


def round_tiles(grid, round_: int, rows_per_tile: int, rounds: int = ROUNDS
                ) -> list[np.ndarray]:
    """The tiles of a round: its cells (round_cells) cut into blocks of ``rows_per_tile`` rows
    along q' (the tasks of the scheduler; a fixed cut, so that the map does not depend on how
    many workers run it)."""
    nq, _ = grid
    cells = round_cells(grid, round_, rounds)
    rows = cells // nq
    return [cells[(rows >= s.start) & (rows < s.stop)]
            for s in basin_grid.row_blocks(grid[1], rows_per_tile)
            if np.any((rows >= s.start) & (rows < s.stop))]


def resolve_open(omega: float, sigma: float, zeta: float, options: dict, orbits: list[dict],
                 cert: np.ndarray, cert_label: np.ndarray, q0: np.ndarray, v0: np.ndarray,
                 transient_periods: int, record_periods: int) -> BasinBlock:
    """Step 5: the census's transients from the states (q0, v0), recognised on the certified
    neighbourhoods, as a basin_grid.BasinBlock whose outcome indexes ``orbits`` first, then
    the stable orbits found here (its ``orbits``: the given ones, count 0, then the new)."""
    k = len(q0)
    known = KnownAttractors()
    for i, row in enumerate(cert):
        # one recognition label per certified phase (negative: periodic, as the census's)
        known.add_certified(-1 - i, row)
    label_of = {-1 - i: int(lab) for i, lab in enumerate(cert_label)}
    rows = np.empty((k, N_ATTRACTOR_FIELDS))
    orbit_rows = np.empty((k, N_FIELDS))
    strobes = np.empty((k, STROBE_POINTS, 2))
    run_transients(omega, sigma, zeta, np.asarray(q0, float), np.asarray(v0, float),
                   dict(options, harmonics=False), transient_periods, record_periods, rows,
                   orbit_rows, strobes, known=known)
    block = BasinBlock(np.full(k, basin_grid.FAILED, np.int32),
                       [dict(o, count=0) for o in orbits])
    for r in range(k):
        status = int(rows[r, A["status"]])
        if status == st.RECOGNISED:
            block.outcome[r] = label_of[int(rows[r, A["recognised_as"]])]
        elif status == st.CONVERGED:
            sol = solutions_from_rows(orbit_rows[r:r + 1], int(rows[r, A["period"]]))[0]
            if sol["status"] != st.CONVERGED:
                block.outcome[r] = basin_grid.OPEN
                continue
            idx = next((i for i, o in enumerate(block.orbits) if same_cycle(sol, o)), None)
            if idx is None:
                pts = orbit_points(sol, omega, sigma, zeta, options)
                if pts is None:
                    block.outcome[r] = basin_grid.OPEN
                    continue
                idx = len(block.orbits)
                block.orbits.append(dict(sol, count=0, phases=pts,
                                         strobe=strobe_points(strobes[r], rows[r])))
            block.outcome[r] = idx
        elif status in (st.UNSETTLED, st.UNCONFIRMED):
            block.outcome[r] = basin_grid.OPEN
            window = float(np.nan_to_num(rows[r, A["window_periods"]]))
            if window > block.open_window:
                block.open_window = window
                block.open_end = (float(rows[r, A["q_end"]]), float(rows[r, A["v_end"]]))
                block.open_strobe = strobe_points(strobes[r], rows[r])
    return block


def join_resolved(orbits: list[dict], blocks: list[BasinBlock]) -> BasinBlock | None:
    """Step 5's blocks (each on ``orbits`` then its own new orbits) as one block on ``orbits``
    then every new orbit once (same_cycle), the open runs' representative the one with the
    longest window."""
    if not blocks:
        return None
    joined = [dict(o) for o in orbits]
    parts = []
    for b in blocks:
        local = np.empty(len(b.orbits) + 2, np.int64)
        for i, o in enumerate(b.orbits):
            g = i if i < len(orbits) else next(
                (j for j, p in enumerate(joined) if same_cycle(o, p)), None)
            if g is None:
                g = len(joined)
                joined.append(dict(o))
            local[i] = g
        local[basin_grid.OPEN], local[basin_grid.FAILED] = basin_grid.OPEN, basin_grid.FAILED
        parts.append(local[b.outcome])
    rep = max(blocks, key=lambda b: b.open_window)
    out = BasinBlock(np.concatenate(parts), joined)
    out.open_end, out.open_window, out.open_strobe = rep.open_end, rep.open_window, rep.open_strobe
    return out


def reuse_tile(spec: dict) -> dict:
    """A tile of a round (a task): reuse_cells of the spec."""
    return reuse_cells(*spec["point"], spec["options"], spec["q_range"], spec["v_range"],
                       spec["grid"], spec["evidence"], spec["evidence_box"], spec["cells"],
                       spec["cert"], spec["cert_label"], spec["radius"], spec["visits"])


def census_tile(spec: dict) -> dict:
    """A block of step 5 (a task): resolve_open of the spec's states."""
    return {"block": resolve_open(*spec["point"], spec["options"], spec["orbits"], spec["cert"],
                                  spec["cert_label"], spec["q"], spec["v"],
                                  spec["transient_periods"], spec["record_periods"])}


def run_here(name: str, function, specs: list[dict], sizes=None) -> list[dict]:
    """Tasks run in this process, in order (cell_basin_map's default ``run``)."""
    return [function(s) for s in specs]


def assemble(omega: float, sigma: float, zeta: float, options: dict, q_range, v_range, grid,
             orbits: list[dict], outcome: np.ndarray, method: np.ndarray,
             resolved: BasinBlock | None, open_cells: np.ndarray, transient_periods: int,
             record_periods: int, box: int = BOX_SIDE) -> BasinMap:
    """The BasinMap of the steps' outcomes: ``outcome`` (flat) step 4's labels (indices into
    ``orbits``, OPEN, FAILED) and ``method`` (flat), ``resolved`` step 5's block for the flat
    indices ``open_cells`` (in that order; its orbits: ``orbits`` then the new ones). Orbits
    no cell reached are left out (a store's orbit whose basin misses the box)."""
    nq, nv = grid
    q, v = grid_axes(q_range, v_range, grid)
    outcome = np.array(outcome, np.int64).reshape(-1)
    method = np.array(method, np.int8).reshape(-1)
    block = BasinBlock(outcome, [dict(o) for o in orbits])
    if resolved is not None and len(open_cells):
        block.orbits = [dict(o) for o in resolved.orbits]
        outcome[open_cells] = resolved.outcome
        method[open_cells] = CENSUS
        block.open_end, block.open_window = resolved.open_end, resolved.open_window
        block.open_strobe = resolved.open_strobe
    counts = np.bincount(outcome[outcome >= 0], minlength=len(block.orbits))
    used = [i for i in range(len(block.orbits)) if counts[i] > 0]
    remap = np.full(len(block.orbits) + 2, -99, np.int64)
    remap[used] = np.arange(len(used))
    remap[basin_grid.OPEN], remap[basin_grid.FAILED] = basin_grid.OPEN, basin_grid.FAILED
    block.outcome = remap[np.where(outcome == FAILED, basin_grid.FAILED,
                                   np.where(outcome == OPEN, basin_grid.OPEN, outcome))
                          ].reshape(nv, nq)
    block.orbits = [dict(block.orbits[i], count=int(counts[i])) for i in used]
    bm = merge_blocks(omega, sigma, zeta, q, v, [block], options, transient_periods,
                      record_periods, box)
    bm.method = method.reshape(nv, nq)
    return bm


def cell_basin_map(omega: float, sigma: float, zeta: float, q_range=TRANSIENT_BOX[0],
                   v_range=TRANSIENT_BOX[1], grid: tuple[int, int] = (1000, 1000), *,
                   options: dict | None = None, orbits=(), transient_periods: int = 500,
                   record_periods: int = 128, box: int = BOX_SIDE,
                   rows_per_tile: int = ROWS_PER_TILE, probe=PROBE_GRID,
                   radius: int = REUSE_RADIUS, visits: int = VISITS, rounds: int = ROUNDS,
                   census_chunk: int = CENSUS_CHUNK, stats: dict | None = None,
                   run=run_here) -> BasinMap:
    """The basin map at (omega, sigma, zeta) on ``grid`` = (cells along q, along q') over
    q_range x v_range by label reuse (module docstring). ``orbits``: stable orbits known at the
    point (solution dicts; the probe finds them otherwise); ``options``: the solver's
    (exponent, model, rtol); ``stats``: a dict that receives the steps' counts. ``run(name,
    function, specs)``: runs a list of tasks and returns their results in order (default: in
    this process; scheduler.stages.basin_tasks runs them on a Dask cluster, the same specs, so the map
    does not depend on where it ran)."""
    options = dict(options or {})
    point = (float(omega), float(sigma), float(zeta))
    nq, nv = grid
    budget = dict(transient_periods=int(transient_periods), record_periods=int(record_periods))
    probes = []
    if probe and min(probe) > 0:
        pq, pv = grid_axes(q_range, v_range, probe)
        probes = [r["block"] for r in run("probe", probe_tile, [
            dict(point=point, q=pq, v=pv[s], options=options, **budget)
            for s in basin_grid.row_blocks(len(pv), max(1, len(pv) // 2))])]
    known = known_orbits(omega, sigma, zeta, options, orbits, probes)
    cert, cert_label = certificates(known, omega, sigma, zeta, options)
    # no state is labelled by its position alone: each one's transient shows the contraction
    seeds = np.full(nq * nv, -1, np.int64)
    ev_box, ev_shape, offset = evidence_grid(q_range, v_range, grid, known)
    evidence = np.full(ev_shape, UNSEEN, np.int16)
    evidence.reshape(-1)[to_evidence(np.arange(nq * nv), grid, ev_shape, offset)] = \
        np.where(seeds >= 0, seeds, UNSEEN)
    outcome = np.where(seeds >= 0, seeds, OPEN).astype(np.int64)
    method = np.full(outcome.size, SEED, np.int8)
    periods = np.zeros(outcome.size, np.int64)
    common = dict(point=point, options=options, q_range=tuple(q_range), v_range=tuple(v_range),
                  grid=tuple(grid), cert=cert, cert_label=cert_label, radius=int(radius),
                  visits=int(visits), evidence_box=ev_box)
    for r in range(rounds):
        tiles = [c[seeds[c] < 0] for c in round_tiles(grid, r, rows_per_tile, rounds)]
        tiles = [c for c in tiles if len(c)]
        done = run(f"round {r + 1}/{rounds}", reuse_tile,
                   [dict(common, evidence=evidence, cells=c) for c in tiles])
        for c, t in zip(tiles, done):
            outcome[c], periods[c], method[c] = t["label"], t["periods"], REUSED
        evidence = merge_evidence(evidence, done).reshape(ev_shape)
    open_cells = np.flatnonzero(outcome < 0)
    q, v = grid_axes(q_range, v_range, grid)
    chunks = [open_cells[i:i + census_chunk] for i in range(0, len(open_cells), census_chunk)]
    blocks = [r["block"] for r in run("census", census_tile, [
        dict(point=point, options=options, orbits=known, cert=cert, cert_label=cert_label,
             q=q[c % nq], v=v[c // nq], **budget) for c in chunks])]
    resolved = join_resolved(known, blocks)
    if stats is not None:
        stats.update(periods=int(periods.sum()), mean_periods=float(periods.mean()),
                     orbits=len(known), certified=len(cert), seeds=int((seeds >= 0).sum()),
                     census=len(open_cells), conflict=int((evidence == CONFLICT).sum()))
    return assemble(omega, sigma, zeta, options, q_range, v_range, grid, known, outcome,
                    method, resolved, open_cells, transient_periods, record_periods, box)
