"""Solve one block of a grid study: every periodic response found at each point of the block.

A block is a set of omega lines (one per (sigma, zeta) pair). Along each line the solutions
seed each other, swept up and then down in omega, so that coexisting responses (the hysteresis
of the primary resonance with contact loss, the 2T branches) are followed from where they exist:

* 1T seeds: the linear response (paper Eq. 7 linearised about the static point), and the 1T
  solutions at the neighbouring point of each sweep.
* 2T seeds: the multiple-scales response (paper Eq. 19, study.multiple_scales), both branches;
  the flip eigenvector of the 1T orbit where it has a multiplier below -1 (x0 +- d e); and the
  2T solutions at the neighbouring point of each sweep.

Continuation seeds use a secant predictor along the branch. The linear, multiple-scales and flip
seeds are shot once per point (on the way up); on the way down only the orbits that the way up
did not reach by continuation are continued. Exploratory 2T seeds get 15 Newton steps. Together
these made a block 5.6x cheaper (15 -> 2.7 ms per point with 1T and 2T, sigma 0.2/0.5/0.8 lines
at zeta 0.01) with no orbit lost and 4 more found.

Distinct solutions are kept once: two orbits are the same when their invariants (min q, max q,
trace of the monodromy) agree; a 2T solve that lands on the 1T orbit (minimal period 1) is
dropped. Slot 0 always holds the 1T result (converged or the failure status of its best try).

This module is physics and numpy only: the scheduler ships ``solve_block`` without knowing it.
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from kernels import status as st
from kernels.api import DEFAULT_MAX_ITER, DEFAULT_MAX_STEPS
from kernels.model import MODELS
from kernels.shooting import F, N_FIELDS, shoot_batch_into

N_HARMONICS = 4
FLIP_SEED_OFFSETS = (0.05, 0.3)
MAX_ITER_1T = 40
MAX_ITER_2T = 15          # a 2T seed that has not converged in 15 Newton steps is a bad seed
SAME_ORBIT_TOL = 1e-6

VARIABLES = {
    # name: (dtype, empty value, trailing dims)
    "period": (np.int8, 0, ()),
    "q0": (np.float64, np.nan, ()),
    "v0": (np.float64, np.nan, ()),
    "multipliers": (np.complex128, np.nan + 0j, (2,)),
    "stable": (np.bool_, False, ()),
    "min_q": (np.float64, np.nan, ()),
    "max_q": (np.float64, np.nan, ()),
    "ptp": (np.float64, np.nan, ()),
    "loses_contact": (np.bool_, False, ()),
    "flight_fraction": (np.float64, np.nan, ()),
    "max_impact_velocity": (np.float64, np.nan, ()),
    "force_harmonics": (np.float64, np.nan, (N_HARMONICS,)),
    "newton_iterations": (np.int16, 0, ()),
    "residual": (np.float64, np.nan, ()),
    "status": (np.int8, st.EMPTY, ()),
}

#: Located bifurcation points kept per omega line of a block (``locate=True``); more are
#: dropped (``bifurcation_count`` says how many were found).
BIFURCATION_SLOTS = 16
#: Codes of ``bifurcation_kind`` (0: empty slot).
BIFURCATION_KINDS = {"fold": 1, "flip": 2, "grazing": 3}

BLOCK_VARIABLES = {
    # name: (dtype, empty value, trailing dims); leading dims (1, len(sigma), len(zeta)):
    # one omega block (the whole block's omega range) per (sigma, zeta) line
    "bifurcation_omega": (np.float64, np.nan, (BIFURCATION_SLOTS,)),
    "bifurcation_kind": (np.int8, 0, (BIFURCATION_SLOTS,)),
    "bifurcation_period": (np.int8, 0, (BIFURCATION_SLOTS,)),
    "bifurcation_q0": (np.float64, np.nan, (BIFURCATION_SLOTS,)),
    "bifurcation_v0": (np.float64, np.nan, (BIFURCATION_SLOTS,)),
    "bifurcation_count": (np.int16, -1, ()),
}


def linear_response_seed(omega, sigma, zeta):
    """(q, q') at tau = 0 of the linearised 1T response: q = Re[X e^{i omega tau}],
    X = sigma / (1 - omega^2 + 2 i zeta omega)."""
    den = 1.0 - omega**2 + 2j * zeta * omega
    if den == 0:            # undamped exact resonance: no linear response; start at rest
        return 0.0, 0.0
    X = sigma / den
    return X.real, (1j * omega * X).real


def _mms_seeds(omega, sigma, zeta):
    """Multiple-scales 2T seeds (both branches of Eq. 23, where real) at every omega of a line:
    a list, per omega, of (q0, v0) pairs. Evaluated once per line (the functions broadcast)."""
    # Far from omega = 2 the multiple-scales response is no theory, but it is a cheap seed that
    # lands on unstable halves of 2T branches the sweeps miss (measured on sigma 0.2/0.5/0.8
    # lines: restricting it to |omega - 2| < 0.3 lost 17 unstable orbits of 1330).
    omega = np.atleast_1d(np.asarray(omega, float))
    seeds = [[] for _ in range(omega.size)]
    try:
        from study.multiple_scales import mms_2t_seed
    except ImportError:     # analytic layer absent: the other seeds still work
        return seeds
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        for branch in ("upper", "lower"):
            q, v = mms_2t_seed(omega, sigma, zeta, branch)
            q = np.broadcast_to(np.asarray(q, float), omega.shape)
            v = np.broadcast_to(np.asarray(v, float), omega.shape)
            for i in range(omega.size):
                if np.isfinite(q[i]) and np.isfinite(v[i]):
                    seeds[i].append((float(q[i]), float(v[i])))
    return seeds


def _flip_seeds(sol):
    """2T seeds along the eigenvector of a 1T multiplier below -1 (past a flip)."""
    if sol["period"] != 1 or sol["status"] != st.CONVERGED:
        return []
    M = sol["monodromy"]
    # np.linalg.eig is most of this function's cost and gives no seed unless a multiplier is
    # below -0.95: skip it where the kernel's multipliers (roots of mu^2 - tr M mu + det M,
    # the same M) are both above -0.9. For |M_ij| < 1e4 the two computations differ by less
    # than ~sqrt(eps) |M| ~ 1e-4 (the eigenvalue perturbation bound of a 2x2 matrix), well
    # inside the 0.05 margin: the seeds are exactly those eig gives.
    mu = sol["multipliers"]
    if mu[0].real > -0.9 and mu[1].real > -0.9 and np.abs(M).max() < 1e4:
        return []
    w, V = np.linalg.eig(M)
    seeds = []
    for k in range(2):
        if abs(w[k].imag) < 1e-12 and w[k].real < -0.95:
            e = np.real(V[:, k])
            e /= np.linalg.norm(e)
            for d in FLIP_SEED_OFFSETS:
                seeds.append(tuple(sol["x0"] + d * e))
                seeds.append(tuple(sol["x0"] - d * e))
    return seeds


# Columns of the kernel's result rows (kernels.shooting.FIELDS) that become a solution's
# arrays, gathered by one ``take`` per batch: the start point, the multipliers as (re, im)
# pairs (viewed as complex), the monodromy row by row, the force harmonics.
_ARRAY_COLUMNS = np.array([
    F["q0"], F["v0"],
    F["multiplier1_re"], F["multiplier1_im"], F["multiplier2_re"], F["multiplier2_im"],
    F["m11"], F["m12"], F["m21"], F["m22"],
    F["force_h1"], F["force_h2"], F["force_h3"], F["force_h4"]])
_START, _MULTIPLIERS, _MONODROMY, _HARMONICS = (slice(0, 2), slice(2, 6), slice(6, 10),
                                                slice(10, 14))


def _solve(omega, sigma, zeta, period, seeds, options):
    """Shoot from every seed; return a list of solution dicts (converged or not), in the
    order of the seeds.

    Calls the numba batch entry point directly with preallocated arrays: the generic
    kernels.shoot_batch wrapper (broadcasting, a dict of arrays per call) cost ~15 % of a block.
    The rows are converted a batch at a time (numpy indexing per row, for each field, was most
    of the time spent outside the kernel) and the scalar fields read as Python floats.
    """
    if not seeds:
        return []
    n = len(seeds)
    period = int(period)
    q_guess, v_guess = zip(*seeds)
    # (omega, sigma, zeta, q guess, q' guess) per seed, each row a contiguous array
    inputs = np.array([(omega,) * n, (sigma,) * n, (zeta,) * n, q_guess, v_guess], float)
    rtol = float(options.get("rtol", 1e-10))
    rows = np.empty((n, N_FIELDS))
    shoot_batch_into(inputs[0], inputs[1], inputs[2], np.full(n, period, np.int64),
                     inputs[3], inputs[4], float(options.get("exponent", 1.5)),
                     MODELS[options.get("model", "hertz")], rtol, rtol,
                     int(options.get("max_iter", DEFAULT_MAX_ITER)), DEFAULT_MAX_STEPS,
                     bool(options.get("harmonics", True)), rows)
    picked = rows.take(_ARRAY_COLUMNS, axis=1)
    starts = picked[:, _START]
    multipliers = picked[:, _MULTIPLIERS].view(np.complex128)
    monodromies = picked[:, _MONODROMY].reshape(n, 2, 2)
    harmonics = picked[:, _HARMONICS]
    out = []
    for row, x0, mu, M, h in zip(rows.tolist(), starts, multipliers, monodromies, harmonics):
        minimal = row[F["minimal_period"]]
        out.append({
            # a 2T solve whose orbit repeats after T is a 1T orbit (minimal period 1); its
            # multipliers are still those of the 2T map: callers re-solve it as 1T
            "period": int(minimal) if math.isfinite(minimal) and minimal >= 1 else period,
            "status": int(row[F["status"]]),
            "x0": x0, "multipliers": mu, "monodromy": M,
            "stable": row[F["stable"]] == 1.0,
            "min_q": row[F["min_q"]], "max_q": row[F["max_q"]], "ptp": row[F["ptp"]],
            "loses_contact": row[F["loses_contact"]] == 1.0,
            "flight_fraction": row[F["flight_fraction"]],
            "max_impact_velocity": row[F["max_impact_velocity"]],
            "force_harmonics": h,
            "newton_iterations": int(row[F["iterations"]]), "residual": row[F["residual"]],
            "trace": row[F["trace_m"]],
        })
    return out


def _same_orbit(a, b):
    if a["period"] != b["period"]:
        return False
    tol = SAME_ORBIT_TOL * (1.0 + abs(a["ptp"]))
    return (abs(a["min_q"] - b["min_q"]) <= tol and abs(a["max_q"] - b["max_q"]) <= tol
            and abs(a["trace"] - b["trace"]) <= SAME_ORBIT_TOL * (1.0 + abs(a["trace"])))


def _merge(found, candidates):
    """Add the converged candidates that are new orbits; a candidate that duplicates a known
    orbit passes on its ``continued`` mark (reached by continuation from the previous point)."""
    for c in candidates:
        if c["status"] != st.CONVERGED:
            continue
        same = [f for f in found if _same_orbit(c, f)]
        if same:
            if c.get("continued"):
                same[0]["continued"] = True
        else:
            found.append(c)


def _continuation_seed(sol, omega):
    """Seed at omega from a solution of the neighbouring point: a secant predictor along the
    branch when the solution itself came from continuation, else its start point."""
    # Python floats: the same IEEE operations as on 2-element arrays, at a fraction of the cost
    q, v = sol["x0"].tolist()
    if "x0_prev" in sol and sol["omega"] != sol["omega_prev"]:
        step = (omega - sol["omega"]) / (sol["omega"] - sol["omega_prev"])
        q_prev, v_prev = sol["x0_prev"].tolist()
        dq, dv = q - q_prev, v - v_prev
        if (0.0 < step <= 2.0 and abs(dq) < 0.5 * (1.0 + abs(q))
                and abs(dv) < 0.5 * (1.0 + abs(v))):
            return q + step * dq, v + step * dv
    return q, v


def _mark_continued(sols, parents, omega):
    """Mark the solutions shot from the continuation seeds of ``parents`` (in that order) as
    continued; those that kept their parent's period remember it for the secant predictor."""
    for s, parent in zip(sols, parents):
        s["omega"] = omega
        s["continued"] = True
        if s["period"] == parent["period"]:
            s["x0_prev"] = parent["x0"]
            s["omega_prev"] = parent["omega"]


def _given_seeds(options, period):
    """The caller's own seeds (``solve_block(seeds=...)``) of this period, as (q, q')."""
    return [(q, v) for p, q, v in options.get("seeds", ()) if p == period]


def _point(omega, sigma, zeta, periods, prev, options, first_visit, mms_seeds=()):
    """Solutions at one point from continuation of the previous point's solutions ``prev``
    and, on the first visit of the point, from the linear, multiple-scales and flip seeds.

    Returns (distinct converged orbits, every 1T try). The seeds of one period share a
    Newton budget and go to the kernel in one batch (the results do not depend on batching).
    """
    found, tries_1t = [], []
    if 1 in periods:
        parents = [s for s in prev if s["period"] == 1]
        seeds = [_continuation_seed(p, omega) for p in parents]
        if first_visit:     # first: of two tries landing on one orbit, _merge keeps the first
            seeds[:0] = [linear_response_seed(omega, sigma, zeta)] + _given_seeds(options, 1)
        tries_1t = _solve(omega, sigma, zeta, 1, seeds, dict(options, max_iter=MAX_ITER_1T))
        _mark_continued(tries_1t[len(seeds) - len(parents):], parents, omega)
        _merge(found, tries_1t)
    if 2 in periods:
        parents = [s for s in prev if s["period"] == 2]
        seeds = [_continuation_seed(p, omega) for p in parents]
        if first_visit:
            seeds += mms_seeds
            for s in found:
                seeds += _flip_seeds(s)
            seeds += _given_seeds(options, 2)
        sols = _solve(omega, sigma, zeta, 2, seeds, dict(options, max_iter=MAX_ITER_2T))
        _mark_continued(sols, parents, omega)
        _merge(found, [s for s in sols if s["period"] == 2])
        # A 2T solve with minimal period 1 landed on a 1T orbit. Its monodromy is that of two
        # periods (multipliers squared), so the orbit is re-solved as 1T from its start point
        # (one Newton step) and kept only as that.
        landed = [tuple(s["x0"]) for s in sols
                  if s["period"] == 1 and s["status"] == st.CONVERGED]
        if landed and 1 in periods:
            _merge(found, _solve(omega, sigma, zeta, 1, landed, options))
    for s in found:
        s.setdefault("omega", omega)
    return found, tries_1t


def _record(arrays, points, j, k, slots, sols):
    """Write the solutions ``sols`` of line (j, k) into their cells (omega index ``points``,
    slot ``slots``), one fancy-indexed assignment per variable for the whole line."""
    cells = (points, j, k, slots)
    starts = np.array([s["x0"] for s in sols])
    for name in VARIABLES:
        if name == "q0":
            arrays[name][cells] = starts[:, 0]
        elif name == "v0":
            arrays[name][cells] = starts[:, 1]
        else:
            arrays[name][cells] = np.array([s[name] for s in sols])


def line_bifurcations(special, omega_lo, omega_hi) -> list[dict]:
    """The fold, flip and grazing points of a line (``LineResult.special`` of
    study.discovery.discover_line) with omega_lo <= omega <= omega_hi, ordered by
    (omega, kind, period). Branch points (a 2T branch ending on the 1T orbit: the 1T flip
    seen from the 2T side, located to ~1e-4 only) are left out: the flip is the 1T entry."""
    out = [d for d in special if d["kind"] in BIFURCATION_KINDS
           and np.isfinite(d["omega"]) and omega_lo <= d["omega"] <= omega_hi]
    out.sort(key=lambda d: (d["omega"], BIFURCATION_KINDS[d["kind"]], d["period"], d["q0"]))
    return out


def _record_bifurcations(arrays, j, k, points):
    arrays["bifurcation_count"][0, j, k] = len(points)
    for slot, d in enumerate(points[:BIFURCATION_SLOTS]):
        arrays["bifurcation_omega"][0, j, k, slot] = d["omega"]
        arrays["bifurcation_kind"][0, j, k, slot] = BIFURCATION_KINDS[d["kind"]]
        arrays["bifurcation_period"][0, j, k, slot] = d["period"]
        arrays["bifurcation_q0"][0, j, k, slot] = d["q0"]
        arrays["bifurcation_v0"][0, j, k, slot] = d["v0"]


def solve_block(omega, sigma, zeta, *, periods=(1, 2), exponent=1.5, model="hertz", rtol=1e-10,
                max_solutions=4, discover=False, transients=16, locate=False,
                harmonics=True, time_budget=None, seeds=()) -> dict[str, np.ndarray]:
    """Every periodic response at each point of the block omega x sigma x zeta.

    ``seeds``: more initial guesses ``(period, q0, q'0)``, shot at every point of the block on
    its first visit with the automatic ones (1T: after the linear seed; 2T: last), so an orbit
    they reach that another seed also reaches is kept once. The error estimate re-solves a
    stored orbit from its own start point with them, so that it finds that orbit again without
    its neighbours.

    ``discover=True`` adds, per omega line, the discovery stage of study.discovery (transients
    from ``transients`` initial states at up to 12 points of the line, continuation of every
    branch found, branch switching at flips): isolas and the unstable halves of branches are
    found without hand-given seeds. Off by default (it costs about 0.5-2 s per line).

    ``locate=True`` also locates, along each omega line, the fold points (1T and 2T), the
    flip points and the grazing points (onset of contact loss, min q = -n) inside the
    block's omega range, and returns them in BLOCK_VARIABLES (shape (1, len(sigma),
    len(zeta), BIFURCATION_SLOTS); ``bifurcation_count`` (1, len(sigma), len(zeta)): how many
    were found, -1 where the time budget ran out first). They come from the continuation stage
    of study.discovery (every grid solution continued in omega across the line, sign changes
    of 1 - tr M + det M, 1 + tr M + det M and min q + n between consecutive continuation
    points, at most half a grid step apart, refined on the branch by
    kernels.continuation: |test function| ~ 1e-14). Off by default: the grid results are the
    same with or without it.

    ``harmonics=False`` leaves ``force_harmonics`` NaN: their quadrature costs about a quarter
    of the solver's time, and a study that does not store them (product ``force_harmonics``)
    need not pay for it. Every other variable is bit-for-bit the same either way.

    ``time_budget`` (seconds, optional): once spent, the points not yet reached get status
    ``time_limit`` in slot 0 (period 0) and the block returns: a runaway block is cut and
    recorded instead of holding up a study. Every kernel call is itself bounded in work.

    Returns {variable: array} with shape (len(omega), len(sigma), len(zeta), max_solutions)
    (+ (2,) for multipliers, + (4,) for force_harmonics); see VARIABLES for dtypes and the
    values of empty slots. Dimensionless inputs (paper Eq. 7). Deterministic: the same block
    gives the same arrays, bit for bit, on any worker.
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
                   harmonics=bool(harmonics),
                   seeds=tuple((int(p), float(q), float(v)) for p, q, v in seeds))
    shape = (omega.size, sigma.size, zeta.size, int(max_solutions))
    arrays = {name: np.full(shape + trail, empty, dtype=dtype)
              for name, (dtype, empty, trail) in VARIABLES.items()}
    if locate:
        lead = (1, sigma.size, zeta.size)
        arrays.update({name: np.full(lead + trail, empty, dtype=dtype)
                       for name, (dtype, empty, trail) in BLOCK_VARIABLES.items()})
    order = np.argsort(omega, kind="stable")
    deadline = None if time_budget is None else time.monotonic() + float(time_budget)
    for j in range(sigma.size):
        for k in range(zeta.size):
            if deadline is not None and time.monotonic() > deadline:
                arrays["status"][:, j, k, 0] = st.TIME_LIMIT
                continue
            per_point = [[] for _ in range(omega.size)]
            best_1t = [None] * omega.size
            visited = np.zeros(omega.size, bool)
            mms = _mms_seeds(omega, sigma[j], zeta[k]) if 2 in periods else None
            # Up the omega axis, then down. Going down, only the orbits that the way up did not
            # reach by continuation are continued (the others would lead back to orbits already
            # known): this finds the branches that end in a fold towards higher omega.
            for first_visit, sweep in ((True, order), (False, order[::-1])):
                prev = []
                for i in sweep:
                    if deadline is not None and time.monotonic() > deadline:
                        break
                    found, tries = _point(omega[i], sigma[j], zeta[k], periods, prev, options,
                                          first_visit, mms[i] if mms is not None else ())
                    visited[i] = True
                    _merge(per_point[i], found)
                    if tries and best_1t[i] is None:
                        best_1t[i] = min(tries, key=lambda s: (s["status"] != st.CONVERGED,
                                                               s["residual"]
                                                               if math.isfinite(s["residual"])
                                                               else math.inf))
                    if first_visit:
                        prev = per_point[i]
                    else:
                        prev = [s for s in per_point[i] if not s.get("continued_up")]
                if first_visit:
                    for sols in per_point:
                        for s in sols:
                            s["continued_up"] = bool(s.get("continued"))
            line = None
            if discover and (deadline is None or time.monotonic() <= deadline):
                from study.discovery import discover_line
                line = discover_line(omega, sigma[j], zeta[k], periods=periods,
                                     exponent=exponent, model=model, rtol=rtol,
                                     transients=int(transients), initial=per_point)
                per_point = line.solutions
            if locate and omega.size and (deadline is None or time.monotonic() <= deadline):
                if line is None:
                    # continuation only (no transients): the grid solutions are unchanged
                    from study.discovery import discover_line
                    line = discover_line(omega, sigma[j], zeta[k], periods=periods,
                                         exponent=exponent, model=model, rtol=rtol,
                                         transients=0, initial=per_point)
                _record_bifurcations(arrays, j, k, line_bifurcations(
                    line.special, float(omega.min()), float(omega.max())))
            points, slots, recorded = [], [], []
            for i in range(omega.size):
                sols = per_point[i]
                one = sorted([s for s in sols if s["period"] == 1], key=lambda s: s["ptp"])
                two = sorted([s for s in sols if s["period"] == 2], key=lambda s: s["ptp"])
                ordered = one + two
                if not one and best_1t[i] is not None and 1 in periods:
                    ordered = [best_1t[i]] + two     # record why the 1T solve failed
                for slot, sol in enumerate(ordered[:max_solutions]):
                    points.append(i)
                    slots.append(slot)
                    recorded.append(sol)
            if recorded:
                _record(arrays, points, j, k, slots, recorded)
            arrays["status"][~visited, j, k, 0] = st.TIME_LIMIT
    return arrays
