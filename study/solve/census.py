"""The attractor census of a grid point: what the contact does in the long run, from a set of
initial states.

From each initial state (study.solve.seeds.initial_states: a fixed box, and where the point's
known orbits leave it, half of them in a box that covers those, seeds.reach_box, so that
attractors with long flights are reached) a transient runs on the stroboscopic
map (kernels.attractors): it settles on a stable periodic orbit of period m <= 16 (refined by
shooting), or it does not within its period budget. The census groups the outcomes of one point
into attractors:

* **periodic**: a stable orbit (the identity rule of study.orbit_rules); new orbits join the point's
  orbits and are stored like any other, with their period;
* **non_periodic**: the transients that did not settle, when the point has no stable orbit (from
  shooting, or found here) and their largest Lyapunov exponent over the record window is
  positive beyond three standard errors, with the two halves of the window agreeing: chaos;
* **unsettled**: transients that did not settle otherwise (a period > 16, a transient longer
  than the budget, or a stable orbit at the point these transients did not reach and that
  the longer passes below did not tell apart: a point with a stable orbit is never called
  chaotic because a transient was long);
* **failed**: integration failures (never a crash).

Before a point is called non-periodic, its stroboscopic points are searched for close returns
x_{k+m} ~ x_k (m = 1..8); each is a Newton seed of period m: a stable orbit found so turns the
point into "unsettled" (the chaotic-looking transients are transients), an unstable one is a
periodic response of the point like any other (an orbit embedded in the chaotic set).

Unsettled: a point whose open transients are not shown chaotic gets longer passes, each
``LONGER`` times the last, from where they stopped, up to the study's search.max_transient_periods
periods in all and within its search.point_steps (integration steps summed over its open
transients: work, not wall time, so that the results do not depend on the machine): a
transient that settles then counts with its periodic attractor. At a point with a stable
orbit, open transients with a positive exponent are a chaotic attractor beside it once a
longer pass ends with none of them escaping to the orbit (a chaotic transient leaks runs at
its escape rate: with k runs and a pass of P periods none escaping, its mean lifetime is
beyond about k P periods, and the contact is chaotic for that long) or once they ran all
their periods; where no stable orbit is known, a positive exponent suffices. The others stay
unsettled with the reason (``unsettled_reason``: the period limit, or the work budget).

Certified orbits (study.solve.certificate): before the first transient, each stable orbit the
point already knows (the grid's search, the atlas) gets its certified neighbourhood, where its
m-period map contracts a quadratic Lyapunov function of its monodromy; a transient that enters
it and shows the predicted contraction m periods later stops there and counts with that orbit
(it is reached, with its own window measures taken once from a run started on the orbit). A
stable orbit a transient finds is certified too while more than CERTIFY_AHEAD of the point's
own transients are to come. On the default scene's lines a transient stops after 70 periods
where the recognition below took 135 (BENCHMARKS.md, benchmarks/census_ab.py --compare
certified), every attractor named as without it.

Recognition (study.solve.recognition): the transients run one after another, and one stops as
soon as it is recognised on what the point's earlier ones found: a periodic attractor's points
(then it counts with it, without its own refinement and measures) or, in the longer passes of
a point without a stable orbit, the open set of another unsettled transient (then it shares
that transient's fate, and the passes go on without it until a transient reaches a stable
orbit); the first OPEN_LEADERS unsettled transients are never recognised so. The order is fixed, so a block gives the same arrays on
any worker.

Neighbours: the caller may pass states on the neighbouring grid points' attractors
(attractor_starts: the last stroboscopic point of each periodic or chaotic attractor there;
study.solve.line passes those of the line's neighbours whose census ran, study.solve.atlas
those of every axis). After the first pass of the point's own states, a transient runs from
each, recognised on everything the own runs found (their periodic attractors, and one set of
the points of all their open runs, in the first pass too: these runs decide nothing about the
own states) and on what the earlier neighbour starts found. Where the neighbour's attractor is here too, the run stops
within a few periods and adds nothing. One that settles on a stable orbit no own state reached
adds the orbit and a periodic attractor with basin fraction 0; one that stays open joins the
open runs (their longer passes and chaos test, beside any stable orbit now known), and alone
makes an attractor only once shown chaotic (basin fraction 0 again). Basin fractions and the
basin entropy count the point's own states only.

Basin fractions: the share of the initial states ending on each attractor. Where none of the
first FULL_BUDGET_STATES transients settles within the whole budget, the others run for a fifth
of it, to screen for a periodic attractor with a quick transient; those that have not settled
by then count with the unsettled (or non-periodic) group.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.attractors import (A, LYAPUNOV_FIELDS, N_ATTRACTOR_FIELDS, N_LYAPUNOV_FIELDS,
                                NO_LABEL, attractor_batch_into, lyapunov_into)
from hertzmap.kernels.model import Model
from hertzmap.kernels.shooting import N_FIELDS
from hertzmap.study.basin_entropy import BasinEntropy, scattered_basin_entropy
from hertzmap.study.orbit_rules import same_orbit
from hertzmap.study.solve.certificate import LevelHints, certify, orbit_points
from hertzmap.study.solve.point import shoot_seeds, solutions_from_rows
from hertzmap.study.solve.recognition import (NOTHING_KNOWN, OPEN_LEADERS, KnownAttractors,
                                              periodic_index, periodic_label)
from hertzmap.study.solve.seeds import TRANSIENT_BOX, initial_states, reach_box

#: The transients' integrator tolerance: looser than the shooting's (a transient is refined by
#: shooting at the study's rtol once it settles); the exponent and measures of a chaotic window
#: do not depend on it beyond their own statistical error.
TRANSIENT_RTOL = 1e-8
#: A cycle is detected when the stroboscopic points repeat to this (relative) over CYCLE_REPEATS
#: returns; shooting then confirms it at the study's rtol.
CYCLE_TOL = 1e-2
CYCLE_REPEATS = 3
#: Initial states whose transients always get the whole budget; when none of them settles, the
#: others get SCREEN_SHARE of it (a chaotic point's cost is in transients that never settle:
#: 4 + 12 x 0.2 budgets instead of 16).
FULL_BUDGET_STATES = 4
SCREEN_SHARE = 0.2
#: Periods the tangent vector is aligned for before Benettin's average starts.
LYAPUNOV_DISCARD = 16
#: Close returns searched for Newton seeds before a point is called non-periodic.
RECURRENCE_PERIODS = tuple(range(1, 9))
#: transients whose close returns are shot from
RECURRENCE_RUNS = 1
#: a return closer than this share of (1 + |x|) is a seed
RECURRENCE_SHARE = 0.2
#: the exponent is positive when above this many standard errors ...
LYAPUNOV_SIGMAS = 3.0
#: ... and the two halves of the window agree to this share of it
LYAPUNOV_HALVES_SHARE = 0.5
#: each longer pass of a point that did not settle runs this many times the last one
LONGER = 4
#: why a point is unsettled (``unsettled_reason``): its transients ran the study's
#: search.max_transient_periods without settling, or its search.point_steps ran out first
PERIOD_LIMIT = 1
WORK_BUDGET = 2
#: (not stored) a longer pass ended with none of its runs settled
QUIET = -1
#: the kinds of a neighbour's attractors a point's transients also start from (an unsettled
#: group is no attractor yet, a failed one none)
NEIGHBOUR_KINDS = ("periodic", "non_periodic")
#: transients stop once recognised on what the point's earlier ones found
#: (study.solve.recognition); off, every transient runs its budget (benchmarks compare both)
RECOGNITION = True
#: transients also start from the neighbouring points' attractors (``neighbour_starts``); off,
#: from the point's own states only (benchmarks compare both)
NEIGHBOUR_STARTS = True
#: transients stop once in a certified neighbourhood of a stable orbit the point knows
#: (study.solve.certificate), contracting there; off, only on the points of periodic attractors
#: the census's own runs found (benchmarks compare both)
CERTIFIED = True
#: a certificate's ladder starts at the rung nearest the last grid point's level of the same
#: orbit (study.solve.certificate.LevelHints: the same certificates for half the ring
#: evaluations); off, at rung 0 (benchmarks compare both)
LEVEL_HINTS = True
#: a stable orbit a run of the census finds is certified when more than this many of the
#: point's own runs are still to come
CERTIFY_AHEAD = 2
#: the longest period the census detects (kernels.attractors.M_MAX)
MAX_CYCLE = 16


@dataclass(eq=False)
class Attractor:
    """One attractor of a grid point: its kind, how many initial states reach it, its window's
    exponent and measures, and (periodic) its orbit."""

    kind: str
    count: int = 0
    orbit: dict | None = None
    row: np.ndarray | None = None            # the kernel row of a representative transient
    strobe: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    reason: int = 0                          # unsettled: why (PERIOD_LIMIT, WORK_BUDGET)
    # the initial states (q, q') whose transients end here (the point's basin entropy)
    states: list[tuple] = field(default_factory=list)

    @property
    def period(self) -> int:
        return int(self.orbit["period"]) if self.orbit is not None else 0


def is_chaotic(row: np.ndarray) -> bool:
    """The exponent of an attractor row is positive beyond LYAPUNOV_SIGMAS standard errors,
    and its window's two halves agree (module docstring)."""
    lam, err, halves = row[A["lyapunov"]], row[A["lyapunov_error"]], row[A["lyapunov_halves"]]
    return (math.isfinite(lam) and math.isfinite(err) and lam > 0.0
            and lam > LYAPUNOV_SIGMAS * err
            and (not math.isfinite(halves) or halves <= LYAPUNOV_HALVES_SHARE * lam))


