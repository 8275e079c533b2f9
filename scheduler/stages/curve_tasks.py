"""Traced curves as Dask tasks of the same study, after its grid (the ``curves`` output).

The seeds are the grid cells where a test function changes sign, read from the store (the
lines' ``crossing_*`` records and the stored orbits: study.solve.curve_seeds.curve_seeds, in a fixed
order); one task traces one curve (study.solve.curve_seeds.trace_seed). The client commits the
finished traces **in seed order** (scheduler.store.write_curve_part) through a
study.solve.curve_seeds.SeedBook: a seed that lies on a curve committed from an earlier seed, or
near an earlier seed whose trace did not cover it, is skipped before it is shipped and again
when its turn to commit comes; a trace that starts on an earlier curve is committed as a
duplicate (no vertices); so the curves kept depend on the grid only, never on which task
finished first. At most ``IN_FLIGHT_PER_WORKER`` traces per worker (and the first undecided seed's)
are in flight (finished ones wait for their turn outside this bound), ahead of it only one per
family of seeds (plane, kind, period: the curves are traced side by side, not one seed after
another on the same curve) and none that a finished trace of its family, waiting for its turn,
would skip (SeedBook.may_cover); a seed shipped ahead of its turn can turn out covered (its
trace is then dropped).
When every seed is decided, the product gets the completeness check: each seed's covering
curve or why there is none (``seed_*``).

A run killed at any point leaves the committed parts; rerunning resumes after the last of them
and ends with the same ``products/traced_curves`` as an undisturbed run (the parts are combined
into it, in seed order, when every seed is decided, then removed).
"""
from __future__ import annotations

import os
import time
from typing import Any, TextIO

import numpy as np
import xarray as xr

from hertzmap.scheduler.stages.stage import Stage, Task, TaskRunner
from hertzmap.scheduler.store import (TRACED_CURVES, Store, finish_traced_curves,
                                      has_run_product, read_curve_parts, write_curve_part)
from hertzmap.study.products.results import quiet
from hertzmap.study.products.traced_curves import (combine_traced_curves, part_attrs, trace_from_part,
                                          traced_curves_dataset)
from hertzmap.study.schema import CROSSING_VARIABLES
from hertzmap.study.solve.curve_seeds import SEED_SOURCES, Seed, SeedBook, curve_seeds, window

IN_FLIGHT_PER_WORKER = 2
#: what traces one seed's curve (module:function, imported on the worker by name)
DEFAULT_TRACER = "hertzmap.study.solve.curve_seeds:trace_seed"


def trace_task(spec: dict[str, Any]) -> dict[str, Any]:
    """Trace the curve of one seed. Runs on a worker. ``spec``: seed (Seed fields), bounds
    ({param: (lo, hi)}), options (exponent, model, rtol), tracer (module:function)."""
    from hertzmap.scheduler.stages.worker import load_solver

    trace = load_solver(spec.get("tracer", DEFAULT_TRACER))
    seed = Seed(**dict(spec["seed"], plane=tuple(spec["seed"]["plane"])))
    t0 = time.perf_counter()
    out = trace(seed, spec["bounds"], **spec["options"])
    out["seconds"] = time.perf_counter() - t0
    out["pid"] = os.getpid()
    return out


def warm_curve_kernels() -> float:
    """Load (or compile) the curve kernels in this process (study.solve.curve_seeds.curve_kernels:
    the workers' warm-up compiled them when the grid ran in this run; a run that resumes at its
    curves has no warm-up). Returns the seconds it took."""
    import scipy.optimize  # noqa: F401  (the extremum search's; ~0.4 s on a first import)

    from hertzmap.kernels import compile_kernels
    from hertzmap.study.solve.curve_seeds import curve_kernels

    t0 = time.perf_counter()
    compile_kernels(curve_kernels())
    return time.perf_counter() - t0


def seed_dataset(store: Store) -> xr.Dataset:
    """What the seeds are read from, of a (complete) store, in memory."""
    with quiet():
        ds = xr.open_zarr(str(store.path), chunks=None)
        names = [n for n in SEED_SOURCES + CROSSING_VARIABLES if n in ds]
        return ds[names].load()


