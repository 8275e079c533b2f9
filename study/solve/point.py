"""The orbits at one grid point: shoot from seeds, keep each orbit once (paper section 3.2).

A *solution* is a dict with the stored variables of one slot (study.schema ORBIT_VARIABLES:
period, status, x0 as the start point, multipliers, stable, min_q, ...) plus the monodromy and
its trace; the solver adds bookkeeping keys (``omega``, ``continued``, ``x0_prev``...).
Distinct orbits are kept once by the identity rule of study.orbit_rules.
"""
from __future__ import annotations

import math

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.periodic_orbit import DEFAULT_MAX_ITER, DEFAULT_MAX_STEPS
from hertzmap.kernels.model import Model
from hertzmap.kernels.records import ORBIT
from hertzmap.kernels.shooting import F, N_FIELDS, shoot_batch_into
from hertzmap.study.orbit_rules import same_orbit
from hertzmap.study.solve.seeds import continuation_seed, flip_seeds, linear_response_seed

MAX_ITER_1T = 40
MAX_ITER_2T = 15          # a 2T seed that has not converged in 15 Newton steps is a bad seed

#: The orbit record's fields a solution carries (kernels.records.ORBIT): those a study may
#: store, and the monodromy and its trace, which the solver reads.
_SOLUTION_FIELDS = tuple(f for f in ORBIT.fields if f.kernel_columns
                         and (f.output is not None or f.name in ("monodromy", "trace_m")))
_START = np.array([F["q0"], F["v0"]])


def _field_values(rows: np.ndarray, field) -> list:
    """One value per row of ``field``: Python scalars for scalar fields (they are read one at a
    time, where numpy scalars cost more), arrays for vectors (the monodromy as 2 x 2)."""
    cols = [F[c] for c in field.kernel_columns]
    if field.dim is None:
        col = rows[:, cols[0]]
        if field.dtype == "bool":
            return (col == 1.0).tolist()
        if field.dtype.startswith("int"):
            return [int(v) for v in col.tolist()]
        return col.tolist()
    block = rows.take(cols, axis=1)
    if field.dtype == "complex128":
        return list(block.view(np.complex128))
    if field.name == "monodromy":
        return list(block.reshape(-1, 2, 2))
    return list(block)


def _solve(omega, sigma, zeta, periods, q_guess, v_guess, options) -> list[dict]:
    """One Newton solve per row of the arrays (omega, sigma, zeta, period, guess), in one call
    of the numba batch entry point with preallocated arrays (the generic kernels.shoot_batch
    wrapper, broadcasting and a dict of arrays per call, cost ~15 % of a block)."""
    inputs = np.array([omega, sigma, zeta, q_guess, v_guess], float)
    periods = np.asarray(periods, np.int64)
    model = Model.of(options)
    rows = np.empty((periods.size, N_FIELDS))
    shoot_batch_into(inputs[0], inputs[1], inputs[2], periods, inputs[3], inputs[4],
                     model.exponent, model.code, model.rtol, model.rtol, int(options.get("max_iter", DEFAULT_MAX_ITER)),
                     float(options.get("stall_ratio", 1.0)), DEFAULT_MAX_STEPS,
                     bool(options.get("harmonics", True)), rows)
    return solutions_from_rows(rows, periods)


def shoot_seeds(omega, sigma, zeta, period, seeds, options):
    """Shoot from every seed; return a list of solution dicts (converged or not), in the
    order of the seeds."""
    if not seeds:
        return []
    n = len(seeds)
    q_guess, v_guess = zip(*seeds)
    return _solve((omega,) * n, (sigma,) * n, (zeta,) * n, (int(period),) * n, q_guess,
                  v_guess, options)


def solutions_from_rows(rows: np.ndarray, period) -> list[dict]:
    """Solution dicts from kernel result rows (kernels.shooting.FIELDS) of solves of ``period``
    (one for all rows, or one per row): the fields of :data:`_SOLUTION_FIELDS` by name, ``x0``
    the start point and ``period``. The rows are converted a field at a time for the whole
    batch (numpy indexing per row, for each field, was most of the time spent outside the
    kernel)."""
    values = [(f.name, _field_values(rows, f)) for f in _SOLUTION_FIELDS]
    starts = rows.take(_START, axis=1)
    periods = np.broadcast_to(np.asarray(period, int), (rows.shape[0],)).tolist()
    out = []
    for r, minimal in enumerate(rows[:, F["minimal_period"]].tolist()):
        sol = {name: v[r] for name, v in values}
        # a 2T solve whose orbit repeats after T is a 1T orbit (minimal period 1); its
        # multipliers are still those of the 2T map: callers re-solve it as 1T
        sol["period"] = int(minimal) if math.isfinite(minimal) and minimal >= 1 else periods[r]
        sol["x0"] = starts[r]
        sol["atlas_round"] = 0          # found by the grid's search (study.solve.atlas: >= 1)
        out.append(sol)
    return out


