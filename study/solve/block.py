"""Solve one block of a grid study: every periodic response found at each point of the block.

A block is a set of omega lines (one per (sigma, zeta) pair). Along each line the solutions
seed each other, swept up and then down in omega, so that coexisting responses (the hysteresis
of the primary resonance with contact loss, the 2T branches) are followed from where they exist:

* 1T seeds: the linear response (paper Eq. 7 linearised about the static point), and the 1T
  solutions at the neighbouring point of each sweep.
* 2T seeds: the multiple-scales response (paper Eq. 19, study.analytic.multiple_scales), both branches;
  the flip eigenvector of the 1T orbit where it has a multiplier below -1 (x0 +- d e); and the
  2T solutions at the neighbouring point of each sweep.

Continuation seeds use a secant predictor along the branch. The linear, multiple-scales and flip
seeds are shot once per point (on the way up); on the way down only the orbits that the way up
did not reach by continuation are continued. Exploratory 2T seeds get 15 Newton steps. Together
these made a block 5.6x cheaper (15 -> 2.7 ms per point with 1T and 2T, sigma 0.2/0.5/0.8 lines
at zeta 0.01) with no orbit lost and 4 more found.

Distinct solutions are kept once (the identity rule of study.orbit_rules); a 2T solve that lands on
the 1T orbit (minimal period 1) is not a new orbit. Every orbit found is stored, in the slots
study.solve.point_state orders (slot 0: the 1T result, converged or the failure status of its
best try). The arrays are those of the stored schema (study.schema), sized by the data.

This module is physics and numpy only: the scheduler ships ``solve_block`` without knowing it.
"""
from __future__ import annotations

import time

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.model import (DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL, MODELS,
                                    contact_loss_level)
from hertzmap.study.schema import (ATTRACTOR_VARIABLES, BIFURCATION_KINDS, BIFURCATION_SLOTS,
                                   BIFURCATION_VARIABLES, CROSSING_SLOTS, CROSSING_VARIABLES,
                                   ORBIT_VARIABLES, empty_arrays)
from hertzmap.study.solve.curve_seeds import line_crossings
from hertzmap.study.solve.discovery import discover_line
from hertzmap.study.solve.line import LINEAR_SEED_STRIDE, MMS_SEED_STRIDE, LineSearch
from hertzmap.study.solve.point_state import PointState, write_states

#: the time-limit mark of a point its block did not reach (slot 0)
TIME_LIMIT_RECORD = {"status": st.TIME_LIMIT, "period": 0}


def line_bifurcations(special, omega_lo, omega_hi) -> list[dict]:
    """The fold, flip and grazing points of a line (``LineResult.special`` of
    study.solve.discovery.discover_line) with omega_lo <= omega <= omega_hi, ordered by
    (omega, kind, period). Branch points (a 2T branch ending on the 1T orbit: the 1T flip
    seen from the 2T side, located to ~1e-4 only) are left out: the flip is the 1T entry."""
    out = [d for d in special if d["kind"] in BIFURCATION_KINDS
           and np.isfinite(d["omega"]) and omega_lo <= d["omega"] <= omega_hi]
    out.sort(key=lambda d: (d["omega"], BIFURCATION_KINDS[d["kind"]], d["period"], d["q0"]))
    return out


def record_line(arrays, names, slots, j, k, records):
    """A line's records (dicts with kind and the other fields of the stored ``names``:
    study.schema BIFURCATION_VARIABLES or CROSSING_VARIABLES, ``<prefix>_<field>``) into the
    block arrays: the count, then one slot per record (at most ``slots``)."""
    prefix = names[0].partition("_")[0]
    arrays[f"{prefix}_count"][0, j, k] = len(records)
    fields = [n.removeprefix(prefix + "_") for n in names
              if n not in (f"{prefix}_count", f"{prefix}_kind")]
    for slot, d in enumerate(records[:slots]):
        arrays[f"{prefix}_kind"][0, j, k, slot] = BIFURCATION_KINDS[d["kind"]]
        for name in fields:
            arrays[f"{prefix}_{name}"][0, j, k, slot] = d[name]


