"""What a Dask worker runs: plain, importable, module-level functions (never numba objects).

The block solver is imported by name on the worker (``study.solve.block:solve_block`` by default),
so nothing jitted is ever pickled; the :class:`Warmup` plugin imports it and runs one tiny
solve when a worker starts, which loads (or compiles) the numba kernels once per process.
With an empty numba cache, the workers share the compile (kernels._jit): each compiles the
kernels' leaves and the integrator's small kernels, then the study's entry points (the traced
curves' too when the study asks for curves), in an order of its own (forward or backward by
worker number), and loads from the cache what another has compiled.
"""

from __future__ import annotations

import importlib
import inspect
import os
import time
from typing import Any, Callable

import numpy as np
from distributed import WorkerPlugin

DEFAULT_SOLVER = "hertzmap.study.solve.block:solve_block"

_SOLVERS: dict[str, Callable[..., dict]] = {}


def load_solver(path: str = DEFAULT_SOLVER) -> Callable[..., dict]:
    """Import ``module:function`` once per process."""
    fn = _SOLVERS.get(path)
    if fn is None:
        module, _, name = path.partition(":")
        fn = getattr(importlib.import_module(module), name or "solve_block")
        _SOLVERS[path] = fn
    return fn


def warm_up_kernels(kwargs: dict[str, Any] | None = None, curves: bool = False) -> list:
    """What a worker's warm-up compiles after the shared stages (kernels._jit.compile_shared),
    in order, each once: the integrator (every entry point calls it; typing them needs only
    its signature, so the other worker types its entries meanwhile), the entry points the
    study's blocks call (study.solve.block.entry_kernels) and, with ``curves``, those of the
    traced curves (study.solve.curve_seeds.curve_kernels); the census's, the largest, last, where
    the other worker (which takes the list backward) starts."""
    from hertzmap.kernels.attractors import attractor_batch_into
    from hertzmap.kernels.integrate import integrate
    from hertzmap.study.solve.block import entry_kernels
    entries = [integrate] + entry_kernels(**(kwargs or {}))
    if curves:
        from hertzmap.study.solve.curve_seeds import curve_kernels
        entries += curve_kernels()
    entries = list(dict.fromkeys(entries))
    entries.sort(key=lambda d: d is attractor_batch_into)
    return entries


def warm_up(solver: str = DEFAULT_SOLVER, kwargs: dict[str, Any] | None = None,
            order: int = 0, curves: bool = False) -> float:
    """Import the solver and solve one grid point; returns the seconds it took. For the
    default solver, first compile (or load) what every entry point calls (the kernels' leaves,
    then the integrator's small kernels: kernels._jit.compile_shared), then warm_up_kernels,
    each list backward when ``order`` is odd: two workers starting together with an empty
    cache then compile half each."""
    t0 = time.perf_counter()
    if solver == DEFAULT_SOLVER:
        from hertzmap.kernels import compile_kernels
        from hertzmap.kernels._jit import compile_shared
        backward = order % 2 == 1
        compile_shared(0, 1, backward)
        entries = warm_up_kernels(kwargs, curves)
        compile_kernels(entries[::-1] if backward else entries)
    fn = load_solver(solver)
    one = np.array([1.0])
    fn(one, np.array([0.1]), np.array([0.05]), **(kwargs or {}))
    return time.perf_counter() - t0


def worker_number(worker) -> int:
    """The number in a worker's name (LocalCluster: 0, 1, ...; dask-jobqueue: JOB-0, JOB-1,
    ...), else the process id: only its parity is used, to vary the compile order."""
    name = str(getattr(worker, "name", ""))
    tail = name.rsplit("-", 1)[-1]
    return int(tail) if tail.isdigit() else os.getpid()


