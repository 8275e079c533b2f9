"""The error of a run's results: a deterministic sample of its converged orbits re-solved at a
tighter tolerance, the deviation of their start points reported and stored in the store's attrs."""
from __future__ import annotations

import json
import math
import time
from typing import Any

import numpy as np

from hertzmap.scheduler.stages.stage import Task, TaskRunner
from hertzmap.scheduler.stages.worker import DEFAULT_SOLVER, solve_points
from hertzmap.study.spec import Study

#: Grid points re-solved by the error estimate.
#: The error estimate re-solves at rtol * ERROR_RTOL_FACTOR (not below the solver's floor).
ERROR_RTOL_FACTOR = 1e-3
RTOL_FLOOR = 1e-13


def error_task(spec: dict[str, Any]) -> dict[str, Any]:
    """Re-solve the sample (runs on a worker): scheduler.stages.worker.solve_points of the spec's
    points, options, solver and seeds, with the seconds it took."""
    t0 = time.perf_counter()
    refs = solve_points(spec["points"], spec["kwargs"], spec["solver"], spec["seeds"])
    return {"refs": refs, "seconds": time.perf_counter() - t0}


def estimate_error(runner: TaskRunner, study: Study, samples: list[tuple], *, solver: str = DEFAULT_SOLVER,
                   rtol_factor: float = ERROR_RTOL_FACTOR) -> dict[str, Any]:
    """Re-solve sampled converged points at a tighter tolerance (one task of the runner's
    stage "error sample"); report the deviation of (q0, v0).

    ``samples``: (omega, sigma, zeta, period, q0, v0) of converged slots. Each point is solved
    alone at rtol * rtol_factor (not below 1e-13), with the sampled orbit's own start point as
    one more seed (for solvers that take ``seeds``): Newton from 1e-10 away finds that orbit
    again, where the point's automatic seeds alone missed the orbits that only continuation
    reaches (5 of 8 samples matched on the default study, 2-3 of 8 on the fine map). Each
    sampled slot is matched with the nearest converged re-solved slot of the same period; one
    without a match within 1e-3 is counted as unmatched, not as an error.
    """
    rtol_ref = max(study.rtol * rtol_factor, RTOL_FLOOR)
    out: dict[str, Any] = {"n": len(samples), "rtol": study.rtol, "rtol_ref": rtol_ref,
                           "matched": 0, "max_deviation": math.nan}
    if not samples:
        return out
    kwargs = study.solver_kwargs()
    kwargs["rtol"] = rtol_ref
    points = [s[:3] for s in samples]
    seeds = [[(int(p), float(q0), float(v0))] for (_, _, _, p, q0, v0) in samples]
    got: dict[str, Any] = {}
    spec = {"points": points, "kwargs": kwargs, "solver": solver, "seeds": seeds}
    cost = runner.map("error sample", error_task,
                      [Task(f"hertzmap-error-{study.hash[:12]}", spec, len(points))],
                      lambda task, res: got.update(res), unit="tasks")
    if cost.failed:
        raise RuntimeError(cost.failed[0][1])
    refs = got["refs"]
    devs = []
    for (w, s, z, p, q0, v0), ref in zip(samples, refs):
        ok = (ref["status"] == 0) & (ref["period"] == p)
        if not ok.any():
            continue
        d = np.maximum(np.abs(ref["q0"][ok] - q0), np.abs(ref["v0"][ok] - v0)).min()
        if d <= 1e-3:
            devs.append(float(d))
    out["matched"] = len(devs)
    if devs:
        out["max_deviation"] = max(devs)
    out["ref_equals_run"] = rtol_ref >= study.rtol
    return out


def record_error_estimate(store, summary: dict[str, Any]) -> None:
    """The error estimate and the wall time of this run into the store's attrs
    (``hertzmap_error_estimate``, JSON; NaN as null), then the history line."""
    e = dict(summary.get("error") or {})
    e["wall_seconds"] = summary.get("wall")
    e = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in e.items()}
    try:
        store.set_attrs(hertzmap_error_estimate=json.dumps(e))
        dev = e.get("max_deviation")
        store.add_history(f"error estimate: max |d(q0, v0)| = "
                          f"{'n/a' if dev is None else format(dev, '.2e')} over {e.get('matched', 0)}/"
                          f"{e.get('n', 0)} orbits at rtol {e.get('rtol_ref')}; wall {e['wall_seconds']:.2f} s")
    except Exception as exc:  # a report, never a reason to fail the run
        summary.setdefault("error", {})["store_failed"] = f"{type(exc).__name__}: {exc}"
