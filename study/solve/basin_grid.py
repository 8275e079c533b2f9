"""Basins of attraction: where each initial state (q, q') at tau = 0 ends in the long run, on
a grid of initial states a user chooses (:func:`basin_map`) (the basin entropy of the
census's own initial states at a grid point: study.solve.census.census_basin_entropy).

A basin map runs one transient per cell of the grid (kernels.attractors.attractor_batch_into,
the census's kernel, with the census's detection and refinement: study.solve.census) and
labels each cell by its outcome:

* a stable periodic orbit (confirmed by shooting; two orbits are the same by
  study.orbit_rules.same_orbit): one label per orbit, the largest basin first;
* a transient that did not settle within the budget: one label, ``non_periodic`` when no stable
  orbit was reached from any cell and the largest Lyapunov exponent of a representative
  (Benettin over record_periods, the census's test: study.solve.census.is_chaotic) is positive,
  ``unsettled`` otherwise (the census's longer passes are not run: a long transient stays
  unsettled);
* an integration failure: one label, ``failed``.

The grid is cut into row blocks (:func:`basin_block`, one task each for the scheduler), whose
outcomes :func:`merge_blocks` joins into one :class:`BasinMap`; :func:`basin_map` does both in
this process. Pure numpy over the kernels: no Dask, no I/O.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.attractors import A, N_ATTRACTOR_FIELDS
from hertzmap.kernels.records import STROBE_POINTS
from hertzmap.kernels.shooting import N_FIELDS
from hertzmap.study.basin_entropy import BOX_SIDE, BasinEntropy, basin_entropy, uncertainty_fraction
from hertzmap.study.orbit_rules import same_orbit
from hertzmap.study.solve.census import (is_chaotic, run_transients, strobe_points,
                                         window_exponent)
from hertzmap.study.solve.point import solutions_from_rows
from hertzmap.study.solve.seeds import TRANSIENT_BOX

#: a block's outcome code of a cell whose transient did not settle / failed (>= 0: the index
#: of a periodic attractor in the block's ``orbits``)
OPEN, FAILED = -1, -2


@dataclass
class BasinBlock:
    """The outcomes of one row block of a basin map: ``outcome`` per cell (OPEN, FAILED, or an
    index into ``orbits``), the block's stable orbits (solution dicts, each with ``count`` and
    ``strobe``, the last stroboscopic points of a transient that reached it), and for the open
    cells the representative (end state, periods in its window, strobe points)."""
    outcome: np.ndarray
    orbits: list[dict]
    open_end: tuple[float, float] | None = None
    open_window: float = -1.0
    open_strobe: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))


@dataclass
class BasinMap:
    """A basin map on the grid ``q`` x ``v`` (cell centres; dimensionless) at (omega, sigma,
    zeta). ``labels`` (len(v), len(q)): the index of each cell's attractor in ``attractors``
    (a list of dicts: kind (ATTRACTOR_KINDS name), period, q0, v0 (a periodic attractor's orbit
    start point at tau = 0; NaN otherwise), count (cells), strobe (its last stroboscopic
    points, (n, 2))). ``entropy``: S_b and S_bb over boxes of ``box`` x ``box`` cells (nats);
    ``uncertainty``: the uncertainty fraction at eps = one cell."""
    omega: float
    sigma: float
    zeta: float
    q: np.ndarray
    v: np.ndarray
    labels: np.ndarray
    attractors: list[dict]
    entropy: BasinEntropy
    uncertainty: float
    box: int
    transient_periods: int
    record_periods: int
    #: per cell, how its label was obtained (study.solve.cell_basins.METHODS); None: every
    #: cell ran its own census transient (this module's map)
    method: np.ndarray | None = None


def grid_axes(q_range, v_range, grid: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The cell centres along q (grid[0] cells over q_range) and along v (grid[1] over
    v_range)."""
    (q0, q1), (v0, v1), (nq, nv) = q_range, v_range, grid
    return (q0 + (np.arange(nq) + 0.5) * (q1 - q0) / nq,
            v0 + (np.arange(nv) + 0.5) * (v1 - v0) / nv)


def basin_block(omega: float, sigma: float, zeta: float, q: np.ndarray, v: np.ndarray,
                options: dict, transient_periods: int, record_periods: int) -> BasinBlock:
    """The transients from the cells (v[i], q[j]) of a row block (``v``: the block's rows) at
    (omega, sigma, zeta), grouped into the block's stable orbits. ``options``: the solver's
    (exponent, model, rtol); the transient budget as the census's (transient_periods, then a
    record window of record_periods)."""
    qq, vv = np.meshgrid(np.asarray(q, float), np.asarray(v, float))
    k = qq.size
    rows = np.empty((k, N_ATTRACTOR_FIELDS))
    orbit_rows = np.empty((k, N_FIELDS))
    strobes = np.empty((k, STROBE_POINTS, 2))
    # harmonics off: the refined orbit's force harmonics are not used here
    run_transients(omega, sigma, zeta, qq.ravel(), vv.ravel(), dict(options, harmonics=False),
                   transient_periods, record_periods, rows, orbit_rows, strobes)
    outcome = np.full(k, FAILED, np.int32)
    block = BasinBlock(outcome.reshape(qq.shape), [])
    for r in range(k):
        status = int(rows[r, A["status"]])
        if status == st.CONVERGED:
            sol = solutions_from_rows(orbit_rows[r:r + 1], int(rows[r, A["period"]]))[0]
            if sol["status"] != st.CONVERGED:
                outcome[r] = OPEN
                continue
            idx = next((i for i, s in enumerate(block.orbits) if same_orbit(sol, s)), None)
            if idx is None:
                idx = len(block.orbits)
                sol.update(count=0, strobe=strobe_points(strobes[r], rows[r]))
                block.orbits.append(sol)
            block.orbits[idx]["count"] += 1
            outcome[r] = idx
        elif status in (st.UNSETTLED, st.UNCONFIRMED):
            outcome[r] = OPEN
            window = float(np.nan_to_num(rows[r, A["window_periods"]]))
            if window > block.open_window:
                block.open_window = window
                block.open_end = (float(rows[r, A["q_end"]]), float(rows[r, A["v_end"]]))
                block.open_strobe = strobe_points(strobes[r], rows[r])
    block.outcome = outcome.reshape(qq.shape)
    return block