def shoot_targets(targets, options) -> list[dict]:
    """One Newton solve per target (omega, sigma, zeta, period, (q, q') guess), all in one
    kernel call (targets at different grid points and periods: the atlas's shots of a round),
    a solve that landed on an orbit of a lower minimal period (a 2T solve on the 1T orbit: its
    monodromy is then M^2) re-solved at that period from its start point, so that it carries
    that period's multipliers; solution dicts in the order of the targets."""
    if not targets:
        return []
    w, s, z, m, x = zip(*targets)
    out = _solve(w, s, z, m, [g[0] for g in x], [g[1] for g in x], options)
    low = [i for i, sol in enumerate(out) if sol["period"] < targets[i][3]
           and sol["status"] == st.CONVERGED]
    again = shoot_targets([targets[i][:3] + (out[i]["period"], tuple(out[i]["x0"]))
                           for i in low], options)
    for i, sol in zip(low, again):
        out[i] = sol
    return out


def shoot_seeds_minimal(omega, sigma, zeta, period, seeds, options):
    """shoot_seeds, each solve on a lower minimal period re-solved at it (shoot_targets)."""
    return shoot_targets([(omega, sigma, zeta, int(period), tuple(x)) for x in seeds], options)


def merge_new_orbits(found, candidates):
    """Add the converged candidates that are new orbits; a candidate that duplicates a known
    orbit passes on its ``continued`` mark (reached by continuation from the previous point)."""
    for c in candidates:
        if c["status"] != st.CONVERGED:
            continue
        same = [f for f in found if same_orbit(c, f)]
        if same:
            if c.get("continued"):
                same[0]["continued"] = True
        else:
            found.append(c)


def is_known(sol, sols) -> bool:
    """sol is the same orbit as one of sols (study.orbit_rules identity rule)."""
    return any(same_orbit(sol, s) for s in sols)


def mark_continued(sols, parents, omega):
    """Mark the solutions shot from the continuation seeds of ``parents`` (in that order) as
    continued; those that kept their parent's period remember it for the secant predictor."""
    for s, parent in zip(sols, parents):
        s["omega"] = omega
        s["continued"] = True
        if s["period"] == parent["period"]:
            s["x0_prev"] = parent["x0"]
            s["omega_prev"] = parent["omega"]


def given_seeds(options, period):
    """The caller's own seeds (``solve_block(seeds=...)``) of this period, as (q, q')."""
    return [(q, v) for p, q, v in options.get("seeds", ()) if p == period]


def solve_point(omega, sigma, zeta, periods, prev, options, first_visit, mms=(),
                explore=True):
    """Solutions at one point from continuation of the previous point's solutions ``prev``
    and, on the first visit of the point, from the seeds: the flip eigenvectors of the orbits
    of half the period (2T from 1T, 4T from 2T, ...), the caller's own, the multiple-scales 2T
    seeds ``mms`` given, and, where ``explore``, the linear response (1T). The linear seed is
    also shot wherever no 1T orbit is continued into the point.

    Returns (distinct converged orbits, every 1T try). The seeds of one period share a
    Newton budget and go to the kernel in one batch (the results do not depend on batching).
    Periods are searched in increasing order, so that flip seeds come from orbits found first.
    """
    found, tries_1t = [], []
    # the caller's own seeds are shot at their period even when it is not searched (an orbit
    # the census found, re-solved by the error estimate)
    extra = {p for p, _, _ in options.get("seeds", ())} if first_visit else set()
    for period in sorted(set(periods) | extra):
        parents = [s for s in prev if s["period"] == period]
        seeds = [continuation_seed(p, omega) for p in parents]
        if period == 1:
            if first_visit:     # first: of two tries landing on one orbit, the merge keeps the first
                linear = [linear_response_seed(omega, sigma, zeta)] if explore or not parents \
                    else []
                seeds[:0] = given_seeds(options, 1) + linear
            tries_1t = shoot_seeds(omega, sigma, zeta, 1, seeds,
                                   dict(options, max_iter=MAX_ITER_1T))
            mark_continued(tries_1t[len(seeds) - len(parents):], parents, omega)
            merge_new_orbits(found, tries_1t)
            continue
        explorers = []
        if first_visit:
            if period == 2:
                explorers += mms
            if period % 2 == 0:
                for s in found:
                    if s["period"] == period // 2:
                        explorers += flip_seeds(s)
        # the caller's seeds first: of two tries landing on one orbit (its start point or a
        # T-shifted one) the merge keeps the first, so the error estimate finds the start
        # point it sampled
        given = given_seeds(options, period) if first_visit else []
        sols = shoot_seeds(omega, sigma, zeta, period, given + seeds + explorers,
                           dict(options, max_iter=MAX_ITER_2T))
        mark_continued(sols[len(given):], parents, omega)
        merge_new_orbits(found, [s for s in sols if s["period"] == period])
        # A solve whose orbit has a smaller minimal period landed on an orbit of that period.
        # Its monodromy is that of the longer map (multipliers raised to the ratio), so the
        # orbit is re-solved at its own period from its start point (one Newton step) and kept
        # only as that, where that period is searched.
        for low in sorted({s["period"] for s in sols if s["period"] < period}):
            landed = [tuple(s["x0"]) for s in sols
                      if s["period"] == low and s["status"] == st.CONVERGED]
            if landed and low in periods:
                merge_new_orbits(found, shoot_seeds(omega, sigma, zeta, low, landed, options))
    for s in found:
        s.setdefault("omega", omega)
    return found, tries_1t
