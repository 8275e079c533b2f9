"""What a lab measures along a line of the grid (issue 45): stepped-sine sweeps up and down one
parameter, with their jumps, as the product ``sweeps`` (written by ``hertzmap run``'s sweeps
stage for studies with the ``sweeps`` output: scheduler.sweep_tasks).

Paper Eq. 7 (dimensionless): q'' + 2 zeta q' + F(q) = 1 + sigma cos(omega tau). At each line of
the grid (each (sigma, zeta) of the study for the default ``[sweep] axis = "omega"``; each
(omega, zeta) for ``axis = "sigma"``) the grid's values of the swept axis are the steps of two
sweeps, up (increasing) and down (decreasing), each started from rest (q, q') = (0, 0) at its
first step: study.solve.sweep.stepped_sweep, one task each. Each step's response is the orbit
its transient settled on (or followed, see study.solve.sweep); the contact force's harmonics
H1 (at the excitation frequency), H2 (at twice it) and H1/2 (the subharmonic) are read off the
orbit's stored force harmonics (kernels.records ORBIT ``force_harmonics``: amplitudes of F/N at
k omega / m, k = 1..4, for an orbit of period m T). Jumps (where consecutive steps are on
different attractors) are bracketed by bisection to ``[sweep] jump_tol`` and named fold, flip,
loss or unlocated.

Beside them, the product holds the store's own orbits along each line (the block solver's and
the atlas's: every branch, stable or not), linked into branches for drawing (dim
``branch_point``): what the sweeps can land on, drawn grey behind them.

Pure: numpy and xarray; the sweeps themselves are computed by study.solve.sweep (here only in
:func:`stepped_sweeps`, the same in one process).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any, Mapping

import numpy as np
import xarray as xr

from hertzmap.kernels.records import N_HARMONICS, PERIOD_FLAGS, STATUS_FLAGS
from hertzmap.study.products.classes import class_flag_attrs, valid_orbits
from hertzmap.study.products.results import open_store, rig_of, source_attrs, var_attrs
from hertzmap.study.schema import study_from_attrs
from hertzmap.study.spec import DEFAULT_SWEEP, Study
from hertzmap.study.solve.sweep import DIRECTIONS, JUMP_KINDS, stepped_sweep

__all__ = ["SWEEPS", "JUMP_KIND_CODES", "SWEEP_START", "LINK_TOL", "force_components",
           "sweep_specs", "run_sweep", "sweep_record", "sweeps_dataset", "stepped_sweeps",
           "stored_branches", "sweep_line", "jumps_of"]

#: the product's name (its group products/sweeps)
SWEEPS = "sweeps"
#: the jump kinds as stored (``jump_kind``): study.solve.sweep.JUMP_KINDS, 1-based
JUMP_KIND_CODES = {kind: i + 1 for i, kind in enumerate(JUMP_KINDS)}
#: where each sweep starts: (q, q') at tau = 0 of its first step, the contact at rest under
#: its static load
SWEEP_START = (0.0, 0.0)
#: stored orbits of one period at consecutive grid values are one branch (for drawing) when
#: their min q and max q differ by at most this, relative to 1 + ptp (greedy, nearest first)
LINK_TOL = 0.25

#: the product's variables, declared once: name -> (long_name, units, description)
_STEP = {
    "period": ("period of the step's response", "1",
               "in forcing periods T = 2 pi / omega; 0: no periodic orbit (not settled)"),
    "status": ("status of the step's transient", "1",
               "kernels.status: 0 converged (settled on a stable periodic orbit); otherwise not "
               "within settle_periods + record_periods forcing periods"),
    "settled": ("the step settled", "1", "its transient settled on a stable periodic orbit"),
    "stable": ("the step's orbit is stable", "1",
               "both Floquet multipliers of its orbit inside the unit circle"),
    "branch": ("branch index", "1",
               "the branch the step is on, counted along the sweep: it changes at each jump"),
    "periods_run": ("forcing periods integrated", "1",
                    "until the transient settled, or the whole budget"),
    "min_q": ("minimum of q", "1", "over the step's orbit (over the record window without one)"),
    "max_q": ("maximum of q", "1", "over the step's orbit (over the record window without one)"),
    "ptp": ("peak-to-peak q (amplitude)", "1", "max q - min q of the step's response"),
    "loses_contact": ("the response loses contact", "1", "min q <= -n (q = -n: contact lost)"),
    "orbit_class": ("orbit class", "1", "study.orbit_rules class of the step's orbit (paper "
                    "Fig. 6 I-V, extended); 0: none"),
    "rms_force": ("rms contact force", "1", "rms of F/N over the orbit (NaN without one)"),
    "H1": ("contact-force harmonic H1", "1",
           "amplitude of F/N at the excitation frequency omega (paper Fig. 12-13 H1)"),
    "H2": ("contact-force harmonic H2", "1",
           "amplitude of F/N at twice the excitation frequency (paper Fig. 12-13 H2); NaN for "
           "an orbit of period m > 2 (its stored harmonics stop at 4 omega / m)"),
    "H1_2": ("contact-force subharmonic H1/2", "1",
             "amplitude of F/N at half the excitation frequency: non-zero only on orbits of even "
             "period (the 2-subharmonic resonance)"),
    "q0": ("displacement at tau = 0", "1", "the step's orbit's start point (NaN without one)"),
    "v0": ("velocity at tau = 0", "1", "the step's orbit's start point (NaN without one)"),
    "multipliers": ("Floquet multipliers", "1",
                    "of the step's orbit over its period (NaN without one)"),
}
_JUMP = {
    "jump_line": ("line of the jump", "1", "index on dim line"),
    "jump_direction": ("direction of the sweep", "1", "0 up, 1 down"),
    "jump_value": ("jump location", "1",
                   "the swept parameter where the followed branch ceases to attract (the "
                   "middle of the final bracket)"),
    "jump_accuracy": ("accuracy of the jump location", "1",
                      "width of the final bracket: jump_value is within half of it"),
    "jump_before": ("last value on the branch", "1",
                    "the bracket's end where the followed branch still attracts"),
    "jump_after": ("first value off the branch", "1",
                   "the bracket's end where it no longer does"),
    "jump_located": ("the jump is located", "1",
                     "bracketed by bisection (False: after a step without an orbit, bracket = "
                     "the two steps)"),
    "jump_kind": ("kind of jump", "1",
                  "1 fold (a real multiplier of the followed orbit -> +1: it disappears), 2 flip "
                  "(-> -1: it loses stability to a period-doubled response), 3 loss (neither: "
                  "a basin boundary crossed), 4 unlocated"),
    "jump_from_period": ("period left", "1", "of the attractor before the jump (0: none)"),
    "jump_to_period": ("period landed on", "1", "of the attractor after the jump (0: none)"),
    "jump_margin": ("distance of the naming multiplier", "1",
                    "to +1 (fold) or -1 (flip) of the followed orbit's multiplier at "
                    "jump_before"),
    "jump_multipliers": ("Floquet multipliers before the jump", "1",
                         "of the followed orbit at jump_before"),
    "jump_probes": ("bisection transients", "1", "run to locate the jump"),
    "jump_from_step": ("last step before the jump", "1",
                       "index on dim step of the sweep's last step on the branch left"),
    "jump_to_step": ("step landed on", "1", "index on dim step of the step after the jump"),
}
_SWEEP = {
    "sweep_seconds": ("wall time of the sweep", "s", "on its worker"),
    "sweep_probes": ("bisection transients of the sweep", "1", "over all its jumps"),
    "sweep_jumps": ("jumps of the sweep", "1", ""),
}
_BRANCH = {
    "branch_line": ("line of the stored orbit", "1", "index on dim line"),
    "branch_value": ("swept value of the stored orbit", "1", "its grid value on the line"),
    "branch_period": ("period of the stored orbit", "1", "in forcing periods"),
    "branch_stable": ("the stored orbit is stable", "1", ""),
    "branch_id": ("branch of the stored orbit", "1",
                  "orbits of one period at consecutive grid values linked when their min q and "
                  f"max q differ by at most {LINK_TOL} (1 + ptp), nearest first: a drawing aid, "
                  "not continuation"),
    "branch_ptp": ("peak-to-peak q of the stored orbit", "1", ""),
    "branch_max_q": ("maximum of q of the stored orbit", "1", ""),
    "branch_H1": ("H1 of the stored orbit", "1", "as H1 (NaN without the force_harmonics "
                                                "output)"),
    "branch_H2": ("H2 of the stored orbit", "1", "as H2"),
    "branch_H1_2": ("H1/2 of the stored orbit", "1", "as H1_2"),
}
_STEP_FIELDS = ("value", "period", "status", "settled", "stable", "min_q", "max_q", "ptp",
                "loses_contact", "rms_force", "class_code", "branch", "periods_run")


def force_components(force_harmonics, period) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(H1, H2, H1/2): the amplitudes of F/N at omega, 2 omega and omega / 2 of orbits of
    ``period`` m whose ``force_harmonics`` (..., 4) are at k omega / m, k = 1..4: H1 is k = m,
    H2 k = 2m, H1/2 k = m / 2 (0 for an odd m: an m T orbit has no component at omega / 2);
    NaN where k > 4 or there is no orbit (m = 0)."""
    fh = np.asarray(force_harmonics, float)
    m = np.asarray(period, int)
    out = []
    for k, half in ((m, False), (2 * m, False), (m // 2, True)):
        ok = (m > 0) & (k >= 1) & (k <= N_HARMONICS)
        got = np.take_along_axis(fh, np.clip(k - 1, 0, N_HARMONICS - 1)[..., None],
                                 axis=-1)[..., 0]
        val = np.where(ok, got, np.nan)
        if half:
            val = np.where((m > 0) & (m % 2 == 1), 0.0, val)
        out.append(val)
    return out[0], out[1], out[2]


def sweep_specs(study: Study) -> list[dict[str, Any]]:
    """The sweeps of a study with the ``sweeps`` output, one dict each (line, its fixed
    parameters, direction, and the keyword arguments of study.solve.sweep.stepped_sweep):
    every line of :meth:`Study.sweep_lines`, up then down."""
    settings = study.sweep_dict
    if settings is None:
        return []
    axis = settings["axis"]
    values = np.sort(study.axis(axis))
    kw = study.solver_kwargs()
    options = {"exponent": kw["exponent"], "model": kw["model"], "rtol": kw["rtol"],
               "jump_tol": settings["jump_tol"], "settle_periods": settings["settle_periods"],
               "record_periods": settings["record_periods"]}
    return [{"line": i, "direction": d,
             "sweep": {"axis": axis, "values": values, "fixed": fixed, "direction": d,
                       "x0": SWEEP_START, **options}}
            for i, fixed in enumerate(study.sweep_lines()) for d in DIRECTIONS]


def run_sweep(spec: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """One sweep of :func:`sweep_specs` computed: its :func:`sweep_record`."""
    return sweep_record(stepped_sweep(**spec["sweep"]))


def sweep_record(sweep) -> dict[str, np.ndarray]:
    """The arrays of one stepped sweep (a study.solve.sweep.Sweep), in sweep order, as its
    task returns them (numbers only: staged by the run as one .npz file): per step the
    fields of ``Sweep.arrays`` with ``force_harmonics`` (steps, 4), ``multipliers`` (steps, 2);
    per jump ``jump_*``; and ``seconds``, ``probes``."""
    a = sweep.arrays()
    out = {name: np.asarray(a[name]) for name in _STEP_FIELDS}
    out["force_harmonics"] = np.asarray(a["force_harmonics"], float).reshape(-1, N_HARMONICS)
    out["q0"], out["v0"] = np.asarray(a["q0"], float), np.asarray(a["v0"], float)
    out["multipliers"] = np.array([s.multipliers for s in sweep.steps], complex).reshape(-1, 2)
    js = sweep.jumps
    for name, get, dtype in (
            ("value", lambda j: j.value, float), ("accuracy", lambda j: j.accuracy, float),
            ("before", lambda j: j.before, float), ("after", lambda j: j.after, float),
            ("located", lambda j: j.located, bool),
            ("kind", lambda j: JUMP_KIND_CODES[j.kind], np.int8),
            ("from_period", lambda j: j.from_period, np.int8),
            ("to_period", lambda j: j.to_period, np.int8),
            ("margin", lambda j: j.margin, float), ("probes", lambda j: j.probes, np.int32),
            ("step", lambda j: j.step_index, np.int32)):
        out[f"jump_{name}"] = np.array([get(j) for j in js], dtype)
    out["jump_multipliers"] = np.array([j.multipliers for j in js], complex).reshape(-1, 2)
    out["seconds"] = np.float64(sweep.seconds)
    out["probes"] = np.int64(sweep.probes)
    return out


def _attrs(table: dict, name: str, **extra) -> dict[str, Any]:
    long_name, units, description = table[name]
    return var_attrs(long_name, units, description, **extra)


def stored_branches(ds: xr.Dataset, axis: str, lines: list[dict[str, float]]) -> dict:
    """The store's orbits along each line (``ds``: study.products.open_store, sorted axes):
    one row per valid orbit (study.products.valid_orbits), in line and value order, linked
    into branches for drawing (:data:`LINK_TOL`). Returns the ``branch_*`` arrays."""
    rows: dict[str, list] = {k: [] for k in _BRANCH}
    ok_all = valid_orbits(ds)
    next_id = 0
    for i, fixed in enumerate(lines):
        line = ds.sel(fixed)
        ok = ok_all.sel(fixed).transpose(axis, "solution").values
        values = line[axis].values
        per = line["period"].transpose(axis, "solution").values.astype(int)
        stable = line["stable"].transpose(axis, "solution").values.astype(bool)
        lo = (line["min_q"].transpose(axis, "solution").values if "min_q" in line
              else np.full(per.shape, np.nan))
        hi = (line["max_q"].transpose(axis, "solution").values if "max_q" in line
              else np.full(per.shape, np.nan))
        if "force_harmonics" in line:
            h = force_components(line["force_harmonics"].transpose(axis, "solution", ...).values,
                                 np.where(ok, per, 0))
        else:
            h = (np.full(per.shape, np.nan),) * 3
        open_: dict[int, tuple[int, float, float]] = {}      # branch id -> (period, lo, hi)
        for k in range(values.size):
            slots = np.flatnonzero(ok[k])
            ids = {}
            pairs = []
            for s in slots:
                for b, (p, blo, bhi) in open_.items():
                    if p != per[k, s]:
                        continue
                    d = (abs(lo[k, s] - blo) + abs(hi[k, s] - bhi)) / (1.0 + abs(hi[k, s] - lo[k, s]))
                    if np.isfinite(d) and d <= LINK_TOL:
                        pairs.append((d, s, b))
            used = set()
            for d, s, b in sorted(pairs):
                if s not in ids and b not in used:
                    ids[s] = b
                    used.add(b)
            new_open = {}
            for s in slots:
                if s not in ids:
                    ids[s] = next_id
                    next_id += 1
                new_open[ids[s]] = (per[k, s], lo[k, s], hi[k, s])
                for name, value in (("branch_line", i), ("branch_value", values[k]),
                                    ("branch_period", per[k, s]),
                                    ("branch_stable", stable[k, s]), ("branch_id", ids[s]),
                                    ("branch_ptp", hi[k, s] - lo[k, s]),
                                    ("branch_max_q", hi[k, s]), ("branch_H1", h[0][k, s]),
                                    ("branch_H2", h[1][k, s]), ("branch_H1_2", h[2][k, s])):
                    rows[name].append(value)
            open_ = new_open
    dtypes = {"branch_line": np.int32, "branch_period": np.int8, "branch_stable": bool,
              "branch_id": np.int32}
    return {k: np.array(v, dtypes.get(k, float)) for k, v in rows.items()}


def sweeps_dataset(ds: xr.Dataset, records: Mapping[tuple[int, str], Mapping[str, Any]],
                   study: Study | None = None) -> xr.Dataset:
    """The ``sweeps`` product from the sweeps' records (:func:`sweep_record`, by (line,
    direction)) and the results ``ds`` (study.products.open_store: the store's orbits along
    each line, the source attrs; ``study``: the study, read from ds's attrs by default).
    A sweep without a record (its task failed) is left empty (NaN, 0, False).

    Dims: ``line`` (the lines swept, coordinates ``line_<param>`` for the two fixed
    parameters), ``direction`` (0 up, 1 down), ``step`` (the grid's values of the swept axis in
    increasing order, coordinate ``value``: the down sweep ran them from the last to the
    first), ``multiplier`` (2); ``jump`` (every jump of every sweep, in line, direction and
    sweep order); ``branch_point`` (the store's orbits along each line). With a ``[rig]``:
    ``frequency_hz`` (axis omega) or ``force_amplitude_N`` (axis sigma) on dim step,
    ``jump_frequency_hz`` / ``jump_force_amplitude_N``, and H1_N, H2_N, H1_2_N (N), ptp_m (m).
    """
    study = study_from_attrs(ds.attrs) if study is None else study
    settings = study.sweep_dict or {}
    axis = settings.get("axis", "omega")
    lines = study.sweep_lines()
    values = np.sort(study.axis(axis))
    nl, ns = len(lines), values.size
    shape = (nl, len(DIRECTIONS), ns)
    step = {"period": np.zeros(shape, np.int8), "status": np.full(shape, -1, np.int8),
            "settled": np.zeros(shape, bool), "stable": np.zeros(shape, bool),
            "branch": np.full(shape, -1, np.int16), "periods_run": np.zeros(shape, np.int32),
            "min_q": np.full(shape, np.nan), "max_q": np.full(shape, np.nan),
            "ptp": np.full(shape, np.nan), "loses_contact": np.zeros(shape, bool),
            "orbit_class": np.zeros(shape, np.int8), "rms_force": np.full(shape, np.nan),
            "H1": np.full(shape, np.nan), "H2": np.full(shape, np.nan),
            "H1_2": np.full(shape, np.nan), "q0": np.full(shape, np.nan),
            "v0": np.full(shape, np.nan),
            "multipliers": np.full(shape + (2,), complex(np.nan, 0.0))}
    per_sweep = {"sweep_seconds": np.full(shape[:2], np.nan),
                 "sweep_probes": np.zeros(shape[:2], np.int32),
                 "sweep_jumps": np.zeros(shape[:2], np.int32)}
    jumps: dict[str, list] = {k: [] for k in _JUMP}
    for i in range(nl):
        for d, direction in enumerate(DIRECTIONS):
            rec = records.get((i, direction))
            if rec is None:
                continue
            rv = np.asarray(rec["value"], float)
            # sweep order -> dim step (increasing values): the down sweep is reversed
            at = np.searchsorted(values, rv)
            if not (np.all(at < ns) and np.array_equal(values[np.minimum(at, ns - 1)], rv)):
                raise ValueError(f"the sweep of line {i} ({direction}) did not step on the "
                                 f"study's {axis} values")
            h1, h2, h12 = force_components(rec["force_harmonics"], rec["period"])
            for name, src in (("period", rec["period"]), ("status", rec["status"]),
                              ("settled", rec["settled"]), ("stable", rec["stable"]),
                              ("branch", rec["branch"]), ("periods_run", rec["periods_run"]),
                              ("min_q", rec["min_q"]), ("max_q", rec["max_q"]),
                              ("ptp", rec["ptp"]), ("loses_contact", rec["loses_contact"]),
                              ("orbit_class", rec["class_code"]),
                              ("rms_force", rec["rms_force"]), ("H1", h1), ("H2", h2),
                              ("H1_2", h12), ("q0", rec["q0"]), ("v0", rec["v0"]),
                              ("multipliers", rec["multipliers"])):
                step[name][i, d, at] = np.asarray(src).astype(step[name].dtype)
            per_sweep["sweep_seconds"][i, d] = float(rec["seconds"])
            per_sweep["sweep_probes"][i, d] = int(rec["probes"])
            per_sweep["sweep_jumps"][i, d] = len(rec["jump_value"])
            for k in range(len(rec["jump_value"])):
                jumps["jump_line"].append(i)
                jumps["jump_direction"].append(d)
                for name in ("value", "accuracy", "before", "after", "located", "kind",
                             "from_period", "to_period", "margin", "probes"):
                    jumps[f"jump_{name}"].append(rec[f"jump_{name}"][k])
                jumps["jump_multipliers"].append(rec["jump_multipliers"][k])
                landed = int(rec["jump_step"][k])
                jumps["jump_from_step"].append(at[landed - 1] if landed > 0 else -1)
                jumps["jump_to_step"].append(at[landed])
    jdtypes = {"jump_line": np.int32, "jump_direction": np.int8, "jump_located": bool,
               "jump_kind": np.int8, "jump_from_period": np.int8, "jump_to_period": np.int8,
               "jump_probes": np.int32, "jump_from_step": np.int32, "jump_to_step": np.int32,
               "jump_multipliers": complex}
    jarr = {k: np.array(v, jdtypes.get(k, float)) for k, v in jumps.items()}
    jarr["jump_multipliers"] = jarr["jump_multipliers"].reshape(-1, 2)
    branches = stored_branches(ds, axis, lines)

    dims3 = ("line", "direction", "step")
    flags = {"period": dict(flag_values=np.array([v for v, _ in PERIOD_FLAGS], np.int8),
                            flag_meanings=" ".join(m for _, m in PERIOD_FLAGS)),
             "status": dict(flag_values=np.array([v for v, _ in STATUS_FLAGS], np.int8),
                            flag_meanings=" ".join(m for _, m in STATUS_FLAGS)),
             "orbit_class": class_flag_attrs()}
    data = {}
    for name, arr in step.items():
        dims = dims3 + (("multiplier",) if name == "multipliers" else ())
        data[name] = (dims, arr, _attrs(_STEP, name, **flags.get(name, {})))
    for name, arr in per_sweep.items():
        data[name] = (("line", "direction"), arr, _attrs(_SWEEP, name))
    for name, arr in jarr.items():
        extra = {}
        if name == "jump_kind":
            extra = dict(flag_values=np.array(list(JUMP_KIND_CODES.values()), np.int8),
                         flag_meanings=" ".join(JUMP_KIND_CODES))
        elif name == "jump_direction":
            extra = dict(flag_values=np.arange(len(DIRECTIONS), dtype=np.int8),
                         flag_meanings=" ".join(DIRECTIONS))
        dims = ("jump", "multiplier") if name == "jump_multipliers" else ("jump",)
        data[name] = (dims, arr, _attrs(_JUMP, name, **extra))
    for name, arr in branches.items():
        data[name] = (("branch_point",), arr, _attrs(_BRANCH, name))
    fixed_axes = [a for a in ("omega", "sigma", "zeta") if a != axis]
    coords = {
        "line": ("line", np.arange(nl, dtype=np.int32), var_attrs(
            "line", "1", f"a line of the grid: its {' and '.join(fixed_axes)} in line_"
            f"{fixed_axes[0]}, line_{fixed_axes[1]}")),
        "direction": ("direction", np.arange(len(DIRECTIONS), dtype=np.int8), var_attrs(
            "sweep direction", "1", "0 up (increasing values), 1 down (decreasing)",
            flag_values=np.arange(len(DIRECTIONS), dtype=np.int8),
            flag_meanings=" ".join(DIRECTIONS))),
        "step": ("step", np.arange(ns, dtype=np.int32), var_attrs(
            "step", "1", f"index of the step's {axis} value among the grid's, increasing")),
        "value": ("step", values, var_attrs(
            f"{axis} (the swept parameter)", "1",
            f"the grid's {axis} values, increasing: the steps of both sweeps")),
        "jump": ("jump", np.arange(jarr["jump_value"].size, dtype=np.int32), var_attrs(
            "jump", "1", "every jump of every sweep, by line, direction and sweep order")),
    }
    for a in fixed_axes:
        coords[f"line_{a}"] = ("line", np.array([f[a] for f in lines], float), var_attrs(
            {"omega": "excitation frequency omega", "sigma": "excitation amplitude sigma",
             "zeta": "damping ratio zeta"}[a], "1", f"the line's {a} (held fixed)"))
    out = xr.Dataset(data, coords=coords)
    out.attrs = {**source_attrs(ds, "stepped-sine sweeps up and down each line, with their "
                                    "jumps (what a lab measures)"),
                 "hertzmap_product_source": "hertzmap run: the sweeps stage "
                                            "(scheduler.sweep_tasks)",
                 "sweep_axis": axis, "sweep_jump_tol": float(settings.get("jump_tol", np.nan)),
                 "sweep_settle_periods": int(settings.get("settle_periods", 0)),
                 "sweep_record_periods": int(settings.get("record_periods", 0)),
                 "sweep_start": list(SWEEP_START),
                 "method": "study.solve.sweep.stepped_sweep: each step starts where the last "
                           "ended and settles on an attractor (stroboscopic map, Newton "
                           "shooting); jumps bracketed by bisection from the followed branch "
                           "(the quasi-static limit) and named from its Floquet multipliers"}
    return _with_rig(out, axis, rig_of(ds))


def _with_rig(out: xr.Dataset, axis: str, rig) -> xr.Dataset:
    """The rig's units (study.analytic.rig.Rig, paper Eq. 1-8, 30) added to the product."""
    if rig is None:
        return out
    for name in ("H1", "H2", "H1_2"):
        out[f"{name}_N"] = (out[name] * rig.N).assign_attrs(var_attrs(
            out[name].attrs["long_name"], "N", f"N times {name} (N = {rig.N:g} N, the study's "
            "[rig])"))
    out["ptp_m"] = (out["ptp"] * rig.z_s / rig.n).assign_attrs(var_attrs(
        "peak-to-peak displacement", "m", "ptp z_s / n (paper Eq. 5)"))
    if axis == "omega":
        out = out.assign_coords(frequency_hz=("step", np.asarray(rig.omega_to_frequency(
            out["value"].values), float), var_attrs(
            "excitation frequency", "Hz", f"omega f0, f0 = {rig.f0:.6g} Hz (the study's [rig])")))
        out["jump_frequency_hz"] = ("jump", np.asarray(rig.omega_to_frequency(
            out["jump_value"].values), float), var_attrs(
            "jump frequency", "Hz", "jump_value f0"))
        out["jump_accuracy_hz"] = ("jump", np.asarray(rig.omega_to_frequency(
            out["jump_accuracy"].values), float), var_attrs(
            "accuracy of the jump frequency", "Hz", "jump_accuracy f0"))
    else:
        out = out.assign_coords(force_amplitude_N=("step", np.asarray(
            rig.sigma_to_force_amplitude(out["value"].values), float), var_attrs(
            "excitation force amplitude", "N", f"sigma N, N = {rig.N:g} N (the study's [rig])")))
        out["jump_force_amplitude_N"] = ("jump", np.asarray(rig.sigma_to_force_amplitude(
            out["jump_value"].values), float), var_attrs(
            "jump force amplitude", "N", "jump_value N"))
    out.attrs.update({"rig_f0_hz": rig.f0, "rig_N": rig.N, "rig_m": rig.m, "rig_k": rig.k,
                      "rig_z_s": rig.z_s})
    return out


def stepped_sweeps(ds: xr.Dataset) -> xr.Dataset:
    """The ``sweeps`` product computed in this process (every sweep one after the other): what
    the run's sweeps stage (scheduler.sweep_tasks, the ``sweeps`` output) computes on its
    workers and stores as products/sweeps. ``ds``: the results of a study with the ``sweeps``
    output (or any study: its [sweep] defaults then)."""
    if "computed" not in ds:
        ds = open_store(ds)
    study = study_from_attrs(ds.attrs)
    if study.sweep is None:
        study = replace(study, sweep=tuple(sorted(DEFAULT_SWEEP.items())))
    records = {(s["line"], s["direction"]): run_sweep(s) for s in sweep_specs(study)}
    return sweeps_dataset(ds, records, study)


def sweep_line(sweeps: xr.Dataset, line: int) -> xr.Dataset:
    """One line of the product: its steps (dims direction, step), its jumps (dim jump) and the
    store's orbits along it (dim branch_point), with the line's fixed parameters in the
    attrs."""
    one = sweeps.isel(line=line)
    one = one.isel(jump=np.flatnonzero(sweeps["jump_line"].values == line),
                   branch_point=np.flatnonzero(sweeps["branch_line"].values == line))
    for name in sweeps.coords:
        if name.startswith("line_"):
            one.attrs[name.removeprefix("line_")] = float(sweeps[name].values[line])
    return one


def jumps_of(sweeps: xr.Dataset) -> list[dict[str, Any]]:
    """The product's jumps as plain rows (line, its fixed parameters, direction, value,
    accuracy, kind, from_period, to_period, located): for printing and tables."""
    kinds = {v: k for k, v in JUMP_KIND_CODES.items()}
    fixed = [n for n in sweeps.coords if n.startswith("line_")]
    rows = []
    for j in range(sweeps.sizes.get("jump", 0)):
        i = int(sweeps["jump_line"].values[j])
        rows.append({"line": i, **{n.removeprefix("line_"): float(sweeps[n].values[i])
                                   for n in fixed},
                     "direction": DIRECTIONS[int(sweeps["jump_direction"].values[j])],
                     "value": float(sweeps["jump_value"].values[j]),
                     "accuracy": float(sweeps["jump_accuracy"].values[j]),
                     "kind": kinds[int(sweeps["jump_kind"].values[j])],
                     "from_period": int(sweeps["jump_from_period"].values[j]),
                     "to_period": int(sweeps["jump_to_period"].values[j]),
                     "located": bool(sweeps["jump_located"].values[j])})
    return rows
