"""Traced curves as Dask tasks of the same study, after its grid (the ``curves`` output).

The seeds are the located points stored by the grid's tasks (study.solve.curves.curve_seeds,
in a fixed order); one task traces one curve (study.solve.curves.trace_seed). The client
commits the finished curves **in seed order** (scheduler.store.write_curve_part): a seed that
lies on a curve committed from an earlier seed is skipped (study.solve.curves.covers) before it
is shipped and again when its turn to commit comes, so the curves kept depend on the located
points only, never on which task finished first. At most ``IN_FLIGHT_PER_WORKER`` traces per
worker are in flight or waiting for their turn: a seed shipped ahead of its turn can turn out
covered (its trace is then dropped).

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

from scheduler.store import (Store, finish_traced_curves, has_traced_curves, read_curve_parts,
                             write_curve_part)
from study.products.results import quiet
from study.products.traced_curves import (combine_traced_curves, part_attrs, trace_from_part,
                                          traced_curves_dataset)
from study.schema import PRODUCT_VARIABLES
from study.solve.curves import Seed, covers, curve_seeds, window
from study.spec import Study

IN_FLIGHT_PER_WORKER = 2
#: what traces one seed's curve (module:function, imported on the worker by name)
DEFAULT_TRACER = "study.solve.curves:trace_seed"


def trace_task(spec: dict[str, Any]) -> dict[str, Any]:
    """Trace the curve of one seed. Runs on a worker. ``spec``: seed (Seed fields), bounds
    ({param: (lo, hi)}), options (exponent, model, rtol), tracer (module:function)."""
    from scheduler.worker import load_solver

    trace = load_solver(spec.get("tracer", DEFAULT_TRACER))
    seed = Seed(**dict(spec["seed"], plane=tuple(spec["seed"]["plane"])))
    t0 = time.perf_counter()
    out = trace(seed, spec["bounds"], **spec["options"])
    out["seconds"] = time.perf_counter() - t0
    out["pid"] = os.getpid()
    return out


def warm_curve_kernels() -> float:
    """Load (or compile) the curve kernels in this process: a three-vertex trace. Returns the
    seconds it took (numba's disk cache: about 1 s per process)."""
    import scipy.optimize  # noqa: F401  (the extremum search's; ~0.4 s on a first import)

    from kernels.continuation import trace_curve

    t0 = time.perf_counter()
    for kind, period in (("flip", 1), ("grazing", 2)):
        trace_curve((0.0, 0.0), 2.0, 0.5, 0.01, kind=kind, period=period, max_points=3,
                    bounds={"omega": (1.9, 2.1), "sigma": (0.4, 0.6)})
    return time.perf_counter() - t0


def located_dataset(store: Store) -> xr.Dataset:
    """The stored located points of a (complete) store, in memory."""
    names = PRODUCT_VARIABLES["bifurcations"]
    with quiet():
        ds = xr.open_zarr(str(store.path), chunks=None)
        return ds[[n for n in names if n in ds]].assign_coords(omega=ds["omega"]).load()


class CurveRun:
    """The curve stage of one run of a study into its (locked) store."""

    def __init__(self, study: Study, store: Store, out: TextIO, err: TextIO, interrupt,
                 command: str = "hertzmap run", tracer: str = DEFAULT_TRACER):
        self.tracer = tracer
        self.study = study
        self.store = store
        self.out = out
        self.err = err
        self.interrupt = interrupt
        self.command = command
        kw = study.solver_kwargs()
        self.options = {"exponent": kw["exponent"], "model": kw["model"], "rtol": kw["rtol"]}
        self.axes = {n: study.axis(n) for n in ("omega", "sigma", "zeta")}

    def pending(self) -> bool:
        """True when the study asks for curves and its store does not hold them yet."""
        return "curves" in self.study.products and not has_traced_curves(self.store.path,
                                                                          self.study.hash)

    def _covered(self, seed: Seed, kept: list[dict]) -> bool:
        bounds = window(self.axes, seed.plane)
        return any(covers(k, seed, bounds, **self.options) for k in kept)

    def run(self, client, n_workers: int) -> dict[str, Any]:
        """Trace, commit and combine the study's curves. Returns the curve summary (also
        printed)."""
        from distributed import wait

        t0 = time.perf_counter()
        # every worker loads the curve kernels first, so that the traces' times are theirs
        warm = client.run(warm_curve_kernels)
        t_warm = time.perf_counter() - t0
        seeds = curve_seeds(located_dataset(self.store))
        parts = read_curve_parts(self.store.path)
        kept = []                 # committed traces with vertices, in seed order
        committed: dict[int, xr.Dataset] = {}
        for i in sorted(parts):
            if i < len(seeds):
                committed[i] = parts[i]
        summary = {"seeds": len(seeds), "resumed": len(committed), "traced": 0, "dropped": 0,
                   "failed": [], "compute": 0.0, "vertices_traced": 0, "warm_up": t_warm,
                   "warm_up_per_worker": max(warm.values()) if warm else 0.0}
        if committed:
            print(f"resuming the curves of {self.store.path}: {len(committed)} committed",
                  file=self.out, flush=True)
        in_flight: dict[int, Any] = {}
        finished: dict[int, dict] = {}
        window_size = IN_FLIGHT_PER_WORKER * max(1, n_workers)
        key = self.study.hash[:12]
        pointer = 0
        ship = 0
        try:
            while True:
                # 1. commit, in seed order, what can be decided
                while pointer < len(seeds):
                    seed = seeds[pointer]
                    if pointer in committed:
                        trace = trace_from_part(committed[pointer])
                        if trace["vertices"]["omega"].size >= 2:
                            kept.append(trace)
                    elif self._covered(seed, kept):
                        fut = in_flight.pop(pointer, None)
                        if fut is not None:
                            fut.cancel()
                        if finished.pop(pointer, None) is not None:
                            summary["dropped"] += 1
                    elif pointer in finished:
                        res = finished.pop(pointer)
                        part = traced_curves_dataset([res], part_attrs(res))
                        with self.interrupt.critical():
                            write_curve_part(self.store.path, pointer, part)
                        committed[pointer] = part
                        if len(res["vertices"]["omega"]) >= 2:
                            kept.append(res)
                    else:
                        break
                    pointer += 1
                if pointer >= len(seeds) or summary["failed"]:
                    break
                # 2. ship the next seeds not yet known to be covered
                ship = max(ship, pointer)
                while len(in_flight) + len(finished) < window_size and ship < len(seeds):
                    if (ship not in committed and ship not in in_flight
                            and ship not in finished and not self._covered(seeds[ship], kept)):
                        seed = seeds[ship]
                        spec = {"seed": seed.as_dict(), "bounds": window(self.axes, seed.plane),
                                "options": self.options, "tracer": self.tracer}
                        in_flight[ship] = client.submit(trace_task, spec, pure=False,
                                                        key=f"hertzmap-curve-{key}-{ship}")
                    ship += 1
                if not in_flight:
                    break               # nothing can be decided (cannot happen; bounded anyway)
                # 3. wait for a trace
                done, _ = wait(list(in_flight.values()), return_when="FIRST_COMPLETED")
                for i, fut in list(in_flight.items()):
                    if fut not in done:
                        continue
                    del in_flight[i]
                    try:
                        res = fut.result()
                    except Exception as exc:   # a task that failed for good (after retries)
                        summary["failed"].append((fut.key, f"{type(exc).__name__}: {exc}"))
                        continue
                    finally:
                        fut.release()
                    summary["traced"] += 1
                    summary["compute"] += res.get("seconds", 0.0)
                    summary["vertices_traced"] += len(res["vertices"]["omega"])
                    finished[i] = res
        finally:
            for fut in in_flight.values():
                fut.cancel()
        summary["wall"] = time.perf_counter() - t0
        summary["complete"] = pointer >= len(seeds) and not summary["failed"]
        if summary["complete"]:
            ordered = [committed[i] for i in sorted(committed)]
            product = combine_traced_curves(ordered, {
                "hertzmap_study_name": self.study.name,
                "hertzmap_study_hash": self.study.hash,
                "hertzmap_curve_seeds": len(seeds),
                "model": self.study.model,
                "exponent": self.study.exponent if self.study.exponent is not None else "none"})
            summary.update(product_summary(product))
            with self.interrupt.critical():
                finish_traced_curves(self.store.path, product)
                self.store.add_history(f"{self.command}: traced {summary['curves']} curves "
                                       f"from {len(seeds)} located points")
        print_curve_summary(summary, self.out)
        return summary


def product_summary(product: xr.Dataset) -> dict[str, Any]:
    """Counts read off the combined product (for the run's summary)."""
    n = product.sizes.get("curve", 0)
    verts = product["curve_vertices"].values if n else np.zeros(0, int)
    return {"curves": int((verts > 0).sum()), "curves_failed": int((verts == 0).sum()),
            "vertices": int(product.sizes.get("vertex", 0)),
            "codim2": int(product.sizes.get("codim2", 0)),
            "maps": int(product["curve_maps"].values.sum()) if n else 0}


def print_curve_summary(s: dict[str, Any], out: TextIO) -> None:
    lines = []
    if s.get("complete"):
        per = 1e3 * s["compute"] / max(1, s["vertices_traced"])
        lines.append(
            f"curves: {s['curves']} traced ({s['curves_failed']} seeds failed to start) from "
            f"{s['seeds']} located points, {s['vertices']} vertices, {s['codim2']} "
            f"codimension-2 points; {s['traced']} traces run"
            + (f" ({s['dropped']} dropped: covered by an earlier seed's curve)"
               if s["dropped"] else "")
            + (f", {s['resumed']} resumed" if s["resumed"] else "")
            + f", {s['wall']:.2f} s wall ({s['warm_up']:.2f} s loading the curve kernels on "
            f"the workers), {per:.2f} ms per vertex traced (products/traced_curves)")
    else:
        lines.append(f"curves: incomplete ({s['traced']} traces run); rerun the same command to "
                     "resume them")
    for k, msg in s["failed"][:5]:
        lines.append(f"  FAILED curve task {k}: {msg}")
    out.write("\n".join(lines) + "\n")
    out.flush()