class CurveStage(Stage):
    """The curve stage of one run of a study into its (locked) store."""

    name = "curves"

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.tracer = getattr(self.opts, "curve_tracer", DEFAULT_TRACER)
        self.axes = {n: self.study.axis(n) for n in ("omega", "sigma", "zeta")}

    def pending(self) -> bool:
        """True when the study asks for curves and its store does not hold them yet."""
        return "curves" in self.study.outputs and not has_run_product(
            self.store.path, TRACED_CURVES, self.study.hash)

    def run(self, runner: TaskRunner) -> dict[str, Any]:
        """Trace, commit and combine the study's curves. Returns the curve summary (also
        printed)."""
        t0 = time.perf_counter()
        # every worker loads the curve kernels first, so that the traces' times are theirs
        runner.client.run(warm_curve_kernels)
        t_warm = time.perf_counter() - t0
        t1 = time.perf_counter()
        seeds = curve_seeds(seed_dataset(self.store), self.level, self.study.periods)
        book = SeedBook(seeds, self.axes)
        t_seeds = time.perf_counter() - t1
        parts = read_curve_parts(self.store.path)
        committed: dict[int, xr.Dataset] = {i: parts[i] for i in sorted(parts) if i < len(seeds)}
        summary = {"seeds": len(seeds), "resumed": len(committed), "traced": 0, "dropped": 0,
                   "duplicates": 0, "failed": [], "compute": 0.0, "vertices_traced": 0,
                   "warm_up": t_warm, "seeding": t_seeds}
        if committed:
            print(f"resuming the curves of {self.store.path}: {len(committed)} committed",
                  file=self.out, flush=True)
        finished: dict[int, dict] = {}
        window_size = IN_FLIGHT_PER_WORKER * runner.n_workers
        may_cover: dict[tuple[int, int], bool] = {}

        def held(i: int, ship: int) -> bool:
            """Finished trace i (not committed yet) would have seed ``ship`` skipped."""
            if (i, ship) not in may_cover:
                may_cover[i, ship] = book.may_cover(finished[i], seeds[ship])
            return may_cover[i, ship]

        pointer = 0
        with runner.window(self.name, trace_task) as traces:
            in_flight = traces.in_flight
            while True:
                # 1. commit, in seed order, what can be decided
                while pointer < len(seeds):
                    if pointer in committed:
                        trace = trace_from_part(committed[pointer])
                        book.commit(trace, trace["duplicate_of"])
                    elif book.skip(pointer):
                        traces.cancel(pointer)
                        if finished.pop(pointer, None) is not None:
                            summary["dropped"] += 1
                    elif pointer in finished:
                        res = finished.pop(pointer)
                        dup = book.duplicate_of(res)
                        if dup >= 0:         # stored without its vertices: a curve kept already
                            summary["duplicates"] += 1
                            res = dict(res, vertices={}, codim2=[])
                        part = traced_curves_dataset([res], part_attrs(res, dup))
                        with self.interrupt.critical():
                            write_curve_part(self.store.path, pointer, part)
                        committed[pointer] = part
                        book.commit(res, dup)
                    else:
                        break
                    pointer += 1
                if pointer >= len(seeds) or traces.cost.failed:
                    break
                # 2. ship the first undecided seed (always: the commits wait for it), then,
                # ahead of it, seeds not yet known to be skipped whose family (plane, kind,
                # period) has no trace under way -- the next seeds of a family in flight
                # mostly lie on its curve, and shipping them would trace the curves one after
                # the other
                # a family with a trace under way ships nothing more; one whose traces are
                # finished (waiting for their turn) ships the seeds they do not cover
                busy = {SeedBook.family(seeds[i]) for i in in_flight}
                waiting: dict[tuple, list] = {}
                for i in finished:
                    waiting.setdefault(SeedBook.family(seeds[i]), []).append(i)
                for ship in range(pointer, len(seeds)):
                    # the window bounds the traces under way, not those finished and waiting
                    # for their turn to commit: a long trace at the pointer (a 9T fold curve,
                    # 5-14 s) would otherwise fill it with short finished ones and leave a
                    # worker idle until it ends (the default scene's curves ran on one worker
                    # at a time: 25.5 s of compute in 25.0 s of wall)
                    if ship > pointer and len(in_flight) >= window_size:
                        break
                    if (ship in committed or ship in in_flight or ship in finished
                            or book.skip(ship)
                            or (ship > pointer and SeedBook.family(seeds[ship]) in busy)
                            or (ship > pointer and any(
                                held(i, ship)
                                for i in waiting.get(SeedBook.family(seeds[ship]), ())))):
                        continue
                    seed = seeds[ship]
                    busy.add(SeedBook.family(seed))
                    spec = {"seed": seed.as_dict(), "bounds": window(self.axes, seed.plane),
                            "options": self.options, "tracer": self.tracer}
                    traces.submit(ship, Task(self.key(ship), spec))
                if not in_flight:
                    break               # nothing can be decided (cannot happen; bounded anyway)
                # 3. wait for a trace
                for i, res in traces.wait():
                    if res is None:     # failed for good (after retries): in traces.cost
                        continue
                    summary["traced"] += 1
                    summary["compute"] += res.get("seconds", 0.0)
                    summary["vertices_traced"] += len(res["vertices"]["omega"])
                    finished[i] = res
        summary["failed"] = list(traces.cost.failed)
        summary["complete"] = pointer >= len(seeds) and not summary["failed"]
        if summary["complete"]:
            ordered = [committed[i] for i in book.curve_ids()]
            outcomes = book.outcomes()
            product = combine_traced_curves(ordered, {
                "hertzmap_study_name": self.study.name,
                "hertzmap_study_hash": self.study.hash,
                "hertzmap_curve_seeds": len(seeds),
                "model": self.study.model,
                "exponent": self.study.exponent if self.study.exponent is not None else "none"},
                outcomes)
            summary.update(product_summary(product))
            with self.interrupt.critical():
                finish_traced_curves(self.store.path, product)
                self.store.add_history(f"{self.command}: traced {summary['curves']} curves "
                                       f"from {len(seeds)} seeds")
        summary["wall"] = time.perf_counter() - t0
        print_curve_summary(summary, self.out)
        return summary


