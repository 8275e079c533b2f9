"""``hertzmap fit`` and ``hertzmap.fit``: f0, zeta and sigma (and on request n) identified from
a lab's measured stepped-sine sweeps (study.identify, docs/identify.md), the fit's tasks on a
Dask cluster: the user's client, an existing scheduler, or an embedded LocalCluster.

Everything the user gives (the measurement, the rig table, the output folder) is checked
before a cluster starts and before anything is written (study.identify raises FitInputError,
naming the row and column or the field; the command line exits with code 2). The fit's three
stages (study.identify.estimation: the global grid over (sigma, zeta[, n]), the Gauss-Newton
refinement, the profile points) hand their batches of tasks to :class:`DaskMapper`, which
runs them through the one TaskRunner (scheduler.stages.stage) as the run's stages do: one task per
grid cell, per forward model of a Jacobian, per profile point; each task the pure function
:func:`fit_task` (study.identify.estimation.run_task on a worker). The result, an xarray
Dataset, is written to ``--out`` as ``<name>_fit.nc`` (netCDF 3, written to a temporary file
and renamed: whole or not at all) beside its figure ``<name>_fit.png``.
"""
from __future__ import annotations

import io
import os
import sys
import time
import uuid
from pathlib import Path
from typing import Any, Callable, TextIO

import numpy as np
import xarray as xr

from hertzmap.scheduler.cluster.clusters import ClusterSpec, close_quietly, make_client
from hertzmap.scheduler.interrupt import DeferInterrupt
from hertzmap.scheduler.stages.stage import Task, TaskRunner
from hertzmap.study.identify.estimation import fit as fit_problem_
from hertzmap.study.identify.estimation import in_process as run_here
from hertzmap.study.identify.estimation import run_task
from hertzmap.study.identify.fit_dataset import fit_dataset, summary_lines
from hertzmap.study.identify.measurement import (FitInputError, Measurement,
                                                 measurement_from_dataset, read_measurement)
from hertzmap.study.identify.problem import fit_problem
from hertzmap.study.identify.rig_table import rig_table

__all__ = ["fit_task", "DaskMapper", "load_inputs", "run_fit", "output_paths"]

#: the batches whose progress is shown (the others are a Jacobian's one or two models)
_SHOWN = ("global grid", "profiles")