def merge_blocks(omega: float, sigma: float, zeta: float, q: np.ndarray, v: np.ndarray,
                 blocks: list[BasinBlock], options: dict, transient_periods: int,
                 record_periods: int, box: int = BOX_SIDE) -> BasinMap:
    """The basin map of row blocks (in row order, covering ``v``): the blocks' orbits joined by
    the identity rule, the open cells' kind decided once (module docstring), the entropies."""
    orbits: list[dict] = []
    parts = []
    for b in blocks:
        local = np.empty(len(b.orbits) + 2, np.int64)       # local index (and OPEN, FAILED)
        for i, sol in enumerate(b.orbits):
            # one block's orbits are distinct already (its own identity rule)
            g = None if len(blocks) == 1 else next(
                (j for j, s in enumerate(orbits) if same_orbit(sol, s)), None)
            if g is None:
                g = len(orbits)
                orbits.append(dict(sol, count=0))
            orbits[g]["count"] += sol["count"]
            local[i] = g
        local[OPEN], local[FAILED] = -1, -2
        parts.append(local[b.outcome])
    outcome = np.concatenate(parts, axis=0)
    order = sorted(range(len(orbits)), key=lambda g: -orbits[g]["count"])
    attractors = [dict(kind="periodic", period=int(orbits[g]["period"]),
                       q0=float(orbits[g]["x0"][0]), v0=float(orbits[g]["x0"][1]),
                       count=int(orbits[g]["count"]), strobe=orbits[g]["strobe"])
                  for g in order]
    labels = np.full(outcome.shape, -1, np.int16)
    for new, g in enumerate(order):
        labels[outcome == g] = new
    n_open = int((outcome == -1).sum())
    if n_open:
        rep = max(blocks, key=lambda b: b.open_window)
        kind = "unsettled"
        if not attractors and rep.open_end is not None:
            row = window_exponent(omega, sigma, zeta, rep.open_end, options, record_periods,
                                  np.full(N_ATTRACTOR_FIELDS, np.nan))
            kind = "non_periodic" if is_chaotic(row) else "unsettled"
        labels[outcome == -1] = len(attractors)
        attractors.append(dict(kind=kind, period=0, q0=np.nan, v0=np.nan, count=n_open,
                               strobe=rep.open_strobe))
    n_failed = int((outcome == -2).sum())
    if n_failed:
        labels[outcome == -2] = len(attractors)
        attractors.append(dict(kind="failed", period=0, q0=np.nan, v0=np.nan, count=n_failed,
                               strobe=np.empty((0, 2))))
    box = max(1, min(int(box), *labels.shape))
    return BasinMap(float(omega), float(sigma), float(zeta), np.asarray(q, float),
                    np.asarray(v, float), labels, attractors, basin_entropy(labels, box),
                    uncertainty_fraction(labels), box, int(transient_periods),
                    int(record_periods))


def row_blocks(rows: int, size: int) -> list[slice]:
    """The row blocks of a grid of ``rows`` rows, ``size`` rows each (the last one shorter)."""
    return [slice(i, min(i + size, rows)) for i in range(0, rows, max(1, int(size)))]


def basin_map(omega: float, sigma: float, zeta: float, q_range=TRANSIENT_BOX[0],
              v_range=TRANSIENT_BOX[1], grid: tuple[int, int] = (200, 200), *,
              options: dict | None = None, transient_periods: int = 500,
              record_periods: int = 128, box: int = BOX_SIDE, rows_per_block: int = 8
              ) -> BasinMap:
    """The basin map at (omega, sigma, zeta) on ``grid`` = (cells along q, cells along v) over
    q_range x v_range (dimensionless initial states at tau = 0; default the census's box,
    study.solve.seeds.TRANSIENT_BOX), in this process (module docstring). ``options``: the
    solver's (exponent, model, rtol; default Hertz, 1.5, 1e-10)."""
    options = dict(options or {})
    q, v = grid_axes(q_range, v_range, grid)
    blocks = [basin_block(omega, sigma, zeta, q, v[s], options, transient_periods,
                          record_periods) for s in row_blocks(v.size, rows_per_block)]
    return merge_blocks(omega, sigma, zeta, q, v, blocks, options, transient_periods,
                        record_periods, box)
