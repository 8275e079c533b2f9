"""A fit's result as one xarray Dataset (docs/identify.md, "The result"): the parameters with
their 95 % intervals and whether the data identify them, the noise model, every measured
point beside the model (its residuals and the period of the response the model's sweep is on
there), the measured and the model's jumps side by side, the model's sweeps at the estimate
(in Hz and N), the profiles and the global stage's grid. Every variable carries long_name,
units and a description (declared once in FIT_VARIABLES); integers and flags as int8/int32 so
that it writes to netCDF 3 (scipy's writer) as it is.

Pure: numpy and xarray.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from hertzmap.study.identify.estimation import FitResult
from hertzmap.study.identify.measurement import CHANNELS, DIRECTIONS, Measurement
from hertzmap.study.identify.problem import PARAMETERS
from hertzmap.study.identify.profile_likelihood import THRESHOLD
from hertzmap.study.identify.rig_table import RigTable, table_attrs
from hertzmap.study.solve.sweep_runs import JUMP_KIND_CODES

__all__ = ["FIT_VARIABLES", "JUMP_SIGMAS", "JUMP_RELATIVE", "fit_dataset", "measured_jumps",
           "summary_lines"]

#: a measured jump: consecutive steps of a sweep where a harmonic changes by more than
#: JUMP_RELATIVE of the larger reading and JUMP_SIGMAS standard deviations of the fitted noise
JUMP_SIGMAS, JUMP_RELATIVE = 5.0, 0.3
_KINDS = {code: kind for kind, code in JUMP_KIND_CODES.items()}

#: the Dataset's variables, declared once: name -> (dims, long_name, units, description)
FIT_VARIABLES: dict[str, tuple[tuple[str, ...], str, str, str]] = {
    "estimate": (("parameter",), "estimate", "see parameter_units",
                 "the maximum-likelihood value (NaN where not identified: see identified)"),
    "best": (("parameter",), "value at the maximum likelihood", "see parameter_units",
             "where the fit's optimum is, identified or not"),
    "lower": (("parameter",), "95 % interval, lower end", "see parameter_units",
              "profile likelihood: where the profile falls 1.92 below its maximum; the "
              "parameter's lower bound when it does not (lower_closed 0)"),
    "upper": (("parameter",), "95 % interval, upper end", "see parameter_units",
              "as lower, above the estimate"),
    "lower_closed": (("parameter",), "the profile leaves the 95 % threshold below", "1",
                     "1: the interval's lower end is the profile's; 0: it runs to the bound"),
    "upper_closed": (("parameter",), "the profile leaves the 95 % threshold above", "1",
                     "as lower_closed, above the estimate"),
    "identified": (("parameter",), "the data identify the parameter", "1",
                   "1: the profile falls below the 95 % threshold on both sides within the "
                   "bounds; 0: it stays above it up to both bounds (the data do not determine "
                   "it: the interval is the bounds)"),
    "standard_error": (("parameter",), "Gauss-Newton standard error", "see parameter_units",
                       "from the Jacobian at the optimum (for comparison with the profile's "
                       "interval; the interval is the profile's)"),
    "bound_low": (("parameter",), "search bound, low", "see parameter_units",
                  "from the rig table"),
    "bound_high": (("parameter",), "search bound, high", "see parameter_units",
                   "from the rig table"),
    "nominal": (("parameter",), "nominal value of the rig table", "see parameter_units",
                "NaN: the table gives none"),
    "noise_multiplicative": ((), "noise model: multiplicative part a", "1",
                             "sd = sqrt((a m)^2 + b^2), estimated with the parameters"),
    "noise_floor": ((), "noise model: additive floor b", "N", "as noise_multiplicative"),
    "loglik": ((), "maximum log-likelihood", "1", "over the readings, noise model included"),
    "frequency_hz": (("point",), "excitation frequency", "Hz", "as measured"),
    "direction": (("point",), "sweep direction", "1", "0 up, 1 down"),
    "row": (("point",), "row of the measurement", "1", "1-based data row of the input"),
    "measured": (("point", "harmonic"), "measured harmonic amplitude", "N",
                 "peak value of the transmitted force's harmonic (NaN: not measured)"),
    "measured_phase": (("point", "harmonic"), "measured phase", "degree",
                       "as given (not fitted; NaN: not given)"),
    "model": (("point", "harmonic"), "model harmonic amplitude", "N",
              "N times the model's F/N harmonic at omega = f / f0 on the branch its sweep "
              "in the point's direction is on there, at the estimate"),
    "residual": (("point", "harmonic"), "residual, measured - model", "N", ""),
    "standardized_residual": (("point", "harmonic"), "standardised residual", "1",
                              "residual / sd, sd = sqrt((a model)^2 + b^2)"),
    "model_period": (("point",), "period of the model's response at the point", "1",
                     "in forcing periods (1: 1T, 2: 2T the subharmonic; 0: not periodic)"),
    "sweep_frequency_hz": (("direction_name", "node"), "model sweep frequency", "Hz",
                           "the model's quasi-static sweep at the estimate: its steps (and "
                           "the branch ends at each jump), f0 omega"),
    "sweep_harmonic": (("direction_name", "node", "harmonic"), "model sweep harmonic", "N",
                       "N times the F/N harmonic of the sweep's response"),
    "sweep_period": (("direction_name", "node"), "model sweep period", "1",
                     "of the response (0: not periodic; -1: padding)"),
    "sweep_segment": (("direction_name", "node"), "model sweep branch run", "1",
                      "the run of one branch each node is on (-1: padding)"),
    "jump_direction": (("jump",), "direction of the jump's sweep", "1", "0 up, 1 down"),
    "model_jump_hz": (("jump",), "model jump frequency", "Hz",
                      "where the model's sweep leaves its branch at the estimate (NaN: a "
                      "measured jump the model does not have)"),
    "model_jump_accuracy_hz": (("jump",), "model jump accuracy", "Hz",
                               "width of its bracket (a step for an unlocated jump)"),
    "model_jump_kind": (("jump",), "model jump kind", "1",
                        "1 fold, 2 flip, 3 loss, 4 unlocated (study.solve.sweep); 0: none"),
    "model_jump_from_period": (("jump",), "model jump: period left", "1", "0: none"),
    "model_jump_to_period": (("jump",), "model jump: period landed on", "1", "0: none"),
    "measured_jump_before_hz": (("jump",), "measured jump: last step before", "Hz",
                                f"the measured step before a change of a harmonic by more "
                                f"than {JUMP_RELATIVE:.0%} and {JUMP_SIGMAS:g} noise sd "
                                "(NaN: the measurement shows none there)"),
    "measured_jump_after_hz": (("jump",), "measured jump: first step after", "Hz",
                               "as measured_jump_before_hz"),
    "measured_jump_harmonic": (("jump",), "measured jump: harmonic", "1",
                               "index on harmonic of the largest change (-1: none)"),
    "profile_value": (("parameter", "profile_point"), "profile: value held", "see "
                      "parameter_units", "NaN: padding"),
    "profile_loglik": (("parameter", "profile_point"), "profile log-likelihood", "1",
                       "the log-likelihood maximised over the other parameters"),
    "profile_deviance": (("parameter", "profile_point"), "profile deviance", "1",
                         "2 (loglik - profile_loglik): the 95 % interval is where it is "
                         f"below {2 * THRESHOLD:.3f}"),
    "profile_at": (("parameter", "profile_point", "parameter_at"),
                   "profile: every parameter at the point", "see parameter_units",
                   "where the other parameters went"),
    "cell_sigma": (("cell",), "global stage: sigma", "1", ""),
    "cell_zeta": (("cell",), "global stage: zeta", "1", ""),
    "cell_exponent": (("cell",), "global stage: contact exponent", "1", ""),
    "cell_f0": (("cell",), "global stage: best f0", "Hz", "at the cell"),
    "cell_loglik": (("cell",), "global stage: log-likelihood", "1",
                    "maximised over f0 and the noise model, model sweeps at twice the step"),
}


def measured_jumps(meas: Measurement, a: float, b: float) -> list[dict[str, Any]]:
    """The jumps a measurement shows by itself (JUMP_SIGMAS, JUMP_RELATIVE), per sweep in the
    order measured: dicts of direction, before, after (Hz), harmonic, the row indices (a
    steep stretch of a branch, as the subharmonic's onset past a flip, can show too: the
    table beside the model's jumps says which the model has)."""
    out = []
    for d in range(len(DIRECTIONS)):
        idx = np.flatnonzero(meas.direction == d)
        for i, k in zip(idx[:-1], idx[1:]):
            y0, y1 = meas.amplitude[i], meas.amplitude[k]
            with np.errstate(invalid="ignore"):
                change = np.abs(y1 - y0)
                sd = np.sqrt((a * y0) ** 2 + (a * y1) ** 2 + 2 * b * b)
                big = ((change > JUMP_SIGMAS * sd) &
                       (change > JUMP_RELATIVE * np.fmax(y0, y1)))
            big &= np.isfinite(change)
            if np.any(big):
                c = int(np.nanargmax(np.where(big, change / sd, -np.inf)))
                out.append({"direction": d, "before": float(meas.frequency[i]),
                            "after": float(meas.frequency[k]), "harmonic": c,
                            "rows": (int(i), int(k))})
    return out


def _side_by_side(result: FitResult, meas: Measurement, f0: float) -> list[dict[str, Any]]:
    """The model's jumps at the estimate, each beside the measured jump of its direction that
    brackets it within a step, then the measured jumps no model jump matches."""
    measured = measured_jumps(meas, result.a, result.b)
    used = set()
    rows = []
    lo, hi = meas.frequency.min(), meas.frequency.max()
    for d, name in enumerate(DIRECTIONS):
        sweep = result.model.sweeps.get(name)
        if sweep is None or name not in meas.directions:
            continue
        for value, acc, kind, p_from, p_to, _ in sweep.jumps:
            f = value * f0
            if not lo <= f <= hi:
                continue            # outside the measured range
            # the measured jump of this direction whose bracket meets the model jump's own
            # (its location -+ half its accuracy: a step for an unlocated jump)
            match, nearest = None, math.inf
            half = 0.5 * acc * f0
            for k, mj in enumerate(measured):
                if k in used or mj["direction"] != d:
                    continue
                lo_b, hi_b = sorted((mj["before"], mj["after"]))
                away = max(lo_b - f, f - hi_b, 0.0)
                if away <= half and away < nearest:
                    match, nearest = k, away
            row = {"direction": d, "model": f, "accuracy": acc * f0, "kind": int(kind),
                   "from": int(p_from), "to": int(p_to), "before": math.nan,
                   "after": math.nan, "harmonic": -1}
            if match is not None:
                used.add(match)
                mj = measured[match]
                row.update(before=mj["before"], after=mj["after"], harmonic=mj["harmonic"])
            rows.append(row)
    for k, mj in enumerate(measured):
        if k not in used:
            rows.append({"direction": mj["direction"], "model": math.nan,
                         "accuracy": math.nan, "kind": 0, "from": 0, "to": 0,
                         "before": mj["before"], "after": mj["after"],
                         "harmonic": mj["harmonic"]})
    return rows


def _pad(arrays: list[np.ndarray], fill) -> np.ndarray:
    n = max([a.shape[0] for a in arrays] + [1])
    out = np.full((len(arrays), n) + arrays[0].shape[1:], fill,
                  dtype=np.result_type(arrays[0].dtype, type(fill)))
    for i, a in enumerate(arrays):
        out[i, :a.shape[0]] = a
    return out


def fit_dataset(result: FitResult, meas: Measurement, rig: RigTable,
                extra_attrs: dict[str, Any] | None = None) -> xr.Dataset:
    """The Dataset of a fit (module docstring)."""
    from hertzmap.study.identify.likelihood import model_amplitudes

    problem = result.problem
    names = list(result.names)
    f0 = result.estimate["f0"]
    units = [PARAMETERS[n][1] for n in names]
    # parameters
    best = np.array([result.estimate[n] for n in names])
    iv = [result.intervals[n] for n in names]
    identified = np.array([lo_c and hi_c for _, _, lo_c, hi_c in iv], np.int8)
    se_u = result.se
    log = np.array([n in ("f0", "zeta") for n in names])
    se = np.where(log, best * se_u, se_u)
    data: dict[str, tuple] = {
        "estimate": np.where(identified.astype(bool), best, np.nan),
        "best": best,
        "lower": np.array([x[0] for x in iv]), "upper": np.array([x[1] for x in iv]),
        "lower_closed": np.array([x[2] for x in iv], np.int8),
        "upper_closed": np.array([x[3] for x in iv], np.int8),
        "identified": identified, "standard_error": se,
        "bound_low": np.array([problem.bounds[n][0] for n in names]),
        "bound_high": np.array([problem.bounds[n][1] for n in names]),
        "nominal": np.array([problem.nominal.get(n, math.nan) for n in names]),
        "noise_multiplicative": np.float64(result.a), "noise_floor": np.float64(result.b),
        "loglik": np.float64(result.loglik),
    }
    # the points
    m, period, _, _ = model_amplitudes(problem, result.model, f0)
    y = meas.amplitude
    sd = np.sqrt((result.a * m) ** 2 + result.b ** 2)
    data.update({
        "frequency_hz": meas.frequency, "direction": meas.direction.astype(np.int8),
        "row": meas.row.astype(np.int32), "measured": y, "measured_phase": meas.phase,
        "model": m, "residual": y - m, "standardized_residual": (y - m) / sd,
        "model_period": period.astype(np.int8),
    })
    # the model's sweeps at the estimate
    sweeps = [result.model.sweeps[d] for d in DIRECTIONS if d in result.model.sweeps]
    data.update({
        "sweep_frequency_hz": _pad([s.omega * f0 for s in sweeps], np.nan),
        "sweep_harmonic": _pad([s.harmonics * problem.N for s in sweeps], np.nan),
        "sweep_period": _pad([s.period.astype(np.int32) for s in sweeps], -1),
        "sweep_segment": _pad([s.segment.astype(np.int32) for s in sweeps], -1),
    })
    # jumps side by side
    rows = _side_by_side(result, meas, f0)
    data.update({
        "jump_direction": np.array([r["direction"] for r in rows], np.int8),
        "model_jump_hz": np.array([r["model"] for r in rows], float),
        "model_jump_accuracy_hz": np.array([r["accuracy"] for r in rows], float),
        "model_jump_kind": np.array([r["kind"] for r in rows], np.int8),
        "model_jump_from_period": np.array([r["from"] for r in rows], np.int8),
        "model_jump_to_period": np.array([r["to"] for r in rows], np.int8),
        "measured_jump_before_hz": np.array([r["before"] for r in rows], float),
        "measured_jump_after_hz": np.array([r["after"] for r in rows], float),
        "measured_jump_harmonic": np.array([r["harmonic"] for r in rows], np.int8),
    })
    # profiles
    profs = [result.profiles[n] for n in names]
    data.update({
        "profile_value": _pad([p[0] for p in profs], np.nan),
        "profile_loglik": _pad([p[1] for p in profs], np.nan),
        "profile_at": _pad([p[2] for p in profs], np.nan),
    })
    data["profile_deviance"] = 2.0 * (result.loglik - data["profile_loglik"])
    thetas, cell_f0, cell_ll = result.cells
    data.update({"cell_sigma": thetas[:, 0], "cell_zeta": thetas[:, 1],
                 "cell_exponent": thetas[:, 2], "cell_f0": cell_f0, "cell_loglik": cell_ll})
    ds = xr.Dataset()
    for name, value in data.items():
        dims, long_name, unit, description = FIT_VARIABLES[name]
        ds[name] = xr.Variable(dims, np.asarray(value),
                               {"long_name": long_name, "units": unit,
                                "description": description})
    ds = ds.assign_coords(
        parameter=("parameter", names, {"long_name": "parameter", "units": "1"}),
        parameter_at=("parameter_at", names, {"long_name": "parameter", "units": "1"}),
        parameter_units=("parameter", units, {"long_name": "units of the parameter",
                                              "units": "1"}),
        harmonic=("harmonic", list(CHANNELS),
                  {"long_name": "harmonic of the transmitted force", "units": "1",
                   "description": "H1 at the excitation frequency, H2 at twice it, H1_2 at "
                                  "half of it"}),
        direction_name=("direction_name", [d for d in DIRECTIONS if d in result.model.sweeps],
                        {"long_name": "sweep direction", "units": "1"}))
    stages = {f"stage_{k}_seconds": float(v[0]) for k, v in result.stages.items()}
    stages.update({f"stage_{k}_task_seconds": float(v[1]) for k, v in result.stages.items()})
    stages.update({f"stage_{k}_task_cpu_seconds": float(v[2])
                   for k, v in result.stages.items()})
    stages.update({f"stage_{k}_tasks": int(v[3]) for k, v in result.stages.items()})
    ds.attrs = {
        "title": "hertzmap fit: f0, zeta, sigma identified from measured stepped-sine sweeps",
        "hertzmap_product_source": "hertzmap fit",
        "measurement_source": meas.source,
        "readings": int(np.isfinite(y).sum()),
        "threshold": THRESHOLD,
        "forward_model": "study.identify.forward_model: stepped_sweep follow_first",
        "forward_step_omega": float(np.median(np.diff(problem.omega))),
        "forward_models": int(result.forward_models),
        "restarts": int(result.restarts),
        "model": "hertz",
        "exponent_fixed": float(problem.exponent) if "exponent" not in names else math.nan,
        **table_attrs(rig), **stages, **(extra_attrs or {}),
    }
    return ds


def summary_lines(ds: xr.Dataset) -> list[str]:
    """The fit's result in a few lines (the command line prints them)."""
    out = []
    for i, name in enumerate(ds["parameter"].values):
        unit = str(ds["parameter_units"].values[i])
        unit = "" if unit == "1" else f" {unit}"
        lo, hi = float(ds["lower"][i]), float(ds["upper"][i])
        lo_c, hi_c = bool(ds["lower_closed"][i]), bool(ds["upper_closed"][i])
        if not bool(ds["identified"][i]) and not lo_c and not hi_c:
            out.append(f"  {name:9s} not identified: the profile stays within 1.92 of its "
                       f"maximum over the whole bounds [{lo:.6g}, {hi:.6g}]{unit}")
            continue
        if not (lo_c and hi_c):
            side, edge, end = (("<=", "lower", lo) if hi_c else (">=", "upper", hi))
            out.append(f"  {name:9s} {side} {hi if hi_c else lo:.6g}{unit} (95 %; bounded "
                       f"{'above' if hi_c else 'below'} only: the profile stays within 1.92 "
                       f"of its maximum up to the {edge} bound {end:.6g}{unit}, open there)")
            continue
        best = float(ds["best"][i])
        out.append(f"  {name:9s} {best:.6g}{unit}  95 % interval [{lo:.6g}, {hi:.6g}]{unit}")
    out.append(f"  noise     a = {float(ds['noise_multiplicative']):.3g} (multiplicative), "
               f"b = {float(ds['noise_floor']):.3g} N (floor); {ds.attrs['readings']} readings")
    return out
