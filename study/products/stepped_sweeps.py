"""What a lab measures along a line of the grid (issue 45): stepped-sine sweeps up and down one
parameter, with their jumps, as the product ``sweeps`` (written by ``hertzmap run``'s sweeps
stage for studies with the ``sweeps`` output: scheduler.stages.sweep_tasks).

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

With ``[sweep] rates``, the swept sines too (study.solve.swept_sine.swept_sine, one task per line,
direction and rate): the parameter moved at each rate over the line's range, up and down, from
the state the stepped sweep's first step settled on; each run read at SWEPT_SAMPLES values of
the swept parameter (dims line, rate, direction, sample: H1, H2, H1/2, ptp over two forcing
cycles) and, for every jump of the stepped sweep of its direction, where it leaves that jump's
branch and its delay against the stepped jump (dims jump, rate). They are stored in the same
group as the stepped sweeps: one stage writes the product whole (its resume rule), the swept
jumps are read against the stepped jumps (the same dim ``jump``) and the ``sweeps`` figure draws
both from one product. A study without rates has none of them (the product as before).

Pure: numpy and xarray; the sweeps themselves are computed by study.solve.sweep and
study.solve.swept_sine, run and recorded as the stage ships them by study.solve.sweep_runs (here
only in :func:`stepped_sweeps`, the same in one process).
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any, Mapping

import numpy as np
import xarray as xr

from hertzmap.kernels.records import PERIOD_FLAGS, STATUS_FLAGS
from hertzmap.study.products.classes import class_flag_attrs, valid_orbits
from hertzmap.study.products.results import open_store, rig_of, source_attrs, var_attrs
from hertzmap.study.schema import study_from_attrs
from hertzmap.study.spec import DEFAULT_SWEEP, Study
from hertzmap.study.solve.sweep import DIRECTIONS, force_components
from hertzmap.study.solve.sweep_runs import (JUMP_KIND_CODES, SWEEP_START, SWEPT_SAMPLES,
                                             run_sweep, run_swept, sample_values, sweep_specs,
                                             swept_specs)
from hertzmap.study.solve.swept_sine import SWEPT_WINDOW

__all__ = ["SWEEPS", "LINK_TOL", "force_components", "sweeps_dataset", "stepped_sweeps",
           "stored_branches", "sweep_line", "jumps_of"]

#: the product's name (its group products/sweeps)
SWEEPS = "sweeps"
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
_WINDOW = f"over the {SWEPT_WINDOW} forcing cycles ending at the sample's cycle"
_SWEPT = {
    "swept_value": ("swept parameter of the swept run", "1",
                    "its value during the sample's forcing cycle (the first of the run at or "
                    "past sample_value in the run's direction; NaN: not reached)"),
    "swept_tau": ("time of the swept run", "1",
                  "dimensionless time tau at the start of the sample's cycle, from the run's "
                  "start"),
    "swept_min_q": ("minimum of q of the swept run", "1", _WINDOW),
    "swept_max_q": ("maximum of q of the swept run", "1", _WINDOW),
    "swept_ptp": ("peak-to-peak q (amplitude) of the swept run", "1", _WINDOW),
    "swept_H1": ("contact-force harmonic H1 of the swept run", "1",
                 "amplitude of F/N at the excitation frequency " + _WINDOW + " (a tracking "
                 "filter's reading: the orbit's own H1 for a 1T or 2T response)"),
    "swept_H2": ("contact-force harmonic H2 of the swept run", "1",
                 "amplitude of F/N at twice the excitation frequency " + _WINDOW),
    "swept_H1_2": ("contact-force subharmonic H1/2 of the swept run", "1",
                   "amplitude of F/N at half the excitation frequency " + _WINDOW),
}
_SWEPT_RUN = {
    "swept_cycles": ("forcing cycles of the swept run", "1",
                     "from the line's first value to its last in the run's direction"),
    "swept_status": ("status of the swept run", "1",
                     "kernels.status of its last cycle: 0 every cycle integrated"),
    "swept_seconds": ("wall time of the swept run", "s", "on its worker"),
}
_SWEPT_JUMP = {
    "swept_jump_value": ("jump location of the swept run", "1",
                         "where the swept response leaves the branch the stepped sweep's jump "
                         "left (study.solve.swept_sine.swept_crossing: its subharmonic H1/2 for a "
                         "1T <-> 2T jump, else its ptp, crosses the middle of the two "
                         "responses'); NaN: it does not there (it stayed on another response, "
                         "or left it only past the next jump), the two responses differ by "
                         "less than 10 % (nothing jumps), or the jump is not between two "
                         "periodic responses"),
    "swept_jump_delay": ("delay of the swept jump", "1",
                         "swept_jump_value - jump_value in the sweep's direction (> 0: later "
                         "than the stepped jump); tends to 0 as the rate falls"),
}


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
                   study: Study | None = None,
                   swept: Mapping[tuple[int, str, int], Mapping[str, Any]] | None = None
                   ) -> xr.Dataset:
    """The ``sweeps`` product from the sweeps' records (:func:`sweep_record`, by (line,
    direction)) and the results ``ds`` (study.products.open_store: the store's orbits along
    each line, the source attrs; ``study``: the study, read from ds's attrs by default).
    A sweep without a record (its task failed) is left empty (NaN, 0, False). With [sweep]
    rates, the swept-sine runs' records too (``swept``: :func:`swept_record`, by (line,
    direction, rate index)): dims ``rate`` (coordinate ``rate``, per unit tau, fastest first)
    and ``sample`` (coordinate ``sample_value``), variables ``swept_*`` on (line, rate,
    direction, sample), (line, rate, direction) and (jump, rate); a run without a record is
    left empty. A study without rates has none of them (the product as before).

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
    first_jump: dict[tuple[int, str], tuple[int, int]] = {}   # (line, direction) -> first, count
    for i in range(nl):
        for d, direction in enumerate(DIRECTIONS):
            rec = records.get((i, direction))
            if rec is None:
                continue
            first_jump[(i, direction)] = (len(jumps["jump_line"]), len(rec["jump_value"]))
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
    rates = study.sweep_rates
    if rates:
        data.update(_swept_variables(swept or {}, rates, nl, jarr["jump_value"].size,
                                     first_jump))
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
    if rates:
        coords["rate"] = ("rate", np.asarray(rates, float), var_attrs(
            "rate of the swept-sine runs", "1",
            f"d {axis} / d tau: the change of {axis} per unit dimensionless time tau "
            "(study.solve.swept_sine.swept_sine), fastest first"))
        coords["sample"] = ("sample", np.arange(SWEPT_SAMPLES, dtype=np.int32), var_attrs(
            "sample", "1", f"index of the swept runs' reading along {axis}, increasing"))
        coords["sample_value"] = ("sample", sample_values(study), var_attrs(
            f"{axis} of the sample", "1",
            f"the middles of {SWEPT_SAMPLES} equal bins of the line's {axis} range, increasing: "
            "where both directions' swept runs are read (the down run ran them from the last "
            "to the first)"))
    for a in fixed_axes:
        coords[f"line_{a}"] = ("line", np.array([f[a] for f in lines], float), var_attrs(
            {"omega": "excitation frequency omega", "sigma": "excitation amplitude sigma",
             "zeta": "damping ratio zeta"}[a], "1", f"the line's {a} (held fixed)"))
    out = xr.Dataset(data, coords=coords)
    out.attrs = {**source_attrs(ds, "stepped-sine sweeps up and down each line, with their "
                                    "jumps (what a lab measures)"),
                 "hertzmap_product_source": "hertzmap run: the sweeps stage "
                                            "(scheduler.stages.sweep_tasks)",
                 "sweep_axis": axis, "sweep_jump_tol": float(settings.get("jump_tol", np.nan)),
                 "sweep_settle_periods": int(settings.get("settle_periods", 0)),
                 "sweep_record_periods": int(settings.get("record_periods", 0)),
                 "sweep_start": list(SWEEP_START),
                 "method": "study.solve.sweep.stepped_sweep: each step starts where the last "
                           "ended and settles on an attractor (stroboscopic map, Newton "
                           "shooting); jumps bracketed by bisection from the followed branch "
                           "(the quasi-static limit) and named from its Floquet multipliers"}
    if rates:
        out.attrs.update({
            "sweep_rates": [float(r) for r in rates], "swept_samples": SWEPT_SAMPLES,
            "swept_window": SWEPT_WINDOW,
            "swept_method": "study.solve.swept_sine.swept_sine: the swept parameter moved at each "
                            "rate while the forcing runs, its phase continuous (updated at the "
                            "end of every forcing cycle), over the line's range from the state "
                            "the stepped sweep's first step settled on; its jumps read against "
                            "the stepped sweep's (study.solve.swept_sine.swept_crossing)"})
    return _with_rig(out, axis, rig_of(ds))


