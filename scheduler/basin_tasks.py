"""``hertzmap basins``: the basin map of a store's grid point on a grid of initial states,
computed in row blocks on a Dask cluster (study.solve.basin_grid), written into the store as the
product group ``products/basin_map_omega<w>_sigma<s>_zeta<z>`` (scheduler.store) and drawn
next to it (study.plots.plot_basin_map).

The grid point is the store's nearest to the asked (omega, sigma, zeta), which must lie within
the store's axis ranges; the solver options (model, exponent, rtol) and the transient budget
(search.transient_periods, search.record_periods) are the study's, read from the store.
Everything the user gives is checked before a cluster starts or anything is written.
"""
from __future__ import annotations

import sys
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hertzmap.scheduler.cluster import ClusterSpec, close_quietly, make_client
from hertzmap.scheduler.errors import RefusedError, StoreError
from hertzmap.scheduler.interrupt import DeferInterrupt
from hertzmap.scheduler.stage import Task, TaskRunner
from hertzmap.scheduler.store import Lock, store_attrs, write_product
from hertzmap.study.schema import study_from_attrs
from hertzmap.study.spec import StudyError
from hertzmap.study.solve.basin_grid import basin_block, grid_axes, merge_blocks, row_blocks
from hertzmap.study.solve.seeds import TRANSIENT_BOX

#: the largest grid of initial states, per side (a 2000 x 2000 map is 4e6 transients)
MAX_GRID_SIDE = 2000
#: rows of the grid per task: about 2 s of a 200-cell row block at a point whose transients
#: settle, enough tasks for a few workers
ROWS_PER_TASK = 8


@dataclass(frozen=True)
class BasinRequest:
    """A checked ``hertzmap basins`` request: the store, the grid point (its indices and
    values), the grid of initial states and the box it covers."""
    store: Path
    index: tuple[int, int, int]
    point: tuple[float, float, float]
    grid: tuple[int, int]
    q_range: tuple[float, float]
    v_range: tuple[float, float]
    options: dict
    transient_periods: int
    record_periods: int
    study_name: str
    study_hash: str


def parse_grid(text: str) -> tuple[int, int]:
    """``NQxNV`` (cells along q, along v), each 2..MAX_GRID_SIDE; RefusedError naming --grid."""
    parts = str(text).lower().split("x")
    try:
        nq, nv = (int(p) for p in parts)
    except ValueError:
        raise RefusedError(f"--grid: expected NQxNV such as 200x200 (cells along q and along "
                           f"v), got {text!r}") from None
    if not (2 <= nq <= MAX_GRID_SIDE and 2 <= nv <= MAX_GRID_SIDE):
        raise RefusedError(f"--grid: each side must be 2..{MAX_GRID_SIDE} cells, got {text!r}")
    return nq, nv


