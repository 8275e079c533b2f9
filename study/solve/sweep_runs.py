"""The runs of a study's ``sweeps`` output (issue 45), as its stage ships them: one stepped
sweep per line and direction (:func:`sweep_specs`, :func:`run_sweep`: study.solve.sweep.
stepped_sweep on a worker, its :func:`sweep_record` of numbers back), and with ``[sweep]
rates`` one swept sine per line, direction and rate (:func:`swept_specs`, :func:`run_swept`:
study.solve.swept_sine.swept_sine, its :func:`swept_record`). The product built from the
records is study.products.stepped_sweeps (scheduler.stages.sweep_tasks ships and stages them; the
product's :func:`stepped_sweeps` runs the same in one process).

Pure: numpy over study.solve.sweep and study.solve.swept_sine; no I/O, no Dask, no xarray.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from hertzmap.kernels.model import Model
from hertzmap.kernels.records import N_HARMONICS
from hertzmap.study.spec import Study
from hertzmap.study.solve.sweep import DIRECTIONS, JUMP_KINDS, force_components, stepped_sweep
from hertzmap.study.solve.swept_sine import (SWEPT_WINDOW, jump_measure, swept_crossing,
                                             swept_sine)

__all__ = ["JUMP_KIND_CODES", "SWEEP_START", "STEP_FIELDS", "SWEPT_SAMPLES", "sweep_specs",
           "sweep_options", "run_sweep", "sweep_record", "sample_values", "swept_specs",
           "run_swept", "swept_record"]

#: the jump kinds as stored (``jump_kind``): study.solve.sweep.JUMP_KINDS, 1-based
JUMP_KIND_CODES = {kind: i + 1 for i, kind in enumerate(JUMP_KINDS)}
#: where each sweep starts: (q, q') at tau = 0 of its first step, the contact at rest under
#: its static load
SWEEP_START = (0.0, 0.0)
#: the per-step fields of a stepped sweep's record (Sweep.arrays), in its order
STEP_FIELDS = ("value", "period", "status", "settled", "stable", "min_q", "max_q", "ptp",
                "loses_contact", "rms_force", "class_code", "branch", "periods_run")
#: the swept-sine runs ([sweep] rates): each run read at SWEPT_SAMPLES values of the swept
#: parameter (dim sample: the middles of SWEPT_SAMPLES equal bins of the line's range), each
#: sample the first forcing cycle of the run to reach that value, over the window of
#: study.solve.swept_sine.SWEPT_WINDOW cycles ending there
SWEPT_SAMPLES = 1000


def sweep_specs(study: Study) -> list[dict[str, Any]]:
    """The sweeps of a study with the ``sweeps`` output, one dict each (line, its fixed
    parameters, direction, and the keyword arguments of study.solve.sweep.stepped_sweep):
    every line of :meth:`Study.sweep_lines`, up then down."""
    settings = study.sweep_dict
    if settings is None:
        return []
    axis = settings["axis"]
    values = np.sort(study.axis(axis))
    options = sweep_options(study.model_value, settings)
    return [{"line": i, "direction": d,
             "sweep": {"axis": axis, "values": values, "fixed": fixed, "direction": d,
                       **options}}
            for i, fixed in enumerate(study.sweep_lines()) for d in DIRECTIONS]


def sweep_options(model: Model, settings: Mapping[str, Any]) -> dict[str, Any]:
    """The keyword arguments of study.solve.sweep.stepped_sweep that a sweep of the ``sweeps``
    output takes besides its line: the contact law, exponent and rtol of ``model``, the
    [sweep] table's jump_tol, settle_periods and record_periods (``settings``), and the start
    from rest (SWEEP_START). The explore page's sweeps take the same (study.explore_data)."""
    return {"exponent": model.exponent, "model": model.law, "rtol": model.rtol,
            "jump_tol": settings["jump_tol"], "settle_periods": settings["settle_periods"],
            "record_periods": settings["record_periods"], "x0": SWEEP_START}