def fit_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One task of a fit (runs on a worker): a global cell, a forward model or a profile
    point (study.identify.estimation.run_task); a dict with its ``seconds``."""
    return run_task(spec)


class DaskMapper:
    """A fit's mapper on a Dask client: each batch through the TaskRunner, results in the
    order given; a task that fails for good fails the fit (RuntimeError naming it)."""

    def __init__(self, client, err: TextIO):
        self.runner = TaskRunner(client, DeferInterrupt(), err)
        self.err = err
        self.call = uuid.uuid4().hex[:8]      # this fit's keys: never an earlier fit's
        self.count = 0

    def __call__(self, label: str, specs: list) -> list:
        tasks = []
        for s in specs:
            tasks.append(Task(f"hertzmap-fit-{self.call}-{self.count}", s))
            self.count += 1
        results: dict[str, dict] = {}
        self.runner.err = self.err if label in _SHOWN else io.StringIO()
        cost = self.runner.map(f"fit {label}", fit_task, tasks,
                               lambda task, res: results.update({task.key: res}), unit="tasks")
        if cost.failed:
            raise RuntimeError(f"fit: {len(cost.failed)} task(s) of the {label} failed: "
                               f"{cost.failed[0][1]}")
        return [results[t.key] for t in tasks]


def output_paths(out: str | Path, name: str) -> tuple[Path, Path]:
    """(netCDF file, figure) of a fit named ``name`` in the folder ``out``."""
    out = Path(out)
    return out / f"{name}_fit.nc", out / f"{name}_fit.png"


def load_inputs(measured, rig) -> tuple[Measurement, Any, Any]:
    """(measurement, rig table, problem) from what the user gave: a measurement as a path
    (CSV, netCDF, zarr), an xarray Dataset or a Measurement; a rig table as a path, TOML
    text, a dict of tables or a RigTable. Raises FitInputError."""
    if isinstance(measured, Measurement):
        meas = measured
    elif isinstance(measured, xr.Dataset):
        meas = measurement_from_dataset(measured)
    elif isinstance(measured, (str, Path)):
        meas = read_measurement(measured)
    else:
        raise FitInputError("give the measurement as a file's path (CSV, .nc, .zarr), an "
                            f"xarray Dataset or a Measurement, got {type(measured).__name__}")
    table = rig_table(rig)
    return meas, table, fit_problem(meas, table)


def _check_out(out: Path) -> None:
    """The output folder can be made and written (checked before anything is computed)."""
    probe = out if out.exists() else next((p for p in out.parents if p.exists()), Path("."))
    if out.exists() and not out.is_dir():
        raise FitInputError("exists and is not a folder", field=f"--out {out}")
    if not os.access(probe, os.W_OK):
        raise FitInputError(f"{probe} is not writable", field=f"--out {out}")


def run_fit(measured, rig, *, out: str | Path | None = None, name: str | None = None,
            client=None, cluster: ClusterSpec | None = None, in_process: bool = False,
            report: Callable[[str], None] | None = None, err: TextIO | None = None,
            figure: bool = True) -> xr.Dataset:
    """Fit a measurement (module docstring). ``client``: a Dask client of the user's (kept
    open); else ``cluster`` (default: an embedded LocalCluster, one worker per core) is
    started and closed; ``in_process``: the tasks run in this process, no Dask. ``out``: the
    folder the Dataset and its figure are written to (None: nothing written); ``name``: their
    file names' stem (default: the measurement's). Returns the Dataset. Raises FitInputError
    (bad input: nothing computed or written) or RefusedError (a cluster that cannot start)."""
    report = report or (lambda line: print(line, flush=True))
    err = err or sys.stderr
    meas, table, problem = load_inputs(measured, rig)
    out = Path(out) if out is not None else None
    if out is not None:
        _check_out(out)
    stem = name or (Path(meas.source).stem if meas.source and not meas.source.startswith("<")
                    else "measurement")
    report(f"fit: {meas.size} measured steps ({', '.join(meas.directions)}), "
           f"{int(np.isfinite(problem.amplitude).sum())} readings of "
           f"{', '.join(meas.channels)}; fitting {', '.join(problem.free)} within f0 "
           f"{problem.bounds['f0'][0]:.5g}..{problem.bounds['f0'][1]:.5g} Hz, sigma "
           f"{problem.bounds['sigma'][0]:.4g}..{problem.bounds['sigma'][1]:.4g}, zeta "
           f"{problem.bounds['zeta'][0]:.4g}..{problem.bounds['zeta'][1]:.4g}; model sweeps "
           f"over omega {problem.omega[0]:.4g}..{problem.omega[-1]:.4g} "
           f"({problem.omega.size} steps a direction)")
    t0 = time.perf_counter()
    own, made = None, False
    if in_process:
        mapper, where = run_here, "in this process"
    else:
        if client is None:
            spec = cluster or ClusterSpec(kind="local")
            client, own = make_client(spec)
            made = True
        mapper = DaskMapper(client, err)
        workers = len(client.scheduler_info(n_workers=-1)["workers"])
        where = f"on {workers} Dask worker{'s' if workers != 1 else ''}"
    report(f"fit: running {where}")
    try:
        result = fit_problem_(problem, mapper, report=lambda s: report("fit: " + s))
    finally:
        if made:                # the client (and the cluster) this call made: closed
            close_quietly(client, own)
    wall = time.perf_counter() - t0
    ds = fit_dataset(result, meas, table, {"fit_wall_seconds": wall,
                                           "fit_where": where})
    stages = result.stages
    report(f"fit: done in {wall:.1f} s: " + "; ".join(
        f"{k} {v[3]} tasks, {v[2]:.1f} s CPU, {v[0]:.1f} s wall"
        for k, v in stages.items() if k != "total") + f"; {result.forward_models} forward "
        "models")
    for line in summary_lines(ds):
        report(line)
    if out is not None:
        nc, png = output_paths(out, stem)
        out.mkdir(parents=True, exist_ok=True)
        tmp = nc.with_name(nc.name + ".tmp")
        ds.to_netcdf(tmp, engine="scipy")
        os.replace(tmp, nc)
        report(f"fit: {nc}")
        if figure:
            from hertzmap.study.plots.fit_figures import plot_fit
            report(f"fit: {plot_fit(ds, png)}")
    return ds