class Warmup(WorkerPlugin):
    """Worker plugin: warm the solver on every worker, including workers that join later."""

    idempotent = False

    def __init__(self, solver: str = DEFAULT_SOLVER, kwargs: dict[str, Any] | None = None,
                 curves: bool = False):
        self.solver = solver
        self.kwargs = dict(kwargs or {})
        self.curves = bool(curves)
        self.seconds: float | None = None

    def setup(self, worker=None):
        self.seconds = warm_up(self.solver, self.kwargs, worker_number(worker), self.curves)

    def teardown(self, worker=None):
        pass

    def transition(self, key, start, finish, **kwargs):
        pass


def run_task(spec: dict[str, Any]) -> dict[str, Any]:
    """Solve one block (one chunk of the store) and stage it in the store (the client packs it
    into its shard, scheduler.store.block_writes). Runs on a worker.

    ``spec``: index, slices (the block's (start, stop) along omega, sigma, zeta), omega, sigma,
    zeta (1-D float64 arrays), kwargs (for solve_block), names (the variables to store), solver
    ("module:function"), time_budget, store (its absolute path) and owner (the client's lock
    record: scheduler.store.stage_task_block stages only while that client holds the store),
    sample (scheduler.stages.sample.Sampler.task_spec).
    Returns a summary of a few hundred bytes, never the arrays: the counts the run summary
    needs (scheduler.doors.report.block_counts), the block's error-sample candidates, the solve and
    staging times and the worker's pid. The client flags the task once its shard is packed.
    """
    from hertzmap.scheduler.stages.sample import block_candidates
    from hertzmap.scheduler.doors.report import block_counts
    from hertzmap.scheduler.store import stage_task_block
    from hertzmap.study.schema import VARIABLES, check_block

    fn = load_solver(spec.get("solver", DEFAULT_SOLVER))
    omega = np.ascontiguousarray(spec["omega"], dtype=np.float64)
    sigma = np.ascontiguousarray(spec["sigma"], dtype=np.float64)
    zeta = np.ascontiguousarray(spec["zeta"], dtype=np.float64)
    kwargs = dict(spec["kwargs"])
    if spec.get("time_budget") is not None and spec.get("solver", DEFAULT_SOLVER) == DEFAULT_SOLVER:
        kwargs["time_budget"] = float(spec["time_budget"])   # cut a runaway block, recorded
    t0 = time.perf_counter()
    out = fn(omega, sigma, zeta, **kwargs)
    seconds = time.perf_counter() - t0
    names = tuple(spec["names"])
    check_block(out, names, (len(omega), len(sigma), len(zeta)))
    arrays = {n: np.ascontiguousarray(out[n], dtype=VARIABLES[n].dtype) for n in names}
    t1 = time.perf_counter()
    stage_task_block(spec["store"], spec["owner"], tuple(spec["index"]), arrays)
    return {"index": tuple(spec["index"]), "seconds": seconds,
            "write_seconds": time.perf_counter() - t1, "pid": os.getpid(),
            "counts": block_counts(arrays),
            "samples": block_candidates(arrays, (omega, sigma, zeta), spec["sample"])}


def solve_points(points: list[tuple[float, float, float]], kwargs: dict[str, Any],
                 solver: str = DEFAULT_SOLVER,
                 seeds: list[list[tuple[int, float, float]]] | None = None
                 ) -> list[dict[str, np.ndarray]]:
    """Solve isolated grid points (one block each); used by the error estimate. ``seeds``
    (one list of (period, q0, q'0) per point) go to solvers that take a ``seeds`` argument."""
    fn = load_solver(solver)
    takes_seeds = "seeds" in inspect.signature(fn).parameters
    out = []
    for i, (w, s, z) in enumerate(points):
        kw = dict(kwargs, seeds=seeds[i]) if seeds is not None and takes_seeds else kwargs
        r = fn(np.array([w]), np.array([s]), np.array([z]), **kw)
        out.append({k: np.asarray(r[k])[0, 0, 0] for k in ("period", "status", "q0", "v0")})
    return out
