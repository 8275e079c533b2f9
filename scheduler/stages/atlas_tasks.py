"""The atlas as Dask tasks of the same study, after its grid and before its curves
(study.solve.atlas: every stored orbit continued into its grid neighbours, round after round,
until a round adds nothing).

A round's tasks are the atlas's tiles (TILE_BLOCKS of the grid's task blocks along sigma) that
hold, or touch, an orbit the last round added (round 1: every tile). A task reads its tile and a one-point halo from the store
(the snapshot: nothing is written to the main group during a round), stages its result
itself (scheduler.store.stage_atlas_tile: the tile's arrays where it gained orbits, one file
per tile, as the grid's tasks write their blocks) and returns its counts. Once every tile of
the round is staged, the client commits them
(region writes of whole chunks) and records the round in the store's attrs
(``hertzmap_atlas``). A run killed during a round keeps the staged tiles and computes the rest
from the same snapshot; killed during a commit, it commits the staged round again: either way
the store ends as an undisturbed run leaves it, whatever the worker count or the task order.
"""
from __future__ import annotations

import os
import time
from typing import Any, TextIO

import numpy as np

from hertzmap.scheduler.stages.plan import make_plan
from hertzmap.scheduler.stages.stage import Stage, Task, TaskRunner
from hertzmap.scheduler.store import (ATLAS_ATTR, read_atlas_tile, read_region,
                                      remove_atlas_stage, stage_atlas_tile, staged_atlas_tiles)
from hertzmap.scheduler.stages.worker import DEFAULT_SOLVER
from hertzmap.study.schema import (ATTRACTOR_VARIABLES, CROSSING_VARIABLES, ORBIT_VARIABLES,
                                   VARIABLES, stored_variables)
from hertzmap.study.solve.atlas import HALO_NAMES, NEIGHBOUR_NAMES, atlas_names, census_points

#: the stored variables the atlas needs (the orbits' identity and continuity invariants)
NEEDS = ("min_q", "max_q", "ptp")
#: what computes one tile of a round, of either kind (module:function, imported on the worker
#: by name)
DEFAULT_ATLAS_TILE = "hertzmap.study.solve.atlas:atlas_tile"
#: what a census round reads of the grid to find its points
CENSUS_NEEDS = ("attractor_kind", "attractor_periods_run", "stable", "status")
#: An atlas tile is this many of the grid's blocks along sigma (the store's chunks): a tile's
#: task reads the chunks of its one-point halo besides its own, and zarr's cost is per chunk
#: read, not per value, so small tiles read three chunks for each one they compute (the
#: default scene's atlas: 8 rounds over 80 tiles with one block, 4 over 23 with three:
#: `atlas:` line of hertzmap run). A function of the store's chunks only: the tiles, and so
#: the store, are the same for any worker count.
TILE_BLOCKS = 3


def atlas_chunks(chunks: tuple[int, int, int]) -> tuple[int, int, int]:
    """The atlas tiles' shape from the store's chunks (TILE_BLOCKS blocks along sigma)."""
    return (int(chunks[0]), int(chunks[1]) * TILE_BLOCKS, int(chunks[2]))


def _region(tile: tuple[slice, slice, slice], shape: tuple[int, int, int]):
    """The tile grown by one point along every axis (clipped to the grid), and the tile's
    cells within it."""
    grown, own = [], []
    for s, n in zip(tile, shape):
        lo, hi = max(s.start - 1, 0), min(s.stop + 1, n)
        grown.append(slice(lo, hi))
        own.append(slice(s.start - lo, s.stop - lo))
    return tuple(grown), tuple(own)