def recurrence_seeds(strobe: np.ndarray, periods=RECURRENCE_PERIODS) -> list[tuple[int, tuple]]:
    """(m, x_k) for the closest return x_{k+m} ~ x_k of each m on a stroboscopic sequence,
    where it is closer than RECURRENCE_SHARE (1 + |x_k|)."""
    out = []
    for m in periods:
        if strobe.shape[0] <= m:
            break
        d = np.hypot(*(strobe[m:] - strobe[:-m]).T)
        k = int(np.argmin(d))
        if d[k] <= RECURRENCE_SHARE * (1.0 + float(np.hypot(*strobe[k]))):
            out.append((m, (float(strobe[k, 0]), float(strobe[k, 1]))))
    return out


def census(omega: float, sigma: float, zeta: float, orbits: list[dict], options: dict,
           n_states: int, transient_periods: int, record_periods: int,
           max_transient_periods: int | None = None, point_steps: int = 2_000_000,
           lyapunov_error: float | None = None,
           neighbour_starts=(), levels: LevelHints | None = None
           ) -> tuple[list[Attractor], list[dict]]:
    """The attractors at (omega, sigma, zeta) from ``n_states`` initial states, and the orbits
    the census found that ``orbits`` (the point's known orbits, not changed here) lacks.

    ``options``: the solver's (exponent, model, rtol, harmonics). Dimensionless inputs. A point
    whose transients did not settle and are not shown chaotic gets longer passes (module
    docstring, "Unsettled") up to ``max_transient_periods`` periods in all, within
    ``point_steps`` integration steps summed over its open transients. ``lyapunov_error``:
    the exponent's target standard error (window_exponent; None: one window).
    ``neighbour_starts``: states (q, q') on the neighbouring points' attractors
    (attractor_starts; module docstring, "Neighbours"). ``levels``: the last grid point's
    certified levels (study.solve.certificate.LevelHints), where the ladders of this point's
    certificates start; on return, this point's.
    """
    # half of the states where the largest known orbits go (long flights), when they leave
    # the fixed box
    states = np.array(initial_states(n_states, reach_box(
        [o for o in orbits if o["status"] == st.CONVERGED and o["period"] > 0])), float)
    k = states.shape[0]
    starts = np.asarray(neighbour_starts if NEIGHBOUR_STARTS else (), float).reshape(-1, 2)
    starts = starts[np.all(np.isfinite(starts), axis=1)]
    # runs 0..k-1 from the point's own states (they alone make the basin fractions), then one
    # from each neighbour start
    n = k + starts.shape[0]
    states = np.concatenate([states.reshape(-1, 2), starts])
    rows = np.empty((n, N_ATTRACTOR_FIELDS))
    orbit_rows = np.empty((n, N_FIELDS))
    # the whole record window's points (close returns are searched on them); the store keeps
    # the last STROBE_POINTS
    strobes = np.empty((n, int(record_periods), 2))

    known = list(orbits)
    new: list[dict] = []
    periodic: list[Attractor] = []
    # recognition (study.solve.recognition): what the point's earlier transients found; open
    # sets only while the point has no stable orbit; and the point's stable orbits known before
    # the census (shot by the grid's search, continued by the atlas), each in its certified
    # neighbourhood (study.solve.certificate): a transient that reaches one stops there
    recognised = KnownAttractors()
    certificates: dict[int, np.ndarray] = {}        # periodic attractor index -> its row

    def hint(orbit: dict) -> float | None:
        return levels.start(orbit) if levels is not None and LEVEL_HINTS else None

    first_run: dict[int, int] = {}                  # periodic attractor index -> a run on it
    if RECOGNITION and CERTIFIED:
        for orbit in (o for o in orbits if o["status"] == st.CONVERGED and o.get("stable")
                      and 0 < o["period"] <= MAX_CYCLE):
            pts = orbit_points(orbit, omega, sigma, zeta, options)
            if pts is None:
                continue
            row = certify(orbit, omega, sigma, zeta, options,
                          _other_points(orbits, orbit, pts, omega, sigma, zeta, options),
                          hint(orbit))
            if row is None:
                continue
            periodic.append(Attractor("periodic", orbit=orbit, strobe=pts))
            certificates[len(periodic) - 1] = row
            recognised.add_certified(periodic_label(len(periodic) - 1), row)
    follows: dict[int, int] = {}        # run -> the open set's label it was recognised on
    settled_on: dict[int, Attractor] = {}
    open_sets = [not has_stable_orbit(orbits)]
    # the first OPEN_LEADERS open runs keep their own evidence in the longer passes (each
    # samples the escape from the set: study.solve.recognition)
    leaders: list[int] = []

    def open_set(r) -> None:
        """Run r did not settle: its record window becomes a set later runs may be recognised
        on, once OPEN_LEADERS runs are open (their sets then all at once)."""
        if not (open_sets[0] and RECOGNITION):
            return
        if r in leaders or len(leaders) >= OPEN_LEADERS:
            recognised.add_open(r, strobe_points(strobes[r], rows[r]))
            return
        leaders.append(r)
        if len(leaders) == OPEN_LEADERS:
            for lead in leaders:
                recognised.add_open(lead, strobe_points(strobes[lead], rows[lead]))

    def count_with(a: Attractor, r: int) -> None:
        first_run.setdefault(next(i for i, b in enumerate(periodic) if b is a), r)
        if r < k:
            a.count += 1
            a.states.append(tuple(states[r]))

    def settle(r) -> bool:
        """Run r's transient ended on a stable orbit: count it with that orbit's attractor."""
        sol = solutions_from_rows(orbit_rows[r:r + 1], int(rows[r, A["period"]]))[0]
        sol["omega"] = omega
        if sol["status"] != st.CONVERGED:
            return False
        match = next((s for s in known if same_orbit(sol, s)), None)
        if match is None:
            known.append(sol)
            new.append(sol)
            match = sol
        a = next((a for a in periodic if a.orbit is match), None)
        if a is None:
            a = Attractor("periodic", orbit=match, row=rows[r].copy(),
                          strobe=strobe_points(strobes[r], rows[r]))
            periodic.append(a)
            m = a.period
            if RECOGNITION:
                recognised.add_periodic(periodic_label(len(periodic) - 1), a.strobe[-m:],
                                        CYCLE_TOL, (CYCLE_REPEATS + 1) * m)
                if CERTIFIED and k - r > CERTIFY_AHEAD:
                    # enough of the point's own runs are left for the certificate to pay
                    row = certify(match, omega, sigma, zeta, options, _other_points(
                        known, match, a.strobe[-m:], omega, sigma, zeta, options),
                        hint(match))
                    if row is not None:
                        certificates[len(periodic) - 1] = row
                        recognised.add_certified(periodic_label(len(periodic) - 1), row)
        elif a.row is None:
            # a certified orbit reached by detection before recognition: its window measures
            a.row = rows[r].copy()
        if open_sets[0]:
            # beside a stable orbit, chaos needs each transient's own evidence
            open_sets[0] = False
            recognised.remove_open()
        count_with(a, r)
        settled_on[r] = a
        return True

    def take(r) -> str:
        """Where run r's transient ended: "settled" (counted with a periodic attractor),
        "follows" (recognised on an open set), "open" or "failed"."""
        status = int(rows[r, A["status"]])
        if status == st.RECOGNISED:
            label = int(rows[r, A["recognised_as"]])
            if label < 0:
                a = periodic[periodic_index(label)]
                count_with(a, r)
                settled_on[r] = a
                return "settled"
            follows[r] = label
            return "follows"
        if status == st.CONVERGED and settle(r):
            return "settled"
        if status in (st.CONVERGED, st.UNSETTLED, st.UNCONFIRMED):
            open_set(r)
            return "open"
        return "failed"

    def transient(r, budget, start=None, known=None) -> None:
        """Run r's transient for ``budget`` periods from its initial state, or on from
        ``start`` (its periods_run and steps then add to those so far); recognised on
        ``known`` (every set of it) instead of the point's running recognition."""
        before = rows[r].copy() if start is not None else None
        q, v = start if start is not None else states[r]
        run_transients(omega, sigma, zeta, np.array([q], float), np.array([v], float), options,
                       budget, record_periods, rows[r:r + 1], orbit_rows[r:r + 1],
                       strobes[r:r + 1], recognised if known is None else known, own_label=r,
                       open_sets=known is not None or (start is not None and r not in leaders))
        if before is not None:
            rows[r, A["periods_run"]] += before[A["periods_run"]]
            rows[r, A["steps"]] += before[A["steps"]]

    first = min(k, FULL_BUDGET_STATES)
    outcome = {}
    for r in range(first):
        transient(r, transient_periods)
        outcome[r] = take(r)
    # None of the first states settled within the whole budget: the point is held by a motion
    # that does not repeat. The others only screen for a periodic attractor with a quick
    # transient beside it; one that has not settled by then joins the unsettled ones.
    rest_budget = transient_periods if "settled" in outcome.values() else max(
        10, int(transient_periods * SCREEN_SHARE))
    for r in range(first, k):
        transient(r, rest_budget)
        outcome[r] = take(r)
    if n > k:
        # from the neighbours' attractors, recognised on everything the own runs found: one
        # that is here too stops within a few periods and adds nothing; one whose basin none
        # of the own states fell in is found (a stable orbit, or a motion the passes below
        # show chaotic)
        here = KnownAttractors()

        def know_periodic(first_index: int) -> None:
            for index, a in enumerate(periodic[first_index:], first_index):
                # fewer periods than the detection's (CYCLE_REPEATS + 1) m: a run that is
                # next to the orbit from its start stops before its detection and Newton
                here.add_periodic(periodic_label(index), a.strobe[-a.period:], CYCLE_TOL,
                                  CYCLE_REPEATS * a.period)
                if index in certificates:
                    here.add_certified(periodic_label(index), certificates[index])

        know_periodic(0)
        own_open = [r for r in range(k) if outcome[r] == "open"]
        if own_open:
            # one set of all their points (its tolerance from their joint spacing): a run's
            # visits count on one label, and the own runs' sets are most often the same set,
            # its points spread over their labels
            here.add_open(own_open[0], np.concatenate([strobe_points(strobes[r], rows[r])
                                                       for r in own_open]))
        for r in range(k, n):
            known_before = len(periodic)
            transient(r, transient_periods, known=here)
            if int(rows[r, A["status"]]) == st.RECOGNISED:
                label = int(rows[r, A["recognised_as"]])
                if label < 0:
                    # a periodic attractor: one of the own runs', or a certified orbit of the
                    # point that none of them reached (reached now, with no basin)
                    count_with(periodic[periodic_index(label)], r)
                outcome[r] = "known"
            else:
                outcome[r] = take(r)
            know_periodic(known_before)
            if outcome[r] == "open":
                here.add_open(r, strobe_points(strobes[r], rows[r]))
    open_runs = [r for r in range(n) if outcome[r] == "open"]
    failed = [r for r in range(k) if outcome[r] == "failed"]

    def detach() -> list[int]:
        """The point has a stable orbit: the runs recognised on an open set become open runs
        of their own (each needs its own evidence, module docstring); returns them."""
        runs = sorted(follows)
        follows.clear()
        recognised.remove_open()
        open_sets[0] = False
        return runs

    def representative(runs, window=int(record_periods)):
        """The run with the longest record window, its exponent by Benettin over ``window``
        periods from its last state."""
        rep = max(runs, key=lambda r: (np.nan_to_num(rows[r, A["window_periods"]]), -r))
        return rep, window_exponent(omega, sigma, zeta, (rows[rep, A["q_end"]],
                                                         rows[rep, A["v_end"]]),
                                    options, window, rows[rep], lyapunov_error,
                                    int(max_transient_periods or transient_periods))

    left = [float(point_steps)]
    budget = [int(transient_periods)]
    behind: dict[int, int] = {}         # detached run -> periods it is behind the others

    def longer_passes(runs, limit, until_quiet=False):
        """Continue the runs that did not settle from their last states, each pass LONGER
        times the last, until they settle, ``limit`` periods are run in all (PERIOD_LIMIT), or
        the point's work budget is spent (WORK_BUDGET); ``until_quiet``: or a pass ends in
        which no run settled (QUIET). A run recognised on another's open set leaves the passes
        and shares that set's fate, until a run reaches a stable orbit (then it goes on, and
        first catches up). Returns the runs still open and why."""
        run_so_far = float(np.nanmax(rows[runs, A["periods_run"]]))
        while True:
            if run_so_far >= limit:
                return runs, PERIOD_LIMIT
            # a pass the point's work budget still affords, at the steps per period its runs
            # took so far (steps, not seconds: the same block gives the same arrays on any
            # worker, loaded or not)
            per_period = max(float(np.nanmax(rows[runs, A["steps"]] / rows[runs, A["periods_run"]])),
                             1.0)
            affordable = int(left[0] / (len(runs) * per_period)) - record_periods
            if affordable < transient_periods:
                return runs, WORK_BUDGET
            budget[0] = int(min(LONGER * budget[0], limit - run_so_far, affordable))
            still, settled_now = [], 0
            for r in runs:
                steps_before = rows[r, A["steps"]]
                transient(r, budget[0] + behind.pop(r, 0),
                          (rows[r, A["q_end"]], rows[r, A["v_end"]]))
                left[0] -= float(np.nan_to_num(rows[r, A["steps"]] - steps_before))
                recognised.remove(r)
                outcome = take(r)
                settled_now += outcome == "settled"
                if outcome in ("open", "failed"):
                    still.append(r)
            run_so_far = float(np.nanmax(rows[runs, A["periods_run"]]))
            if follows and has_stable_orbit(known):
                # a run escaped from an open set to a stable orbit: the runs recognised on
                # the set go on with their own evidence, first catching up with the periods
                # the others ran (each samples the escape as long as it would have)
                detached = detach()
                for r in detached:
                    behind[r] = max(0, int(run_so_far - rows[r, A["periods_run"]]))
                still = sorted(still + detached)
            if not still:
                return still, 0
            if until_quiet and not settled_now:
                return still, QUIET
            runs = still

    others: list[Attractor] = []
    if open_runs:
        # (no run follows an open set yet: they are recognised in the longer passes only)
        has_stable = has_stable_orbit(known)
        if not has_stable:
            # close returns of an unsettled transient: Newton seeds of orbits it passes near
            # (from one of them: a second found the same stable orbits on the vibro-impact
            # scene's lines and cost as much again)
            for r in open_runs[:RECURRENCE_RUNS]:
                strobe = strobe_points(strobes[r], rows[r])
                for m, x in recurrence_seeds(strobe):
                    for sol in shoot_seeds(omega, sigma, zeta, m, [x],
                                           dict(options, max_iter=15)):
                        if sol["status"] == st.CONVERGED and not any(
                                same_orbit(sol, s) for s in known):
                            sol["omega"] = omega
                            known.append(sol)
                            new.append(sol)
            has_stable = has_stable_orbit(known)
        rep, row = representative(open_runs)
        chaotic = (not has_stable) and is_chaotic(row) and any(
            int(rows[r, A["status"]]) == st.UNSETTLED for r in open_runs)
        reason = 0
        limit = int(max_transient_periods or transient_periods)
        if not chaotic and limit > transient_periods:
            open_runs, reason = longer_passes(open_runs, limit, until_quiet=has_stable)
            if open_runs:
                rep, row = representative(open_runs, LONGER * int(record_periods))
                # a motion that still does not repeat, with a positive exponent over a longer
                # window: chaotic where no stable orbit is known; beside one, once a longer
                # pass ended with none of the runs escaping to it (a chaotic transient leaks
                # runs to the orbit: its lifetime is then beyond runs x pass periods) or after
                # the longest transients allowed
                chaotic = (not has_stable or reason in (QUIET, PERIOD_LIMIT)) and is_chaotic(
                    row) and any(int(rows[r, A["status"]]) == st.UNSETTLED for r in open_runs)
                if reason == QUIET and not chaotic:
                    # quiet but not chaotic (a long period, a slow drift): longer still
                    open_runs, reason = longer_passes(open_runs, limit)
                    if open_runs:
                        rep, row = representative(open_runs, LONGER * int(record_periods))
                        chaotic = reason == PERIOD_LIMIT and is_chaotic(row) and any(
                            int(rows[r, A["status"]]) == st.UNSETTLED for r in open_runs)
        # a run recognised on an open set shares the fate of that set's transient
        attached = []
        for r, label in sorted(follows.items()):
            while label in follows:
                label = follows[label]
            if label in settled_on:
                count_with(settled_on[label], r)
            else:
                attached.append(r)
        runs = [r for r in sorted(open_runs + attached) if r < k]
        # open runs from neighbour starts alone: an attractor only once shown chaotic (their
        # motion says nothing of the point's own states otherwise)
        if open_runs and (runs or chaotic):
            others.append(Attractor("non_periodic" if chaotic else "unsettled",
                                    count=len(runs), row=row,
                                    strobe=strobe_points(strobes[rep], rows[rep]),
                                    reason=0 if chaotic else reason,
                                    states=[tuple(states[r]) for r in runs]))
    if failed:
        others.append(Attractor("failed", count=len(failed), row=rows[failed[0]].copy(),
                                states=[tuple(states[r]) for r in failed]))
    # the certified orbits known before the census are attractors of it where a run reached
    # them; their window measures (as a settled run's: one period of the orbit, at the
    # study's rtol) from a run started on the orbit, their periods run a run's that reached
    # them
    reached = [a for index, a in enumerate(periodic) if index in first_run]
    for index, a in enumerate(periodic):
        if index in first_run and a.row is None:
            a.row, a.strobe = orbit_window(omega, sigma, zeta, a, options, record_periods)
            a.row[A["periods_run"]] = rows[first_run[index], A["periods_run"]]
    # largest basin first (every one is stored: study.solve.point_state)
    found = sorted(reached, key=lambda a: -a.count) + sorted(others, key=lambda a: -a.count)
    found.sort(key=lambda a: -a.count)
    if levels is not None:
        levels.keep(certificates.values())
    return found, new


