"""``hertzmap basins``: the basin map of a store's grid point on a grid of initial states,
computed as tiles on a Dask cluster, written into the store as the product group
``products/basin_map_omega<w>_sigma<s>_zeta<z>`` (scheduler.store) and drawn next to it
(study.plots.plot_basin_map).

Two methods. ``reuse`` (the default; study.solve.dense_basins): a probe of census transients,
then coarse-to-fine rounds of transients that stop where earlier ones already tell their fate,
each round cut into tiles of rows (one task each, the round's evidence scattered once to the
workers), then the census's whole transient for what did not settle; the map does not depend on
the number of workers (the tiles are fixed by the grid). ``transients`` (study.solve.basin_grid):
one census transient per state, in row blocks: the brute force.

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

from hertzmap.scheduler.cluster.clusters import ClusterSpec, close_quietly, make_client
from hertzmap.scheduler.errors import RefusedError, StoreError
from hertzmap.scheduler.interrupt import DeferInterrupt
from hertzmap.scheduler.stages.stage import Task, TaskRunner
from hertzmap.scheduler.store import Lock, store_attrs, write_product
from hertzmap.study.schema import study_from_attrs
from hertzmap.study.spec import StudyError
from hertzmap.study.solve import dense_basins
from hertzmap.study.solve.basin_grid import basin_block, grid_axes, merge_blocks, row_blocks
from hertzmap.study.solve.seeds import TRANSIENT_BOX

#: the largest grid of initial states, per side (a 2000 x 2000 map is 4e6 transients)
MAX_GRID_SIDE = 2000
#: rows of the grid per task: about 2 s of a 200-cell row block at a point whose transients
#: settle, enough tasks for a few workers
ROWS_PER_TASK = 8
#: the methods of ``hertzmap basins --method`` (module docstring), the first the default
METHODS = ("reuse", "transients")


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
    method: str = METHODS[0]


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
                  grid: str, q_range: str | None, v_range: str | None,
                  method: str = METHODS[0]) -> BasinRequest:
    """The request, checked against the store (nothing is written): RefusedError naming the
    option and what is allowed."""
    if method not in METHODS:
        raise RefusedError(f"--method: one of {', '.join(METHODS)}, got {method!r}")
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
        int(study.transient_periods), int(study.record_periods), study.name, study.hash,
        method)


#: the tasks of the reuse method, by name (study.solve.dense_basins)
TILE_FUNCTIONS = {"probe": dense_basins.probe_tile, "round": dense_basins.reuse_tile,
                  "census": dense_basins.census_tile}


def basin_tile_task(spec: dict) -> dict:
    """One task of the reuse method (runs on a worker): the spec's ``step`` (probe, round,
    census) of study.solve.dense_basins, with the seconds it took."""
    t0 = time.perf_counter()
    out = dict(TILE_FUNCTIONS[spec["step"]](spec))
    out["seconds"] = time.perf_counter() - t0
    return out


def store_orbits(req: BasinRequest) -> list[dict]:
    """The stable orbits the store holds at the request's grid point (solution dicts: period,
    x0, stable, status), where the map's transients start knowing them."""
    import xarray as xr

    from hertzmap.study.products.results import open_store

    try:
        ds = open_store(req.store, load=False)
        i, j, k = req.index
        pt = ds.isel(omega=i, sigma=j, zeta=k)[["status", "stable", "period", "q0", "v0"]]
        pt = pt.load()
    except (KeyError, ValueError, OSError, xr.MergeError):
        return []
    out = []
    for s in range(pt.sizes.get("solution", 0)):
        row = pt.isel(solution=s)
        if int(row.status) == 0 and bool(row.stable) and np.isfinite(float(row.q0)):
            out.append({"period": int(row.period), "x0": np.array([float(row.q0),
                                                                   float(row.v0)]),
                        "stable": True, "status": 0})
    return out


def basin_task(spec: dict) -> dict:
    """One row block of a basin map (runs on a worker): study.solve.basin_grid.basin_block of
    the spec's point, rows and options, with the seconds it took."""
    t0 = time.perf_counter()
    w, s, z = spec["point"]
    block = basin_block(w, s, z, spec["q"], spec["v"], spec["options"],
                        spec["transient_periods"], spec["record_periods"])
    return {"block": block, "seconds": time.perf_counter() - t0}