def parse_range(text: str | None, option: str, default: tuple[float, float]
                ) -> tuple[float, float]:
    """``LO,HI`` with LO < HI, both finite (default: ``default``); RefusedError naming the
    option."""
    if text is None:
        return tuple(float(x) for x in default)
    try:
        lo, hi = (float(p) for p in str(text).split(","))
    except ValueError:
        raise RefusedError(f"{option}: expected LO,HI such as {default[0]:g},{default[1]:g}, "
                           f"got {text!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise RefusedError(f"{option}: expected finite LO < HI, got {text!r}")
    return lo, hi


def check_request(store: str | Path, omega: float, sigma: float, zeta: float | None,
                  grid: str, q_range: str | None, v_range: str | None) -> BasinRequest:
    """The request, checked against the store (nothing is written): RefusedError naming the
    option and what is allowed."""
    store = Path(store)
    attrs = store_attrs(store)
    try:
        study = study_from_attrs(attrs)
    except StudyError as exc:
        raise StoreError(f"{store}: not a hertzmap store ({exc})") from None
    values = {"omega": omega, "sigma": sigma, "zeta": zeta}
    index, point = [], []
    for name in ("omega", "sigma", "zeta"):
        axis = study.axis(name)
        x = values[name]
        if x is None:
            if axis.size > 1:
                raise RefusedError(f"--{name}: the store has {axis.size} {name} values "
                                   f"({axis.min():g} to {axis.max():g}): give one")
            x = float(axis[0])
        lo, hi = float(axis.min()), float(axis.max())
        span = 1e-9 * max(1.0, abs(lo), abs(hi))
        if not (np.isfinite(x) and lo - span <= x <= hi + span):
            raise RefusedError(f"--{name} {x:g} is outside the store's {name} axis "
                               f"[{lo:g}, {hi:g}]")
        i = int(np.argmin(np.abs(axis - x)))
        index.append(i)
        point.append(float(axis[i]))
    return BasinRequest(
        store, tuple(index), tuple(point), parse_grid(grid),
        parse_range(q_range, "--q-range", TRANSIENT_BOX[0]),
        parse_range(v_range, "--v-range", TRANSIENT_BOX[1]),
        dict(exponent=study.model_value.exponent, model=study.model_value.law,
             rtol=study.model_value.rtol),
        int(study.transient_periods), int(study.record_periods), study.name, study.hash)


def basin_task(spec: dict) -> dict:
    """One row block of a basin map (runs on a worker): study.solve.basin_grid.basin_block of
    the spec's point, rows and options, with the seconds it took."""
    t0 = time.perf_counter()
    w, s, z = spec["point"]
    block = basin_block(w, s, z, spec["q"], spec["v"], spec["options"],
                        spec["transient_periods"], spec["record_periods"])
    return {"block": block, "seconds": time.perf_counter() - t0}


def run_basins(req: BasinRequest, cluster: ClusterSpec, out: Path, *,
               rows_per_task: int = ROWS_PER_TASK, client=None) -> dict:
    """Compute the basin map of ``req`` on the cluster (row blocks as tasks; ``client``: an
    existing one, else one is made from ``cluster`` and closed), write the product group and
    draw the figure into ``out``. Returns the group, the figure's path, the seconds the map
    took and the map's entropies."""
    from hertzmap.study.plots import plot_basin_map
    from hertzmap.study.products.basin_map import basin_map_dataset, basin_map_name

    with Lock(req.store):       # refused while a run writes the store; nothing computed then
        pass
    omega, sigma, zeta = req.point
    q, v = grid_axes(req.q_range, req.v_range, req.grid)
    t0 = time.perf_counter()
    own = client is None
    cluster_obj = None
    if own:
        client, cluster_obj = make_client(cluster)
    try:
        rows = list(row_blocks(v.size, rows_per_task))
        call = uuid.uuid4().hex[:8]     # one map's keys: never an earlier map's results
        tasks = [Task(f"hertzmap-basins-{req.study_hash[:12]}-{call}-{i}",
                      {"point": req.point, "q": q, "v": v[s], "options": req.options,
                       "transient_periods": req.transient_periods,
                       "record_periods": req.record_periods}, q.size * (s.stop - s.start))
                 for i, s in enumerate(rows)]
        blocks: dict[str, dict] = {}
        runner = TaskRunner(client, DeferInterrupt(), sys.stderr)
        cost = runner.map("basin map", basin_task, tasks,
                          lambda task, res: blocks.update({task.key: res["block"]}), unit="points")
        if cost.failed:
            raise RuntimeError(f"basin map: {len(cost.failed)} row block(s) failed: "
                               f"{cost.failed[0][1]}")
        blocks = [blocks[t.key] for t in tasks]
    finally:
        if own:
            close_quietly(client, cluster_obj)
    bm = merge_blocks(omega, sigma, zeta, q, v, blocks, req.options, req.transient_periods,
                      req.record_periods)
    seconds = time.perf_counter() - t0
    name = basin_map_name(omega, sigma, zeta)
    ds = basin_map_dataset(bm, {"hertzmap_study_name": req.study_name,
                                "hertzmap_study_hash": req.study_hash,
                                "hertzmap_product_source": "hertzmap basins",
                                "model": req.options["model"],
                                "exponent": req.options["exponent"],
                                "grid_index": list(req.index)})
    group = write_product(req.store, name, ds)
    figure = plot_basin_map(ds, Path(out) / f"{req.study_name}_{name}.png")
    return {"group": group, "figure": figure, "seconds": seconds,
            "basin_entropy": bm.entropy.basin_entropy,
            "boundary_basin_entropy": bm.entropy.boundary_basin_entropy,
            "uncertainty_fraction": bm.uncertainty,
            "attractors": [(a["kind"], a["period"], a["count"]) for a in bm.attractors]}