def product_summary(product: xr.Dataset) -> dict[str, Any]:
    """Counts read off the combined product (for the run's summary)."""
    n = product.sizes.get("curve", 0)
    verts = product["curve_vertices"].values if n else np.zeros(0, int)
    outcome = product["seed_outcome"]
    names = dict(zip(outcome.attrs["flag_values"].tolist(), outcome.attrs["flag_meanings"].split()))
    uncovered = {}
    for code in outcome.values[product["seed_curve"].values < 0].tolist():
        uncovered[names[code]] = uncovered.get(names[code], 0) + 1
    return {"curves": int((verts > 0).sum()), "curves_failed": int((verts == 0).sum()),
            "vertices": int(product.sizes.get("vertex", 0)),
            "codim2": int(product.sizes.get("codim2", 0)),
            "maps": int(product["curve_maps"].values.sum()) if n else 0,
            "uncovered": uncovered}


def print_curve_summary(s: dict[str, Any], out: TextIO) -> None:
    lines = []
    if s.get("complete"):
        per = 1e3 * s["compute"] / max(1, s["vertices_traced"])
        unc = s.get("uncovered", {})
        lines.append(
            f"curves: {s['curves']} traced ({s['curves_failed']} seeds failed to start) from "
            f"{s['seeds']} seeds (grid cells where a test function changes sign), "
            f"{s['vertices']} vertices, {s['codim2']} codimension-2 points; {s['traced']} "
            "traces run"
            + (f" ({s['dropped']} dropped: covered by an earlier seed's curve)"
               if s["dropped"] else "")
            + (f", {s['duplicates']} onto earlier curves" if s.get("duplicates") else "")
            + (f", {s['resumed']} resumed" if s["resumed"] else "")
            + f", {s['wall']:.2f} s wall ({s['warm_up']:.2f} s loading the curve kernels on "
            f"the workers, {s.get('seeding', 0.0):.2f} s reading the seeds), {per:.2f} ms per "
            "vertex traced (products/traced_curves)")
        lines.append("  seeds not covered by a traced curve: "
                     + (", ".join(f"{v} {k}" for k, v in sorted(unc.items())) if unc else "none")
                     + " (seed_outcome)")
    else:
        lines.append(f"curves: incomplete ({s['traced']} traces run); rerun the same command to "
                     "resume them")
    for k, msg in s["failed"][:5]:
        lines.append(f"  FAILED curve task {k}: {msg}")
    out.write("\n".join(lines) + "\n")
    out.flush()