def run_basins(req: BasinRequest, cluster: ClusterSpec, out: Path, *,
               rows_per_task: int = ROWS_PER_TASK, client=None, on_tile=None) -> dict:
    """Compute the basin map of ``req`` on the cluster (row blocks as tasks; ``client``: an
    existing one, else one is made from ``cluster`` and closed), write the product group and
    draw the figure into ``out``. Returns the group, the figure's path, the seconds the map
    took (``seconds``, with the cluster's start; ``map_seconds``, without), the map's Dataset
    and its measures. ``on_tile(step, spec, result)``: called as each
    task of the reuse method returns (the explore page draws the tiles as they come)."""
    with Lock(req.store):       # refused while a run writes the store; nothing computed then
        pass
    omega, sigma, zeta = req.point
    q, v = grid_axes(req.q_range, req.v_range, req.grid)
    t0 = time.perf_counter()
    own = client is None
    cluster_obj = None
    if own:
        client, cluster_obj = make_client(cluster)
    t_map = time.perf_counter()
    try:
        if req.method == "reuse":
            bm = _reuse_map(req, client, on_tile)
            blocks = None
        else:
            blocks = _transient_blocks(req, client, q, v, rows_per_task)
    finally:
        if own:
            close_quietly(client, cluster_obj)
    if blocks is not None:
        bm = merge_blocks(omega, sigma, zeta, q, v, blocks, req.options,
                          req.transient_periods, req.record_periods)
    now = time.perf_counter()
    return dict(_write(req, bm, now - t0, out), map_seconds=now - t_map)


def _transient_blocks(req: BasinRequest, client, q, v, rows_per_task: int) -> list:
    """The brute force's row blocks, computed as tasks."""
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
    return [blocks[t.key] for t in tasks]


def _reuse_map(req: BasinRequest, client, on_tile=None):
    """The reuse method's map (study.solve.dense_basins.cell_basin_map) with its tasks on the
    client's cluster; ``on_tile(step, spec, result)`` is called as each task returns."""
    runner = TaskRunner(client, DeferInterrupt(), sys.stderr)
    call = uuid.uuid4().hex[:8]     # one map's keys: never an earlier map's results

    def run(name, function, specs):
        step = {dense_basins.probe_tile: "probe", dense_basins.reuse_tile: "round",
                dense_basins.census_tile: "census"}[function]
        if not specs:
            return []
        shared = specs[0].get("evidence")
        if shared is not None and all(sp.get("evidence") is shared for sp in specs):
            # the round's evidence sent once (workers fetch it from one another), not per task
            shared = client.scatter(shared, hash=False)
        sized = [dict(sp, step=step, **({"evidence": shared} if shared is not None else {}))
                 for sp in specs]
        tag = name.replace(" ", "").replace("/", "of")
        tasks = [Task(f"hertzmap-basins-{req.study_hash[:12]}-{call}-{tag}-{i}", sp,
                      _states(sp)) for i, sp in enumerate(sized)]
        index = {t.key: i for i, t in enumerate(tasks)}
        results: list = [None] * len(tasks)

        def commit(task, res):
            i = index[task.key]
            results[i] = res
            if on_tile is not None:
                on_tile(step, specs[i], res)
        cost = runner.map(f"basin map: {name}", basin_tile_task, tasks, commit, unit="tasks")
        if cost.failed:
            raise RuntimeError(f"basin map: {len(cost.failed)} task(s) of {name} failed: "
                               f"{cost.failed[0][1]}")
        return results

    omega, sigma, zeta = req.point
    return dense_basins.cell_basin_map(
        omega, sigma, zeta, req.q_range, req.v_range, req.grid, options=req.options,
        orbits=store_orbits(req), transient_periods=req.transient_periods,
        record_periods=req.record_periods, run=run)


def _states(spec: dict) -> int:
    """The initial states a task integrates (its size for the progress line)."""
    if "cells" in spec:
        return len(spec["cells"])
    n = int(np.size(spec["q"]))
    return n * int(np.size(spec["v"])) if spec["step"] == "probe" else n


def _write(req: BasinRequest, bm, seconds: float, out: Path) -> dict:
    """The map written into the store as its product group and drawn; the summary."""
    from hertzmap.study.plots import plot_basin_map
    from hertzmap.study.products.basin_map import basin_map_dataset, basin_map_name

    omega, sigma, zeta = req.point
    name = basin_map_name(omega, sigma, zeta)
    ds = basin_map_dataset(bm, {"hertzmap_study_name": req.study_name,
                                "hertzmap_study_hash": req.study_hash,
                                "hertzmap_product_source": "hertzmap basins",
                                "model": req.options["model"],
                                "exponent": req.options["exponent"],
                                "grid_index": list(req.index)})
    group = write_product(req.store, name, ds)
    figure = plot_basin_map(ds, Path(out) / f"{req.study_name}_{name}.png")
    return {"group": group, "figure": figure, "seconds": seconds, "dataset": ds,
            "basin_entropy": bm.entropy.basin_entropy,
            "boundary_basin_entropy": bm.entropy.boundary_basin_entropy,
            "uncertainty_fraction": bm.uncertainty,
            "attractors": [(a["kind"], a["period"], a["count"]) for a in bm.attractors]}