def entry_kernels(*, attractors="never", turn_folds=True, discover=False, locate=False,
                  **_ignored) -> list:
    """The numba entry points a block with these options calls (kernels._jit kernels):
    the batch shooting kernel; the period map of the continuation when folds are turned or
    branches continued; the census's batch kernel and its Lyapunov exponent when it runs. A
    worker's warm-up compiles these (kernels._jit.compile_kernels), so that with an empty
    cache two workers share them instead of meeting in their first tasks, where one waits for
    the other's compile."""
    from hertzmap.kernels.attractors import attractor_batch_into, lyapunov_into
    from hertzmap.kernels.continuation import period_map_into
    from hertzmap.kernels.shooting import shoot_batch_into

    out = [shoot_batch_into]
    if turn_folds or discover or locate:
        out.append(period_map_into)
    if attractors != "never":
        out += [attractor_batch_into, lyapunov_into]
    return out


def solve_block(omega, sigma, zeta, *, periods=(1, 2), exponent=DEFAULT_EXPONENT, model=DEFAULT_LAW,
                rtol=DEFAULT_RTOL,
                discover=False, transients=16, locate=False, crossings=False,
                harmonics=True, time_budget=None, seeds=(), turn_folds=True,
                attractors="never", initial_states=16, transient_periods=500,
                record_periods=128, max_transient_periods=None, point_steps=2_000_000,
                lyapunov_error=None,
                seed_strides=(LINEAR_SEED_STRIDE, MMS_SEED_STRIDE)) -> dict[str, np.ndarray]:
    """Every periodic response at each point of the block omega x sigma x zeta.

    ``seeds``: more initial guesses ``(period, q0, q'0)``, shot at every point of the block on
    its first visit before the automatic ones (at their own period, searched or not), so an
    orbit they reach that another seed also reaches is kept once, with their start point. The error estimate re-solves a
    stored orbit from its own start point with them, so that it finds that orbit again without
    its neighbours.

    ``discover=True`` adds, per omega line, the discovery stage of study.solve.discovery (transients
    from ``transients`` initial states at up to 12 points of the line, continuation of every
    branch found, branch switching at flips): isolas and the unstable halves of branches are
    found without hand-given seeds. Off by default (it costs about 0.5-2 s per line).

    ``locate=True`` also locates, along each omega line, the fold points (1T and 2T), the
    flip points and the grazing points (onset of contact loss, min q = -n) inside the
    block's omega range, and returns them in the schema's BIFURCATION_VARIABLES (shape (1,
    len(sigma), len(zeta), BIFURCATION_SLOTS); ``bifurcation_count`` (1, len(sigma), len(zeta)): how many
    were found, -1 where the time budget ran out first). They come from the continuation stage
    of study.solve.discovery (every grid solution continued in omega across the line, sign changes
    of 1 - tr M + det M, 1 + tr M + det M and min q + n between consecutive continuation
    points, at most half a grid step apart, refined on the branch by
    kernels.continuation: |test function| ~ 1e-14). Off by default: the grid results are the
    same with or without it.

    ``crossings=True`` also records, along each omega line, where a test function changes sign
    between two neighbouring grid points of the block (study.solve.curve_seeds.line_crossings, over
    every orbit the line search found, stored in the slots or not): the seeds of the traced
    curves, in the schema's CROSSING_VARIABLES (shape (1, len(sigma), len(zeta),
    CROSSING_SLOTS)). No kernel call: the grid results are the same with or without it.

    ``harmonics=False`` leaves ``force_harmonics`` NaN: their quadrature costs about a quarter
    of the solver's time, and a study that does not store them (product ``force_harmonics``)
    need not pay for it. Every other variable is bit-for-bit the same either way.

    ``time_budget`` (seconds, optional): once spent, the points not yet reached get status
    ``time_limit`` in slot 0 (period 0) and the block returns: a runaway block is cut and
    recorded instead of holding up a study. Every kernel call is itself bounded in work.

    Returns {variable: array} with shape (len(omega), len(sigma), len(zeta), slots) (+ (2,)
    for multipliers, + (4,) for force_harmonics): every orbit found at a point, ``slots`` the
    most any point of the block holds in whole chunks (study.schema.chunked_length); the
    census's variables likewise along ``attractor``; the dtypes and the values of empty slots
    are those of study.schema.VARIABLES. Dimensionless inputs (paper Eq. 7). Deterministic:
    the same block gives the same arrays, bit for bit, on any worker.
    """
    omega = np.asarray(omega, float)
    sigma = np.asarray(sigma, float)
    zeta = np.asarray(zeta, float)
    periods = tuple(int(p) for p in periods)
    if model not in MODELS:
        raise ValueError(f"model must be one of {sorted(MODELS)}, got {model!r}")
    if not (np.isfinite(exponent) and exponent > 0):
        raise ValueError(f"exponent must be a finite number > 0, got {exponent!r}")
    options = dict(exponent=float(exponent), model=model, rtol=float(rtol),
                   linear_stride=int(seed_strides[0]),
                   mms_stride=None if seed_strides[1] is None else int(seed_strides[1]),
                   harmonics=bool(harmonics),
                   seeds=tuple((int(p), float(q), float(v)) for p, q, v in seeds))
    point_names = ORBIT_VARIABLES + ("orbits_found",) \
        + (ATTRACTOR_VARIABLES if attractors != "never" else ())
    line_names = (BIFURCATION_VARIABLES if locate else ()) + (CROSSING_VARIABLES if crossings else ())
    shape = (omega.size, sigma.size, zeta.size)
    arrays = empty_arrays(shape, names=line_names)
    states: dict[tuple, PointState] = {}
    deadline = None if time_budget is None else time.monotonic() + float(time_budget)
    level = contact_loss_level(model, float(exponent))
    for j in range(sigma.size):
        for k in range(zeta.size):
            if deadline is not None and time.monotonic() > deadline:
                for i in range(omega.size):
                    states[i, j, k] = PointState(status_record=TIME_LIMIT_RECORD,
                                                 visited=False, omega=float(omega[i]))
                continue
            search = LineSearch(omega, float(sigma[j]), float(zeta[k]), periods, options,
                                deadline)
            search.sweep()
            if turn_folds:
                search.turn_folds()
            search.run_census(attractors, int(initial_states), int(transient_periods),
                              int(record_periods),
                              int(max_transient_periods or transient_periods),
                              int(point_steps), lyapunov_error)
            per_point = search.per_point
            line = None
            if discover and (deadline is None or time.monotonic() <= deadline):
                line = discover_line(omega, sigma[j], zeta[k], periods=periods,
                                     exponent=exponent, model=model, rtol=rtol,
                                     transients=int(transients), initial=per_point)
                per_point = line.solutions
            if locate and omega.size and (deadline is None or time.monotonic() <= deadline):
                if line is None:
                    # continuation only (no transients): the grid solutions are unchanged
                    line = discover_line(omega, sigma[j], zeta[k], periods=periods,
                                         exponent=exponent, model=model, rtol=rtol,
                                         transients=0, initial=per_point)
                record_line(arrays, BIFURCATION_VARIABLES, BIFURCATION_SLOTS, j, k,
                             line_bifurcations(line.special, float(omega.min()),
                                               float(omega.max())))
            if crossings and search.visited.all():
                record_line(arrays, CROSSING_VARIABLES, CROSSING_SLOTS, j, k,
                             line_crossings(omega, per_point, level, periods))
            for i in range(omega.size):
                state = PointState(list(per_point[i]), visited=bool(search.visited[i]),
                                   omega=float(omega[i]))
                state.status_record = search.best_1t[i] if search.visited[i] \
                    else TIME_LIMIT_RECORD
                if i in search.attractors:
                    state.attractors = search.attractors[i]
                    state.n_states = int(initial_states)
                states[i, j, k] = state
    arrays.update(write_states(states, shape, point_names, periods))
    return arrays