def _swept_variables(swept: Mapping[tuple[int, str, int], Mapping[str, Any]],
                     rates: tuple[float, ...], nl: int, n_jumps: int,
                     first_jump: Mapping[tuple[int, str], tuple[int, int]]
                     ) -> dict[str, tuple]:
    """The ``swept_*`` variables of the product from the swept runs' records."""
    nr, nd = len(rates), len(DIRECTIONS)
    shape = (nl, nr, nd, SWEPT_SAMPLES)
    per_sample = {name: np.full(shape, np.nan) for name in _SWEPT}
    per_run = {"swept_cycles": np.zeros(shape[:3], np.int64),
               "swept_status": np.full(shape[:3], -1, np.int8),
               "swept_seconds": np.full(shape[:3], np.nan)}
    per_jump = {name: np.full((n_jumps, nr), np.nan) for name in _SWEPT_JUMP}
    for (i, direction, k), rec in swept.items():
        if not (0 <= i < nl and 0 <= k < nr and direction in DIRECTIONS):
            continue
        d = DIRECTIONS.index(direction)
        for name in _SWEPT:
            src = np.asarray(rec[name.removeprefix("swept_")], float)
            if src.shape == (SWEPT_SAMPLES,):
                per_sample[name][i, k, d] = src
        per_run["swept_cycles"][i, k, d] = int(rec["cycles"])
        per_run["swept_status"][i, k, d] = int(rec["status"])
        per_run["swept_seconds"][i, k, d] = float(rec["seconds"])
        # its readings of the jumps of its stepped sweep (the one it was specified from)
        j0, count = first_jump.get((i, direction), (0, -1))
        jv = np.asarray(rec["jump_value"], float)
        if jv.size == count:
            per_jump["swept_jump_value"][j0:j0 + count, k] = jv
            per_jump["swept_jump_delay"][j0:j0 + count, k] = np.asarray(rec["jump_delay"],
                                                                        float)
    status = dict(flag_values=np.array([v for v, _ in STATUS_FLAGS], np.int8),
                  flag_meanings=" ".join(m for _, m in STATUS_FLAGS))
    data = {name: (("line", "rate", "direction", "sample"), arr, _attrs(_SWEPT, name))
            for name, arr in per_sample.items()}
    data.update({name: (("line", "rate", "direction"), arr,
                        _attrs(_SWEPT_RUN, name, **(status if name == "swept_status" else {})))
                 for name, arr in per_run.items()})
    data.update({name: (("jump", "rate"), arr, _attrs(_SWEPT_JUMP, name))
                 for name, arr in per_jump.items()})
    return data


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
    if "rate" in out.coords:
        out = _swept_with_rig(out, axis, rig)
    out.attrs.update({"rig_f0_hz": rig.f0, "rig_N": rig.N, "rig_m": rig.m, "rig_k": rig.k,
                      "rig_z_s": rig.z_s})
    return out