def run_sweep(spec: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """One sweep of :func:`sweep_specs` computed: its :func:`sweep_record`."""
    return sweep_record(stepped_sweep(**spec["sweep"]))


def sweep_record(sweep) -> dict[str, np.ndarray]:
    """The arrays of one stepped sweep (a study.solve.sweep.Sweep), in sweep order, as its
    task returns them (numbers only: staged by the run as one .npz file): per step the
    fields of ``Sweep.arrays`` with ``force_harmonics`` (steps, 4), ``multipliers`` (steps, 2);
    per jump ``jump_*`` (``jump_from_ptp``, ``jump_from_H1``, ``jump_from_H1_2``: the followed
    orbit's at the bracket's attracting end, what a swept run's jump is read against); and
    ``seconds``, ``probes``."""
    a = sweep.arrays()
    out = {name: np.asarray(a[name]) for name in STEP_FIELDS}
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
    # the followed orbit at the bracket: what a swept run's jump is read against
    fo = [j.from_orbit for j in js]
    out["jump_from_ptp"] = np.array([o.ptp if o is not None else np.nan for o in fo], float)
    h1, _, h12 = force_components(
        np.array([o.force_harmonics if o is not None else np.full(N_HARMONICS, np.nan)
                  for o in fo], float).reshape(-1, N_HARMONICS),
        np.array([o.period if o is not None else 0 for o in fo], int))
    out["jump_from_H1"], out["jump_from_H1_2"] = np.asarray(h1, float), np.asarray(h12, float)
    out["seconds"] = np.float64(sweep.seconds)
    out["probes"] = np.int64(sweep.probes)
    return out


def sample_values(study: Study) -> np.ndarray:
    """The values of the swept parameter the swept runs are read at (dim sample): the middles
    of SWEPT_SAMPLES equal bins of the line's range (the grid's values of the [sweep] axis),
    increasing."""
    values = study.axis(study.sweep_dict["axis"])
    lo, hi = float(values.min()), float(values.max())
    return lo + (hi - lo) * (np.arange(SWEPT_SAMPLES) + 0.5) / SWEPT_SAMPLES


def swept_specs(study: Study, records: Mapping[tuple[int, str], Mapping[str, Any]]
                ) -> list[dict[str, Any]]:
    """The swept-sine runs of a study with [sweep] rates, one dict each (line, direction, rate
    index, the keyword arguments of study.solve.swept_sine.swept_sine, and the stepped sweep's
    jumps to read on it): for each stepped sweep of ``records`` (by (line, direction): each
    run needs its own direction's stepped sweep) and each rate, fastest first. A run goes over
    the line's whole range in the sweep's direction from the state the stepped sweep's first
    step settled on (the rig dwelt there first; rest when that step has no orbit), and is read
    at :func:`sample_values`. Each jump of the stepped sweep is looked for on it between the
    step before it and the step before the next jump (study.solve.swept_sine.swept_crossing)."""
    settings = study.sweep_dict
    rates = study.sweep_rates
    if settings is None or not rates:
        return []
    axis = settings["axis"]
    values = np.sort(study.axis(axis))
    model = study.model_value
    samples = sample_values(study)
    out = []
    for i, fixed in enumerate(study.sweep_lines()):
        for d in DIRECTIONS:
            rec = records.get((i, d))
            if rec is None:
                continue
            q0, v0 = float(rec["q0"][0]), float(rec["v0"][0])
            x0 = (q0, v0) if np.isfinite(q0) and np.isfinite(v0) else tuple(SWEEP_START)
            ends = (values[0], values[-1]) if d == "up" else (values[-1], values[0])
            jumps = _swept_jump_specs(rec)
            for k, rate in enumerate(rates):
                out.append({"line": i, "direction": d, "rate_index": k,
                            "swept": {"axis": axis, "start": float(ends[0]),
                                      "stop": float(ends[1]), "rate": float(rate),
                                      "fixed": dict(fixed), "x0": x0,
                                      "exponent": model.exponent, "model": model.law},
                            "jumps": jumps, "samples": samples})
    return out


def _swept_jump_specs(rec: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """What swept_crossing needs of each jump of a stepped sweep's record (sweep order): its
    value, the measure it is read on (``subharmonic``: True for H1/2, a 1T <-> 2T jump, False
    for the ptp: study.solve.swept_sine.jump_measure), the two responses' levels of it (the followed
    orbit's at
    the bracket, the landed step's), the contrast's scale, the ptp's period, and the window of
    the run it is looked for in (start: the step before it; stop: the step before the next
    jump, NaN for the last); ``read`` False for a jump not between two periodic responses (NaN
    on the swept run)."""
    value = np.asarray(rec["value"], float)
    at = np.asarray(rec["jump_step"], int)
    prev = np.maximum(at - 1, 0)
    from_period = np.asarray(rec["jump_from_period"], int)
    to_period = np.asarray(rec["jump_to_period"], int)
    h1, _, h12 = force_components(rec["force_harmonics"], rec["period"])
    ptp = np.asarray(rec["ptp"], float)
    before = value[prev]
    # the followed orbit at the bracket (a record staged before these were kept: the step's)
    from_ptp = np.asarray(rec.get("jump_from_ptp", ptp[prev]), float)
    from_h1 = np.asarray(rec.get("jump_from_H1", h1[prev]), float)
    from_h12 = np.asarray(rec.get("jump_from_H1_2", h12[prev]), float)
    subharmonic = np.array([jump_measure(a, b) == "H1_2"
                            for a, b in zip(from_period, to_period)], bool)
    with np.errstate(invalid="ignore"):
        scale = np.where(subharmonic, np.fmax(from_h1, h1[at]),
                         np.fmax(np.abs(from_ptp), np.abs(ptp[at])))
    return {"value": np.asarray(rec["jump_value"], float), "subharmonic": subharmonic,
            "from": np.where(subharmonic, from_h12, from_ptp),
            "to": np.where(subharmonic, h12[at], ptp[at]), "scale": scale,
            "period": np.maximum(np.maximum(from_period, to_period), 1),
            "start": before, "stop": np.append(before[1:], np.nan),
            "read": (np.asarray(rec["jump_located"], bool) & (from_period > 0) & (to_period > 0)
                     & (at > 0))}


def run_swept(spec: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """One swept-sine run of :func:`swept_specs` computed: its :func:`swept_record`."""
    return swept_record(swept_sine(**spec["swept"]), spec["jumps"], spec["samples"])


def swept_record(swept, jumps: Mapping[str, np.ndarray], samples) -> dict[str, np.ndarray]:
    """The arrays of one swept-sine run (a study.solve.swept_sine.SweptSine) as its task returns
    them (numbers only: staged by the run as one .npz file): at each of ``samples`` (values of
    the swept parameter, increasing) the first cycle that reached it, read over the
    SWEPT_WINDOW cycles ending there (``value``, ``tau``, ``min_q``, ``max_q``, ``ptp``,
    ``H1``, ``H2``, ``H1_2``; NaN where the run did not reach it); per jump of the stepped
    sweep (``jumps``: :func:`_swept_jump_specs`) ``jump_value``, ``jump_delay``
    (study.solve.swept_sine.swept_crossing); and ``cycles``, ``status``, ``seconds``, ``x0``."""
    w = SWEPT_WINDOW
    n = swept.values.size
    idx = swept.cycle_at(samples)
    ok = (idx >= 0) & (n >= w)
    idx = np.where(ok, np.maximum(idx, w - 1), 0)
    lows = np.lib.stride_tricks.sliding_window_view(swept.min_q, w).min(axis=-1) if n >= w \
        else np.zeros(0)
    highs = np.lib.stride_tricks.sliding_window_view(swept.max_q, w).max(axis=-1) if n >= w \
        else np.zeros(0)
    h1, h2, h12 = swept.force_components(w)

    def at(a, shift=0):
        a = np.asarray(a, float)
        if a.size == 0:
            return np.full(idx.size, np.nan)
        return np.where(ok, a[np.clip(idx - shift, 0, a.size - 1)], np.nan)

    out = {"value": at(swept.values), "tau": at(swept.tau), "min_q": at(lows, w - 1),
           "max_q": at(highs, w - 1), "ptp": at(swept.ptp(w)), "H1": at(h1), "H2": at(h2),
           "H1_2": at(h12)}
    m = np.asarray(jumps["value"]).size
    jv, jd = np.full(m, np.nan), np.full(m, np.nan)
    for k in range(m):
        if not jumps["read"][k]:
            continue
        stop = float(jumps["stop"][k])
        jv[k], jd[k] = swept_crossing(
            swept, float(jumps["value"][k]), float(jumps["from"][k]), float(jumps["to"][k]),
            measure="H1_2" if jumps["subharmonic"][k] else "ptp", period=int(jumps["period"][k]),
            scale=float(jumps["scale"][k]), start=float(jumps["start"][k]),
            stop=stop if np.isfinite(stop) else None)
    out.update(jump_value=jv, jump_delay=jd, cycles=np.int64(n), status=np.int64(swept.status),
               seconds=np.float64(swept.seconds),
               x0=np.asarray(swept.settings.get("x0", (np.nan, np.nan)), float))
    return out