def _other_points(orbits, orbit, points, omega, sigma, zeta, options) -> np.ndarray:
    """The points a certified neighbourhood of ``orbit`` (its stroboscopic ``points``) keeps
    clear of: its other phases and the start points of the point's other orbits."""
    xs = [np.asarray(points[1:], float).reshape(-1, 2)]
    xs += [np.asarray(o["x0"], float).reshape(1, 2) for o in orbits
           if o is not orbit and o["status"] == st.CONVERGED]
    return np.concatenate(xs)


def orbit_window(omega, sigma, zeta, a: Attractor, options: dict, record_periods: int
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The row and stroboscopic points of a run started on a certified orbit's start point:
    its detection, shooting and measures over one period of the orbit, as a run that settled
    on it (run_transients)."""
    m = a.period
    x0 = np.asarray(a.orbit["x0"], float)
    rows = np.empty((1, N_ATTRACTOR_FIELDS))
    orbit_rows = np.empty((1, N_FIELDS))
    strobes = np.empty((1, int(record_periods), 2))
    run_transients(omega, sigma, zeta, x0[:1], x0[1:], options, (CYCLE_REPEATS + 2) * m + 16,
                   record_periods, rows, orbit_rows, strobes)
    return rows[0], strobe_points(strobes[0], rows[0])


def attractor_starts(found: list[Attractor]) -> list[tuple[float, float]]:
    """States on each periodic or chaotic attractor of a census: the neighbour starts of the
    points next to it (module docstring, "Neighbours"). A chaotic attractor's last
    stroboscopic point; each of a periodic attractor's m points (its m phases: next door, an
    orbit's basin may take some of its phases and not others; measured on the default scene,
    omega 0.7, sigma 0.95: of a 3T orbit's phases at the neighbouring point, one starts on the
    3T orbit there, two on the 1T orbit)."""
    out = []
    for a in found:
        if a.kind in NEIGHBOUR_KINDS and a.strobe.shape[0]:
            m = max(1, a.period) if a.kind == "periodic" else 1
            out += [(float(q), float(v)) for q, v in a.strobe[-m:]]
    return out


def has_stable_orbit(orbits: list[dict]) -> bool:
    """A converged stable orbit is among ``orbits``: the point's transients that did not settle
    are then "unsettled", never "non_periodic" (module docstring)."""
    return any(s["stable"] and s["status"] == st.CONVERGED for s in orbits)


def first_pass_only(periods_run, transient_periods: int, record_periods: int):
    """An attractor's transients (``periods_run``, scalar or array) ran their first pass only:
    no longer pass tested them."""
    return periods_run <= int(transient_periods) + int(record_periods)


def needs_second_census(found: list[Attractor], orbits: list[dict], transient_periods: int,
                        record_periods: int) -> bool:
    """A census result that called transients chaotic after their first pass (no stable orbit
    was known then) at a point that now has a stable orbit (a trace from a later point of the
    line, or the atlas, found one): the census must run again, knowing it (module docstring:
    beside a stable orbit, chaos needs the longer passes' evidence)."""
    return has_stable_orbit(orbits) and any(
        a.kind == "non_periodic" and first_pass_only(a.row[A["periods_run"]], transient_periods,
                                                     record_periods) for a in found)


def transient_settings(options: dict) -> tuple[float, object, float, float]:
    """(exponent, contact law, the transients' rtol, the shooting's rtol) of the solver's
    options (exponent, model, rtol)."""
    model = Model.of(options)
    return model.exponent, model.code, max(TRANSIENT_RTOL, model.rtol), model.rtol


def run_transients(omega, sigma, zeta, q0, v0, options: dict, budget: int,
                   record_periods: int, rows, orbit_rows, strobes,
                   known: KnownAttractors = NOTHING_KNOWN, own_label: int = NO_LABEL,
                   open_sets: bool = True) -> None:
    """Transients from the states (q0, v0) for ``budget`` periods, then a record window of
    ``record_periods``, into the kernel's rows, refined orbit rows and stroboscopic points
    (kernels.attractors.attractor_batch_into), with the census's detection settings; without
    the tangent integration (2-D: a third of the work: the exponent of the runs that do not
    settle is computed once, from one of them: window_exponent). A transient stops once it is
    recognised on one of the ``known`` attractors not labelled ``own_label`` (the periodic
    ones only, without ``open_sets``; study.solve.recognition)."""
    n_exp, model, t_rtol, rtol = transient_settings(options)
    attractor_batch_into(float(omega), float(sigma), float(zeta), np.ascontiguousarray(q0),
                         np.ascontiguousarray(v0), n_exp, model, int(budget),
                         int(record_periods), False, 0, 0, CYCLE_TOL, CYCLE_REPEATS, t_rtol,
                         t_rtol, rtol, 200_000, bool(options.get("harmonics", True)),
                         *known.arrays(open_sets), int(own_label), rows, orbit_rows, strobes)


def window_exponent(omega, sigma, zeta, end, options: dict, window: int,
                    row: np.ndarray, error_target: float | None = None,
                    max_periods: int | None = None) -> np.ndarray:
    """A copy of the attractor ``row`` holding the largest Lyapunov exponent by Benettin over
    ``window`` periods from the state ``end`` (q, q') (its error, the halves' difference and
    the periods, where the kernel converged).

    With ``error_target`` (per unit tau), windows follow one another along the trajectory, the
    window doubling the periods so far each time, until the standard error of the combined
    estimate is at most the target or ``max_periods`` periods are averaged: the exponent is the
    periods-weighted mean of the windows' estimates, its error their errors combined as
    independent (each window's own error is over 8 blocks), the halves' difference that of the
    last window against those before it (the first window's own, with one window)."""
    n_exp, model, t_rtol, _ = transient_settings(options)
    column = {name: LYAPUNOV_FIELDS.index(name) for name in LYAPUNOV_FIELDS}
    lyap = np.empty(N_LYAPUNOV_FIELDS)
    state = (float(end[0]), float(end[1]))
    windows = []                    # (exponent, error, periods, halves)
    chunk = int(window)
    cap = int(max_periods or window)
    while True:
        lyapunov_into(float(omega), float(sigma), float(zeta), state[0], state[1], n_exp, model,
                      chunk, LYAPUNOV_DISCARD, t_rtol, t_rtol, 200_000, lyap)
        if int(lyap[column["status"]]) != st.CONVERGED:
            break
        windows.append(tuple(float(lyap[column[n]]) for n in
                             ("lyapunov", "lyapunov_error", "periods", "lyapunov_halves")))
        state = (float(lyap[column["q_end"]]), float(lyap[column["v_end"]]))
        _, error, total = _combined(windows)
        if error_target is None or not math.isfinite(error) or error <= error_target \
                or total >= cap:
            break
        chunk = int(min(total, cap - total))
    row = np.array(row, float)
    if len(windows) == 1:
        (row[A["lyapunov"]], row[A["lyapunov_error"]], row[A["lyapunov_periods"]],
         row[A["lyapunov_halves"]]) = windows[0]
    elif windows:
        row[A["lyapunov"]], row[A["lyapunov_error"]], row[A["lyapunov_periods"]] = \
            _combined(windows)
        row[A["lyapunov_halves"]] = abs(windows[-1][0] - _combined(windows[:-1])[0])
    return row


def _combined(windows) -> tuple[float, float, float]:
    """(exponent, standard error, periods) of consecutive Benettin windows (exponent, error,
    periods, ...): the periods-weighted mean, the errors combined as independent."""
    total = sum(w[2] for w in windows)
    return (sum(w[0] * w[2] for w in windows) / total,
            math.sqrt(sum((w[1] * w[2]) ** 2 for w in windows)) / total, total)


def strobe_points(strobe: np.ndarray, row: np.ndarray) -> np.ndarray:
    """The stroboscopic points a transient's row says it recorded, of its ``strobe`` array."""
    n = int(np.nan_to_num(row[A["strobe_count"]]))
    return np.array(strobe[:min(n, strobe.shape[0])])


def census_basin_entropy(found: list[Attractor]) -> BasinEntropy:
    """The basin entropy of a census's initial states in TRANSIENT_BOX (those of a reach box
    sample another density and are left out), each labelled by the attractor its transient
    reached, the box cut into cells of about STATES_PER_BOX states
    (study.basin_entropy.scattered_basin_entropy)."""
    pts = [x for a in found for x in a.states]
    labels = np.array([n for n, a in enumerate(found) for _ in a.states], int)
    pts = np.array(pts, float).reshape(-1, 2)
    (q0, q1), (v0, v1) = TRANSIENT_BOX
    inside = (pts[:, 0] >= q0) & (pts[:, 0] <= q1) & (pts[:, 1] >= v0) & (pts[:, 1] <= v1)
    return scattered_basin_entropy(pts[inside], labels[inside], TRANSIENT_BOX)