def _swept_with_rig(out: xr.Dataset, axis: str, rig) -> xr.Dataset:
    """The rig's units of the swept runs: the rates (Hz/s, or N/s for axis sigma: tau =
    Omega t), the samples' and the jumps' values and delays, forces in N, amplitudes in m,
    times in s."""
    for name in ("H1", "H2", "H1_2"):
        out[f"swept_{name}_N"] = (out[f"swept_{name}"] * rig.N).assign_attrs(var_attrs(
            out[f"swept_{name}"].attrs["long_name"], "N", f"N times swept_{name}"))
    out["swept_ptp_m"] = (out["swept_ptp"] * rig.z_s / rig.n).assign_attrs(var_attrs(
        "peak-to-peak displacement of the swept run", "m", "swept_ptp z_s / n (paper Eq. 5)"))
    out["swept_time_s"] = (out["swept_tau"] / rig.Omega).assign_attrs(var_attrs(
        "time of the swept run", "s", "swept_tau / Omega (Omega = 2 pi f0)"))
    rate = out["rate"].values
    if axis == "omega":
        hz = {"sample": ("sample_frequency_hz", out["sample_value"]),
              "value": ("swept_frequency_hz", out["swept_value"]),
              "jump": ("swept_jump_frequency_hz", out["swept_jump_value"]),
              "delay": ("swept_jump_delay_hz", out["swept_jump_delay"])}
        out = out.assign_coords(rate_hz_per_s=("rate", rate * 2.0 * np.pi * rig.f0 ** 2,
                                               var_attrs(
            "rate of the swept-sine runs", "Hz/s", f"rate 2 pi f0^2 (f0 = {rig.f0:.6g} Hz, the "
            "study's [rig]): the excitation frequency's change per second")))
        unit, scale, what = "Hz", rig.f0, "f0"
    else:
        hz = {"sample": ("sample_force_amplitude_N", out["sample_value"]),
              "value": ("swept_force_amplitude_N", out["swept_value"]),
              "jump": ("swept_jump_force_amplitude_N", out["swept_jump_value"]),
              "delay": ("swept_jump_delay_N", out["swept_jump_delay"])}
        out = out.assign_coords(rate_N_per_s=("rate", rate * rig.N * rig.Omega, var_attrs(
            "rate of the swept-sine runs", "N/s", f"rate N Omega (N = {rig.N:g} N, Omega = 2 pi "
            "f0, the study's [rig]): the force amplitude's change per second")))
        unit, scale, what = "N", rig.N, "N"
    name, src = hz["sample"]
    out = out.assign_coords({name: ("sample", src.values * scale, var_attrs(
        src.attrs["long_name"], unit, f"sample_value {what}"))})
    for key in ("value", "jump", "delay"):
        name, src = hz[key]
        out[name] = (src * scale).assign_attrs(var_attrs(
            src.attrs["long_name"], unit, f"{src.name} {what}"))
    return out


