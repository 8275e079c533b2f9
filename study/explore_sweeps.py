"""Stepped-sine sweeps up and down omega or sigma through a point ``hertzmap explore``'s user
clicked (the page lives in scheduler/doors/explore/), as plain functions of the store's Dataset:
:func:`line_sweep` (``study.solve.sweep.stepped_sweep`` on the store's grid values of that
axis, computed here), :func:`stored_line_sweep` (the store's ``sweeps`` product where it holds
that line), :func:`sweep_columns` (what the page draws: H1, H2, H1/2 and the amplitude, the
jumps marked), and their settings, values and fixed parameters. No server and no plotting
library: every number the page's sweep panel shows is tested without a browser.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from hertzmap.kernels.model import Model
from hertzmap.study.explore_data import Units

__all__ = ["SWEEP_AXES", "MAX_SWEEP_STEPS", "SWEEP_COLORS", "SWEEP_MARKERS", "SWEEP_QUANTITIES",
           "sweep_settings", "sweep_values", "sweep_fixed", "line_sweep", "stored_line_sweep",
           "sweep_columns"]


#: The parameters the page sweeps along (the map's two axes); zeta stays the shown one.
SWEEP_AXES = ("omega", "sigma")
#: Most steps of one sweep of the page (each direction). The sweep steps on the store's grid
#: values of the swept axis, every one of them up to this many: the default map's 161 omega or
#: 77 sigma values, at ~5 us per forcing period and 200-4200 periods per step, sweep up and
#: down in about 1 s on one core (a step that does not settle costs 4200 periods, ~25 ms: 200
#: of them are 5 s per direction, the worst case). A finer grid is swept on every k-th value
#: (the smallest k that keeps it within this many, counted from the clicked value, both ends
#: added): the answer stays within seconds while the user waits at the page.
MAX_SWEEP_STEPS = 200
#: The sweeps' colours and markers on the page, by direction (study/plots' SWEEP_STYLE)
SWEEP_COLORS = {"up": "#d62728", "down": "#1f77b4"}
SWEEP_MARKERS = {"up": "triangle", "down": "inverted_triangle"}
#: The quantities a sweep draws: (column, label, the Units scale it is in)
SWEEP_QUANTITIES = (("H1", "H1 (at the excitation frequency)", "force"),
                    ("H2", "H2 (at twice the excitation frequency)", "force"),
                    ("H1_2", "H1/2 (subharmonic)", "force"),
                    ("ptp", "amplitude, peak-to-peak", "disp"))


def sweep_settings(ds: xr.Dataset) -> dict[str, Any]:
    """The keyword arguments of ``study.solve.sweep.stepped_sweep`` for a sweep of the store
    (those of its ``sweeps`` output, study.solve.sweep_runs.sweep_specs): the store's
    model, exponent and solver rtol; its study's ``[sweep]`` jump_tol, settle_periods,
    record_periods (``study.spec.DEFAULT_SWEEP`` when the study has none); started from rest
    (``SWEEP_START``)."""
    from hertzmap.study.solve.sweep_runs import sweep_options
    from hertzmap.study.schema import study_from_attrs
    from hertzmap.study.spec import DEFAULT_SWEEP, StudyError

    try:
        study = study_from_attrs(ds.attrs)
    except StudyError:
        study = None
    if study is None:
        return sweep_options(Model.of(ds.attrs), DEFAULT_SWEEP)
    return sweep_options(study.model_value, study.sweep_dict or DEFAULT_SWEEP)


def sweep_values(ds: xr.Dataset, axis: str, omega: float, sigma: float, *,
                 max_steps: int = MAX_SWEEP_STEPS) -> tuple[np.ndarray, int]:
    """(values, stride): the steps of the page's sweep along ``axis`` ("omega" or "sigma")
    through the grid point nearest (omega, sigma): the store's grid values of that axis in
    increasing order, all of them when they are at most ``max_steps``, otherwise every
    stride-th one counted from the clicked point's value (so that it is a step), with the
    grid's first and last values (at most ``max_steps`` in all). Raises ValueError for another
    axis or a grid with one value along it."""
    if axis not in SWEEP_AXES:
        raise ValueError(f"a sweep of the page goes along omega or sigma, got {axis!r}")
    grid = np.sort(np.asarray(ds[axis].values, float))
    if grid.size < 2:
        raise ValueError(f"the store has one {axis} value ({grid[0]:g}): nothing to sweep "
                         "along; sweep the other axis")
    if int(max_steps) < 3:
        raise ValueError(f"max_steps must be >= 3, got {max_steps}")
    clicked = omega if axis == "omega" else sigma
    c = int(np.argmin(np.abs(grid - clicked)))
    if grid.size <= max_steps:
        return grid, 1
    stride = math.ceil(grid.size / (int(max_steps) - 2))
    idx = sorted(set(range(c % stride, grid.size, stride)) | {0, grid.size - 1})
    return grid[idx], stride


def sweep_fixed(ds: xr.Dataset, axis: str, omega: float, sigma: float, zeta: float
              ) -> dict[str, float]:
    """The grid point nearest (omega, sigma, zeta): the two parameters a sweep along ``axis``
    holds fixed."""
    pt = {"omega": omega, "sigma": sigma, "zeta": zeta}
    out = {}
    for a in ("omega", "sigma", "zeta"):
        if a != axis:
            g = np.asarray(ds[a].values, float)
            out[a] = float(g[np.argmin(np.abs(g - pt[a]))])
    return out


def _to_increasing(arr, direction: str):
    a = np.asarray(arr)
    return a[::-1].copy() if direction == "down" else a


def line_sweep(ds: xr.Dataset, axis: str, omega: float, sigma: float, zeta: float, *,
               max_steps: int = MAX_SWEEP_STEPS) -> dict[str, Any]:
    """Stepped-sine sweeps up and down ``axis`` ("omega" or "sigma") through the grid point
    nearest (omega, sigma, zeta), computed here: ``study.solve.sweep.stepped_sweep`` on the
    steps of :func:`sweep_values` with the store's :func:`sweep_settings`, each direction from
    rest at its first step (as the ``sweeps`` output computes each line). Returns the page's
    form of a sweep (also :func:`stored_line_sweep`'s): {"axis", "fixed" (the two parameters
    held), "source" ("computed"), "value" (steps, increasing), "up" and "down" ({"H1", "H2",
    "H1_2", "ptp", "period", "settled"} per step in increasing order, H1 H2 H1/2 as
    ``products.stepped_sweeps.force_components`` reads them off the orbit's force harmonics),
    "jumps" ([{direction, value, accuracy, kind, located, from_period, to_period, from_step,
    to_step}], steps as indices into "value", from_step -1 when there is none), "seconds"
    ({"up", "down"}), "stride", "grid_step" (the store's median step along the axis),
    "settings"}. Dimensionless throughout."""
    from hertzmap.study.solve.sweep import force_components
    from hertzmap.study.solve.sweep import DIRECTIONS, stepped_sweep

    values, stride = sweep_values(ds, axis, omega, sigma, max_steps=max_steps)
    fixed = sweep_fixed(ds, axis, omega, sigma, zeta)
    opts = sweep_settings(ds)
    ns = values.size
    out: dict[str, Any] = {"axis": axis, "fixed": fixed, "source": "computed", "value": values,
                           "jumps": [], "seconds": {}, "stride": stride,
                           "grid_step": _grid_step(ds, axis), "settings": opts}
    for direction in DIRECTIONS:
        sw = stepped_sweep(axis, values, fixed, direction, **opts)
        a = sw.arrays()
        h1, h2, h12 = force_components(a["force_harmonics"], a["period"])
        out[direction] = {name: _to_increasing(col, direction)
                          for name, col in (("H1", h1), ("H2", h2), ("H1_2", h12),
                                            ("ptp", a["ptp"]), ("period", a["period"]),
                                            ("settled", a["settled"]))}
        for j in sw.jumps:
            to = j.step_index if direction == "up" else ns - 1 - j.step_index
            frm = (to - 1 if direction == "up" else to + 1) if j.step_index > 0 else -1
            out["jumps"].append({"direction": direction, "value": float(j.value),
                                 "accuracy": float(j.accuracy), "kind": j.kind,
                                 "located": bool(j.located), "from_period": int(j.from_period),
                                 "to_period": int(j.to_period), "from_step": int(frm),
                                 "to_step": int(to)})
        out["seconds"][direction] = float(sw.seconds)
    return out


def _grid_step(ds: xr.Dataset, axis: str) -> float:
    g = np.sort(np.asarray(ds[axis].values, float))
    return float(np.median(np.diff(g))) if g.size > 1 else math.nan


def stored_line_sweep(sweeps: xr.Dataset | None, axis: str, omega: float, sigma: float,
                      zeta: float) -> dict[str, Any] | None:
    """The sweeps up and down ``axis`` through (omega, sigma, zeta) that the store's ``sweeps``
    product (products/sweeps, written by hertzmap run) holds, in :func:`line_sweep`'s form
    ("source": "stored"; "seconds": the run's wall time of each sweep on its worker; "stride"
    1: the product steps on every grid value); None when there is no product, it sweeps
    another axis, or none of its lines is the point's (its two fixed parameters equal the
    point's to 1e-9, relative)."""
    from hertzmap.study.products.stepped_sweeps import sweep_line
    from hertzmap.study.solve.sweep_runs import JUMP_KIND_CODES
    from hertzmap.study.solve.sweep import DIRECTIONS

    if sweeps is None or sweeps.attrs.get("sweep_axis", "omega") != axis:
        return None
    pt = {"omega": omega, "sigma": sigma, "zeta": zeta}
    names = [a for a in ("omega", "sigma", "zeta") if a != axis]
    if any(f"line_{a}" not in sweeps.coords for a in names):
        return None
    hit = np.ones(sweeps.sizes["line"], bool)
    for a in names:
        hit &= np.isclose(sweeps[f"line_{a}"].values, pt[a], rtol=1e-9, atol=1e-12)
    if not hit.any():
        return None
    i = int(np.flatnonzero(hit)[0])
    line = sweep_line(sweeps, i)
    kinds = {v: k for k, v in JUMP_KIND_CODES.items()}
    out: dict[str, Any] = {"axis": axis, "fixed": {a: float(line.attrs[a]) for a in names},
                           "source": "stored", "value": np.asarray(line["value"].values, float),
                           "jumps": [], "seconds": {}, "stride": 1,
                           "grid_step": float(np.median(np.diff(line["value"].values)))
                           if line.sizes["step"] > 1 else math.nan,
                           "settings": {"jump_tol": sweeps.attrs.get("sweep_jump_tol"),
                                        "settle_periods": sweeps.attrs.get("sweep_settle_periods"),
                                        "record_periods": sweeps.attrs.get("sweep_record_periods"),
                                        "x0": tuple(sweeps.attrs.get("sweep_start", (0.0, 0.0)))}}
    for d, direction in enumerate(DIRECTIONS):
        one = line.isel(direction=d)
        out[direction] = {n: np.asarray(one[n].values) for n in ("H1", "H2", "H1_2", "ptp",
                                                                   "period", "settled")}
        out["seconds"][direction] = float(one["sweep_seconds"].values)
    for j in range(line.sizes["jump"]):
        out["jumps"].append({
            "direction": DIRECTIONS[int(line["jump_direction"].values[j])],
            "value": float(line["jump_value"].values[j]),
            "accuracy": float(line["jump_accuracy"].values[j]),
            "kind": kinds.get(int(line["jump_kind"].values[j]), "?"),
            "located": bool(line["jump_located"].values[j]),
            "from_period": int(line["jump_from_period"].values[j]),
            "to_period": int(line["jump_to_period"].values[j]),
            "from_step": int(line["jump_from_step"].values[j]),
            "to_step": int(line["jump_to_step"].values[j])})
    return out


def sweep_columns(sweep: dict[str, Any], units: Units) -> dict[str, Any]:
    """The columns the page draws of a sweep (:func:`line_sweep` or :func:`stored_line_sweep`)
    in page units: for "up" and "down" {"x" (the swept value in page units), "value"
    (dimensionless), "H1", "H2", "H1_2" (contact force, ``units.force``), "ptp"
    (``units.disp``), "period"} in increasing order of the swept value, with a NaN row inserted
    between the two steps of each of that direction's jumps (the drawn path breaks there);
    "jumps": {"x" (the jump's location), "<q>_0" / "<q>_1" (the quantity q at the step before
    and the step after it), "kind", "direction", "color"} one row per jump; "xlabel"."""
    scale = units.freq if sweep["axis"] == "omega" else units.amp
    value = np.asarray(sweep["value"], float)
    out: dict[str, Any] = {"xlabel": scale.label}
    for direction in ("up", "down"):
        d = sweep[direction]
        cols = {"x": scale(value), "value": value,
                "period": np.asarray(d["period"], float)}
        for name, _, q in SWEEP_QUANTITIES:
            cols[name] = getattr(units, q)(np.asarray(d[name], float))
        cuts = sorted({max(j["from_step"], j["to_step"]) for j in sweep["jumps"]
                       if j["direction"] == direction and j["from_step"] >= 0})
        out[direction] = {k: np.insert(np.asarray(c, float), cuts, np.nan)
                          for k, c in cols.items()}
    jumps: dict[str, list] = {"x": [], "kind": [], "direction": [], "color": []}
    for name, _, _ in SWEEP_QUANTITIES:
        jumps[f"{name}_0"] = []
        jumps[f"{name}_1"] = []
    for j in sweep["jumps"]:
        d = sweep[j["direction"]]
        jumps["x"].append(float(scale(j["value"])))
        jumps["kind"].append(j["kind"])
        jumps["direction"].append(j["direction"])
        jumps["color"].append(SWEEP_COLORS[j["direction"]])
        for name, _, q in SWEEP_QUANTITIES:
            conv = getattr(units, q)
            a, c = j["from_step"], j["to_step"]
            jumps[f"{name}_0"].append(float(conv(d[name][a])) if a >= 0 else math.nan)
            jumps[f"{name}_1"].append(float(conv(d[name][c])))
    out["jumps"] = {k: (np.asarray(v, float) if k not in ("kind", "direction", "color")
                        else v) for k, v in jumps.items()}
    return out