def atlas_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One tile of one atlas round. Runs on a worker: reads the tile and its halo from the
    store (read only), continues the neighbours' orbits into the tile. ``spec``: store, round,
    index, slices (the tile), shape (the grid's), chunk_omega, axes (omega, sigma, zeta of the
    grid), names (what the store holds), options, level, periods, owner (the
    client's lock record: the tile is staged only while that client holds the store)."""
    t0 = time.perf_counter()
    tile = tuple(slice(*s) for s in spec["slices"])
    census = spec.get("census")
    region, own = _region(tile, tuple(spec["shape"]))
    names = spec["names"]
    ib = tile[0].start // int(spec["chunk_omega"])
    # the halo's orbit rules and start points over the region; the other slot variables, the
    # counts, the census's attractors and the lines over the tile only (a chunk read costs
    # the same for one line of it: the halo's reads of every variable were most of a small
    # tile's time); all read in one call into zarr's event loop
    where = {n: region if n in HALO_NAMES else tile for n in names if n in ORBIT_VARIABLES
             or n == "orbits_found"}
    if census is not None:
        # a census round writes its tile's attractors; its transients also start from the
        # halo's (study.solve.atlas.neighbour_starts)
        where.update({n: region if n in NEIGHBOUR_NAMES else tile for n in names
                      if n in ATTRACTOR_VARIABLES})
    elif "attractor_solution" in names:
        where["attractor_solution"] = tile
    where.update({n: (slice(ib, ib + 1), tile[1], tile[2]) for n in names
                  if n in CROSSING_VARIABLES})
    read = read_region(spec["store"], where)
    slot = {}
    for n in where:
        if n in CROSSING_VARIABLES:
            continue
        if where[n] == region:
            slot[n] = read[n]
            continue
        # over the region, the halo filled with the variable's empty value (the tile function
        # reads only HALO_NAMES there)
        a = read[n]
        slot[n] = np.full(tuple(r.stop - r.start for r in region) + a.shape[3:],
                          VARIABLES[n].fill, a.dtype)
        slot[n][own] = a
    lines = {n: read[n] for n in where if n in CROSSING_VARIABLES}
    axes = [np.asarray(spec["axes"][a], float)[r] for a, r in zip(("omega", "sigma", "zeta"),
                                                                 region)]
    from hertzmap.scheduler.stages.worker import load_solver

    args = (slot, lines, own, *axes, int(spec["round"]), spec["options"],
            float(spec["level"]), tuple(spec["periods"]))
    result = load_solver(spec.get("tile_function", DEFAULT_ATLAS_TILE))(
        *args, offer_own=bool(spec.get("offer_own")), census=census,
        unstable=spec.get("unstable", "searched-periods"))
    changed = bool(result.changed.any())
    stage_atlas_tile(spec["store"], spec["owner"], int(spec["round"]), tuple(spec["index"]),
                     result.arrays if changed else None)
    return {"index": spec["index"], "changed": changed,
            "shots": result.shots, "added": result.added,
            "seconds": time.perf_counter() - t0, "pid": os.getpid()}


class AtlasStage(Stage):
    """The atlas stage of one run of a study into its (locked) store: its continuation rounds
    (costed as the stage "atlas") and census rounds ("census")."""

    name = "atlas"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        opts = self.opts
        #: False with another block solver than hertzmap's (a test's stand-in) or --no-atlas:
        #: the atlas continues real orbits, which such a grid does not hold
        self.enabled = (opts is None or (getattr(opts, "solver", DEFAULT_SOLVER) == DEFAULT_SOLVER
                                         and getattr(opts, "atlas", True)))
        self.tile = getattr(opts, "atlas_tile", DEFAULT_ATLAS_TILE)
        study = self.study
        self.options["harmonics"] = "force_harmonics" in study.outputs
        self.stored = stored_variables(study)
        self.names = atlas_names(self.stored)
        #: a census round (its attractors again where the atlas brought a stable orbit to a
        #: point its census called chaotic) runs where the study stores the census
        self.census = {k: v for k, v in study.solver_kwargs().items()
                       if k in ("transient_periods", "record_periods", "max_transient_periods",
                                "point_steps", "lyapunov_error")}
        if self.census and all(n in self.stored for n in CENSUS_NEEDS):
            self.census["n_states"] = int(study.initial_states)
            self.census_names = self.names + tuple(n for n in ATTRACTOR_VARIABLES
                                                   if n in self.stored and n not in self.names)
        else:
            self.census = None

    def not_run(self) -> str | None:
        if self.enabled and not self.applies():
            return ("atlas: not run (it matches orbits by min_q, max_q and ptp: add the "
                    "\"measures\" output)")
        return None

    def applies(self) -> bool:
        """The atlas matches orbits by their invariants: it runs on studies that store them."""
        return all(n in self.stored for n in NEEDS)

    def state(self) -> dict[str, Any]:
        return dict(self.store.attrs.get(ATLAS_ATTR) or {"round": 1, "phase": "computing",
                                                          "rounds": []})

    def pending(self) -> bool:
        return self.enabled and self.applies() and self.state()["phase"] != "done"

    def not_continued(self) -> dict[int, int]:
        """What the atlas left where it was found, by period (search.continue_unstable =
        "searched-periods"): the stored unstable orbits of periods the study does not search."""
        if self.study.continue_unstable == "all":
            return {}
        every = (slice(None),) * 3
        read = read_region(self.store.path, {n: every for n in ("status", "stable", "period")})
        left = (read["status"] == 0) & ~read["stable"] & ~np.isin(read["period"],
                                                                  self.study.periods)
        periods, counts = np.unique(read["period"][left], return_counts=True)
        return {int(p): int(c) for p, c in zip(periods, counts)}

    def _census_tiles(self, plan) -> list:
        """The tiles holding a point whose census must run again (census_points)."""
        every = (slice(None),) * 3
        read = read_region(self.store.path, {n: every for n in CENSUS_NEEDS})
        need = census_points(read, self.census["transient_periods"],
                             self.census["record_periods"])
        return [t for t in plan.tasks if need[t.slices].any()]

    def _active_tiles(self, plan, round_: int, kind: str = "continue") -> list:
        """Round 1: every tile; later: the tiles holding or touching an orbit the last round
        added; a census round: _census_tiles."""
        if kind == "census":
            return self._census_tiles(plan)
        if round_ == 1:
            return list(plan.tasks)
        every = (slice(None),) * 3
        fresh = (read_region(self.store.path, {"atlas_round": every})["atlas_round"]
                 == round_ - 1).any(axis=-1)
        # a point next to a fresh orbit is touched: grow the mask by one along each axis
        touched = fresh.copy()
        for axis in range(3):
            lo = [slice(None)] * 3
            hi = [slice(None)] * 3
            lo[axis], hi[axis] = slice(1, None), slice(None, -1)
            touched[tuple(lo)] |= fresh[tuple(hi)]
            touched[tuple(hi)] |= fresh[tuple(lo)]
        return [t for t in plan.tasks if touched[t.slices].any()]

    def _spec(self, task, round_: int, state: dict) -> dict[str, Any]:
        st = self.study
        census = state.get("kind") == "census"
        return {"store": str(self.store.path.resolve()), "owner": self.owner,
                "round": round_, "index": task.index,
                "census": self.census if census else None,
                "offer_own": state.get("after_census", False),
                "slices": [(s.start, s.stop) for s in task.slices], "shape": st.shape,
                "chunk_omega": self.store.chunks[0],
                "axes": {a: np.asarray(st.axis(a), float) for a in ("omega", "sigma", "zeta")},
                "names": self.census_names if census else self.names,
                "options": self.options, "level": self.level,
                "periods": tuple(st.periods), "tile_function": self.tile,
                "unstable": st.continue_unstable}

    def run(self, runner: TaskRunner) -> dict[str, Any]:
        """Run (or resume) the rounds to the fixed point. Returns the atlas summary (also
        printed)."""
        plan = make_plan(self.study, atlas_chunks(self.store.chunks))
        by_index = {t.index: t for t in plan.tasks}
        state = self.state()
        summary = {"rounds": 0, "added": 0, "shots": 0, "censuses": 0,
                   "compute": 0.0, "tiles": 0, "by_period": {}}
        t0 = time.perf_counter()
        while state["phase"] != "done":
            with runner.timed("census" if state.get("kind") == "census" else "atlas"):
                self._round(runner, plan, by_index, state, summary)
        summary["wall"] = time.perf_counter() - t0
        summary["not_continued"] = self.not_continued()
        if state.get("not_continued") != {str(p): n for p, n in summary["not_continued"].items()}:
            # the store says what the atlas left where it was found (JSON: string keys)
            state["not_continued"] = {str(p): n for p, n in summary["not_continued"].items()}
            with self.interrupt.critical():
                self.store.set_attrs(**{ATLAS_ATTR: state})
        summary["total_added"] = sum(x["added"] for x in state.get("rounds", []))
        summary["total_rounds"] = len(state.get("rounds", []))
        self.store.add_history(f"{self.command}: atlas: {summary['total_added']} orbits added "
                               f"in {summary['total_rounds']} round(s)")
        print(atlas_line(summary), file=self.out, flush=True)
        return summary

    def _round(self, runner: TaskRunner, plan, by_index: dict, state: dict,
               summary: dict) -> None:
        """One round (or the rest of one cut short): its tiles computed and staged, then
        committed whole; ``state`` (the store's ``hertzmap_atlas``) moves to the next."""
        r = int(state["round"])
        if state["phase"] == "computing":
            kind = state.get("kind", "continue")
            active = self._active_tiles(plan, r, kind)
            staged = staged_atlas_tiles(self.store.path, r)
            todo = [t for t in active if t.index not in staged]
            tasks = [Task(self.key(r, *t.index), self._spec(t, r, state), t.size)
                     for t in todo]

            def tally(task: Task, res: dict) -> None:
                # its worker has staged the tile: the round commits once all are staged
                summary["censuses" if kind == "census" else "shots"] += res["shots"]
                summary["compute"] += res["seconds"]
                summary["tiles"] += 1

            cost = runner.map("census" if kind == "census" else "atlas", atlas_task, tasks,
                              tally, label=f"{'census' if kind == 'census' else 'atlas'} "
                              f"round {r}", total=len(active),
                              done_before=len(active) - len(todo))
            if cost.failed:
                raise RuntimeError(f"atlas round {r}: {len(cost.failed)} tile(s) failed: "
                                   f"{cost.failed[0][1]}")
            state["phase"] = "committing"
            state["active"] = [list(t.index) for t in active]
            with self.interrupt.critical():
                self.store.set_attrs(**{ATLAS_ATTR: state})
        # commit: idempotent, from the staged tiles of the round's active set
        added = 0
        with self.interrupt.critical():
            for index in map(tuple, state.get("active", [])):
                arrays = read_atlas_tile(self.store.path, r, index)
                if not arrays:
                    continue
                new = arrays["atlas_round"] == r
                added += int(new.sum())
                for p, n in zip(*np.unique(arrays["period"][new], return_counts=True)):
                    summary["by_period"][int(p)] = summary["by_period"].get(int(p), 0) + int(n)
                self.store.write_block(by_index[index].slices, arrays,
                                       tuple(n for n in self.census_names if n in arrays)
                                       if self.census else self.names)
            kind = state.get("kind", "continue")
            state["rounds"] = list(state.get("rounds", [])) + [
                {"round": r, "added": added, "kind": kind}]
            state.pop("active", None)
            # continuation rounds to the fixed point; then a census round where the atlas
            # brought a stable orbit to a chaotic point; the orbits it finds are continued
            # in turn (the next round offers them from their own tiles too)
            if added:
                state.update(round=r + 1, phase="computing", kind="continue",
                             after_census=kind == "census")
            elif kind == "continue" and self.census and self._census_tiles(plan):
                state.update(round=r + 1, phase="computing", kind="census",
                             after_census=False)
            else:
                state.update(phase="done")
            self.store.set_attrs(**{ATLAS_ATTR: state})
            remove_atlas_stage(self.store.path)
        summary["rounds"] += 1
        summary["added"] += added


def atlas_line(s: dict[str, Any]) -> str:
    periods = ", ".join(f"{n} of period {p}" for p, n in sorted(s["by_period"].items()))
    census = (f"; the census run again at {s['censuses']} points where the atlas brought a "
              f"stable orbit to transients called chaotic" if s.get("censuses") else "")
    left = s.get("not_continued") or {}
    if left:
        census += (f"; not continued (search.continue_unstable = \"searched-periods\"): "
                   f"{sum(left.values())} unstable orbits of periods not searched, stored where "
                   "found (" + ", ".join(f"{n} of period {p}" for p, n in sorted(left.items()))
                   + ")")
    return (f"atlas: {s['total_added']} orbits continued into neighbouring grid points "
            f"({periods or 'none new'}) in {s['total_rounds']} round(s) to the fixed point; "
            f"{s['shots']} shots over {s['tiles']} tiles{census}, {s['compute']:.1f} s compute, "
            f"{s['wall']:.1f} s wall")