def stepped_sweeps(ds: xr.Dataset) -> xr.Dataset:
    """The ``sweeps`` product computed in this process (every sweep one after the other): what
    the run's sweeps stage (scheduler.stages.sweep_tasks, the ``sweeps`` output) computes on its
    workers and stores as products/sweeps, the swept-sine runs of its [sweep] rates included.
    ``ds``: the results of a study with the ``sweeps`` output (or any study: its [sweep]
    defaults then)."""
    if "computed" not in ds:
        ds = open_store(ds)
    study = study_from_attrs(ds.attrs)
    if study.sweep is None:
        study = replace(study, sweep=tuple(sorted(DEFAULT_SWEEP.items())))
    records = {(s["line"], s["direction"]): run_sweep(s) for s in sweep_specs(study)}
    swept = {(s["line"], s["direction"], s["rate_index"]): run_swept(s)
             for s in swept_specs(study, records)}
    return sweeps_dataset(ds, records, study, swept)


def sweep_line(sweeps: xr.Dataset, line: int) -> xr.Dataset:
    """One line of the product: its steps (dims direction, step), its jumps (dim jump) and the
    store's orbits along it (dim branch_point), with the line's fixed parameters in the
    attrs."""
    one = sweeps.isel(line=line)
    one = one.isel(jump=np.flatnonzero(sweeps["jump_line"].values == line),
                   branch_point=np.flatnonzero(sweeps["branch_line"].values == line))
    one.attrs = dict(one.attrs)          # its own (isel shares the product's attrs dict)
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
