"""What a lab measures: a stepped-sine sweep, up or down one parameter, with its jumps.

Paper Eq. 7 (dimensionless, n = 3/2 by default):

    q'' + 2 zeta q' + F(q) = 1 + sigma cos(omega tau),   F(q) = (1 + q/n)^n (q >= -n), 0 below,

with q = n (z - z_s) / z_s, tau = Omega t, omega = excitation frequency / Omega, sigma = force
amplitude / static load N, zeta = damping ratio. Everything here is dimensionless.

A test rig steps one parameter (omega or sigma; zeta is accepted too) through a list of values
and at each value waits for the response to settle before reading it. :func:`stepped_sweep`
does the same on the stroboscopic map (kernels.api.attractor):

* **Steps.** The motion at step k starts from the state (q, q') at tau = 0 mod T (T = 2 pi /
  omega) where step k - 1 ended: the refined orbit's start point when that step settled on a
  periodic orbit, the transient's last stroboscopic point otherwise (the first step starts from
  ``x0``). It runs for at most ``settle_periods`` + ``record_periods`` forcing periods; where
  its stroboscopic points repeat with a period m <= 16 and Newton shooting (kernels' ``shoot``)
  confirms a stable orbit there, that orbit is the step's attractor: its period, start point,
  Floquet multipliers, min q / max q, loss of contact and contact-force harmonics are recorded.
  Otherwise the step is recorded as not periodic (status UNSETTLED / UNCONFIRMED, measures over
  the record window), unless it is still approaching the branch it followed (below).
* **Which branch.** Step k + 1 is on step k's branch when the attractor reached at step k + 1
  is, by the identity rule (study.orbit_rules.same_orbit, compared at the same parameter
  point), the orbit that step k's orbit continues into there: Newton shooting of step k's
  period from step k's orbit (in ``FOLLOW_SUBSTEPS`` substeps when a direct shot does not give
  it), each shot checked by its round trip (shooting back at the value it came from must give
  the orbit it started from: past a fold, Newton from the branch's last orbit can land on a
  coexisting orbit of the same period, which the transient may reach too). Near a fold or a flip the followed orbit's multiplier nearest the unit circle makes the
  transient settle in ~1 / (1 - |mu|) periods, beyond any budget at 1e-6 from the bifurcation
  (critical slowing down): a transient that has not settled on anything within the budget is
  still on the branch when the branch's orbit there is stable and the transient ended no
  farther from it than it started (verdict APPROACHING; the step then carries that orbit, with
  settled False). Otherwise (it settled on another attractor, or the branch's orbit is gone or
  unstable, or the transient moved away) there is a **jump** between the two steps.
* **Jumps located.** A jump after a step with an orbit is bracketed between the last value
  where the followed branch still attracts and the first where it no longer does, and the
  bracket is halved until it is at most ``jump_tol`` wide: each probe is a transient started
  from the followed orbit at the bracket's attracting end (the state the sweep arrived with,
  carried along the branch as a slow sweep would: the quasi-static limit of the rig's sweep),
  judged by the same rule. The jump is where the followed branch ceases to attract: a fold (a
  real Floquet multiplier of the followed orbit -> +1, the orbit disappears; also when the
  multipliers at the bracket's attracting end are near neither but the followed orbit no
  longer exists at its far end, as past a grazing, where they run to +1 within 1e-6), a flip (-> -1,
  the orbit loses stability to a period-doubled response) or, when the multipliers at the
  bracket's attracting end are near neither, a "loss" (e.g. a complex pair crossing the unit
  circle; or, with ``before`` at the step after the jump itself, the step's own jump crossed
  a basin boundary: the state the rig arrived with lies outside the basin of the branch's orbit
  there, which a slower sweep would have kept). A jump after a step without an orbit is not located
  (there is no branch to follow): kind "unlocated", bracket = the two steps.

A rig's other way to sweep, the swept sine at a finite rate, is study.solve.swept_sine.

Pure: numpy and the kernels' Python API; dataclasses out. No I/O, no Dask, no xarray.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hertzmap.kernels import api
from hertzmap.kernels import status as st
from hertzmap.kernels.api import Attractor, Orbit
from hertzmap.kernels.model import DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL
from hertzmap.kernels.records import N_HARMONICS
from hertzmap.study.orbit_rules import class_code, same_orbit

__all__ = ["AXES", "DIRECTIONS", "FOLLOW_SUBSTEPS", "JUMP_KINDS", "Jump", "Step", "Sweep",
           "force_components", "jump_kind", "stepped_sweep"]

#: The parameters a sweep can step (the other two are held fixed).
AXES = ("omega", "sigma", "zeta")
DIRECTIONS = ("up", "down")
#: fold: a real multiplier -> +1; flip: -> -1; loss: neither; unlocated: after a non-periodic step
JUMP_KINDS = ("fold", "flip", "loss", "unlocated")
#: Substeps of the Newton continuation of a branch over one step, when a direct shot from the
#: previous orbit does not give the attractor reached (a guess one whole step away can converge
#: to another orbit of the same period near a fold).
FOLLOW_SUBSTEPS = 4
#: Verdicts on a transient at a step or a probe (_Sweeper.judge): it left the followed branch;
#: it settled on the branch's orbit; it did not settle within the budget but is approaching
#: the branch's orbit, which is stable there (critical slowing down near a fold or a flip).
OFF, SETTLED_ON, APPROACHING = 0, 1, 2
VERDICTS = {OFF: "off", SETTLED_ON: "settled_on", APPROACHING: "approaching"}
#: Default distance of a multiplier to +1 / -1 that names a jump a fold / flip, for jump_tol up
#: to 4e-6: at a bracket end a distance d from a fold the multiplier is ~ 1 - c sqrt(d) (c ~ 3
#: at the 2T fold of paper Fig. 6: 2.6e-3 at d = 6e-7); at a flip it is ~ -1 + c' d. Wider
#: brackets: 10 sqrt(jump_tol).
KIND_TOL = 0.02
#: A transient that ends within this distance of the followed orbit's stroboscopic points,
#: relative to (1 + their size), counts as approaching it however near it started (below it,
#: the comparison with the start would be one of integration noise: the transients run at
#: rtol 1e-8 over up to ~1e3 periods).
APPROACH_FLOOR = 1e-4


@dataclass(frozen=True)
class Step:
    """One step of the sweep: the response at one value of the swept parameter (dimensionless).

    value: the swept parameter; omega, sigma, zeta: the point (paper Eq. 7).
    start: (q, q') at tau = 0 the transient started from; end: the state handed to the next
    step, on the section tau = 0 mod T (the orbit's start point when the step settled, else
    the transient's last stroboscopic point).
    status: kernels.status code of the transient (CONVERGED: it settled on a stable periodic
    orbit; UNSETTLED / UNCONFIRMED: not within settle_periods + record_periods periods).
    settled: status is CONVERGED. period: the orbit's period m in forcing periods T = 2 pi /
    omega (0: no orbit). periods_run: forcing periods integrated (until it settled, or the
    whole budget).
    orbit: the stable periodic orbit of the step (kernels.Orbit, refined by Newton shooting:
    every field of kernels.records.ORBIT): the one the transient settled on; or, for a step
    that did not settle, the orbit of the followed branch when the transient was still
    approaching it, stable, as the budget ran out (settled False, see the module docstring);
    None otherwise (not periodic). multipliers: its two Floquet multipliers over m T; stable:
    both inside the unit circle. min_q, max_q, ptp: extremes of q over the orbit (over the
    record window when there is none); loses_contact: min q <= -n (q = -n is where contact is
    lost). force_harmonics: amplitudes of the contact force F/N (in units of the static load)
    at k omega / m, k = 1..4; rms_force: its rms over the orbit (NaN when there is none).
    class_code: study.orbit_rules class of the orbit (0: none). branch: index of the branch the
    step is on (it changes at every jump and after every step without an orbit).
    attractor: the kernels' full record of the step's transient (kernels.api.Attractor; None
    for a step reached by continuation without a transient, stepped_sweep's follow_first).
    """

    value: float
    omega: float
    sigma: float
    zeta: float
    start: np.ndarray
    end: np.ndarray
    status: int
    settled: bool
    period: int
    periods_run: int
    orbit: Orbit | None
    multipliers: np.ndarray
    stable: bool
    min_q: float
    max_q: float
    ptp: float
    loses_contact: bool
    force_harmonics: np.ndarray
    rms_force: float
    class_code: int
    branch: int
    attractor: Attractor | None = field(repr=False)

    @property
    def periodic(self) -> bool:
        """The step has a stable periodic orbit (settled on it, or approaching it)."""
        return self.orbit is not None

    @property
    def status_name(self) -> str:
        return st.NAMES[self.status]


@dataclass(frozen=True)
class Jump:
    """Where consecutive steps are on different attractors, located in the swept parameter.

    value: the jump's location, the middle of the final bracket; accuracy: the bracket's width
    |after - before| (value is within accuracy / 2 of the point where the followed branch
    ceases to attract). before: the last value, in the sweep's direction, where the followed
    branch still attracted (a probe started on it settled back on it, or was approaching it,
    stable, when its budget ran out); after: the first where it no longer did. located: False
    for a jump after a step without an orbit (bracket = the two steps, not halved).
    kind: "fold" (a real multiplier of the followed orbit at ``before`` within kind_tol of +1,
    or neither near +1 nor -1 and the followed orbit gone at ``after``), "flip" (within
    kind_tol of -1), "loss" (neither, and the followed orbit still there at ``after``),
    "unlocated".
    from_period / to_period: the period m of the attractor left / landed on (0: not periodic).
    from_orbit: the followed orbit at ``before`` (refined by shooting); multipliers: its
    Floquet multipliers; margin: the distance to +1 (fold) or -1 (flip) of the multiplier
    that names the kind (for "loss": the smallest distance of a multiplier to +1 or -1).
    to_step: the step after the jump (what the sweep landed on); step_index: its index in
    Sweep.steps. probe_log: (probes, 3) rows (value, kernels.status of the probe's transient,
    verdict: 0 off the branch, 1 settled on it, 2 approaching it) in the order run.
    """

    value: float
    accuracy: float
    before: float
    after: float
    located: bool
    kind: str
    from_period: int
    to_period: int
    from_orbit: Orbit | None
    multipliers: np.ndarray
    margin: float
    to_step: Step = field(repr=False)
    step_index: int
    probe_log: np.ndarray = field(repr=False)

    @property
    def probes(self) -> int:
        """Bisection transients run to locate the jump."""
        return int(self.probe_log.shape[0])


@dataclass(frozen=True)
class Sweep:
    """A stepped-sine sweep (see the module docstring): steps in the order swept, the jumps
    between them, and what it cost.

    axis: the swept parameter; direction: "up" or "down"; fixed: the other parameters;
    values: the swept values in sweep order. probes: bisection transients in all; seconds: wall
    time of the whole sweep. settings: the options it ran with.
    """

    axis: str
    direction: str
    fixed: dict[str, float]
    values: np.ndarray
    steps: tuple[Step, ...]
    jumps: tuple[Jump, ...]
    probes: int
    seconds: float
    settings: dict[str, Any] = field(default_factory=dict, repr=False)

    def arrays(self) -> dict[str, np.ndarray]:
        """Per-step arrays (sweep order): value, period, status, settled, stable, min_q, max_q, ptp,
        loses_contact, rms_force, class_code, branch, periods_run; force_harmonics (steps, 4);
        q0, v0 (the orbit's start point; NaN when not periodic)."""
        s = self.steps
        out = {name: np.array([getattr(x, name) for x in s])
               for name in ("value", "period", "status", "settled", "stable", "min_q",
                            "max_q", "ptp", "loses_contact", "rms_force", "class_code",
                            "branch", "periods_run")}
        out["force_harmonics"] = np.array([x.force_harmonics for x in s]).reshape(len(s), -1)
        out["q0"] = np.array([x.orbit.q0 if x.orbit is not None else np.nan for x in s])
        out["v0"] = np.array([x.orbit.v0 if x.orbit is not None else np.nan for x in s])
        return out


# ---- the rules ---------------------------------------------------------------------------------

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


def jump_kind(multipliers, kind_tol: float) -> tuple[str, float]:
    """(kind, margin) of a branch's end from its orbit's Floquet multipliers near the end: "fold"
    when a real multiplier is within ``kind_tol`` of +1, "flip" within kind_tol of -1 (the
    nearer one when both), else "loss"; margin is that multiplier's distance to +1 / -1 (for
    "loss": the smallest distance of any multiplier to +1 or -1)."""
    mu = np.asarray(multipliers, complex)
    real = mu[np.abs(mu.imag) <= 1e-12 * (1.0 + np.abs(mu.real))].real
    d_fold = float(np.min(np.abs(real - 1.0))) if real.size else math.inf
    d_flip = float(np.min(np.abs(real + 1.0))) if real.size else math.inf
    if min(d_fold, d_flip) <= kind_tol:
        return ("fold", d_fold) if d_fold <= d_flip else ("flip", d_flip)
    if not np.all(np.isfinite(mu)):
        return "loss", math.nan
    return "loss", float(min(np.min(np.abs(mu - 1.0)), np.min(np.abs(mu + 1.0))))


def _is_orbit_of_period(o: Orbit | None) -> bool:
    """A converged solve whose minimal period is its period (a 2T solve that landed on the 1T
    orbit is not a 2T orbit)."""
    return o is not None and o.converged and o.minimal_period == o.period


class _Sweeper:
    """The state of one sweep: the point's fixed parameters, the options, the counters."""

    def __init__(self, axis, fixed, *, exponent, model, rtol, transient_rtol, settle_periods,
                 record_periods, cycle_tol, lyapunov, jump_tol, kind_tol, follow_first=False):
        self.axis = axis
        self.follow_first = follow_first
        self.fixed = fixed
        self.exponent = exponent
        self.model = model
        self.rtol = rtol
        self.transient_rtol = transient_rtol
        self.settle_periods = settle_periods
        self.record_periods = record_periods
        self.cycle_tol = cycle_tol
        self.lyapunov = lyapunov
        self.jump_tol = jump_tol
        self.kind_tol = kind_tol
        self.probes = 0
        self.shoots = 0

    def point(self, value: float) -> tuple[float, float, float]:
        p = dict(self.fixed)
        p[self.axis] = float(value)
        return p["omega"], p["sigma"], p["zeta"]

    def settle(self, value: float, x) -> Attractor:
        """The transient from x (tau = 0) at the swept value: kernels.api.attractor."""
        omega, sigma, zeta = self.point(value)
        return api.attractor(omega, sigma, zeta, x, transient_periods=self.settle_periods,
                             record_periods=self.record_periods, lyapunov=self.lyapunov,
                             cycle_tol=self.cycle_tol, exponent=self.exponent, model=self.model,
                             rtol=self.transient_rtol, shoot_rtol=self.rtol)

    def shoot(self, value: float, period: int, guess) -> Orbit:
        omega, sigma, zeta = self.point(value)
        self.shoots += 1
        return api.shoot(omega, sigma, zeta, period, guess, exponent=self.exponent,
                         model=self.model, rtol=self.rtol)

    def follow(self, orbit: Orbit, v_from: float, v_to: float, substeps: int) -> Orbit | None:
        """The orbit ``orbit`` (at v_from) continues into at v_to: Newton shooting of its period
        from it, in ``substeps`` equal steps; None when a substep fails, lands on an orbit of a
        shorter period, or lands on another branch: each substep's orbit must shoot back onto
        the orbit it started from (the round trip, :meth:`returns`)."""
        prev, v_prev = orbit, v_from
        o = None
        for j in range(1, substeps + 1):
            v = v_to if j == substeps else v_from + (v_to - v_from) * j / substeps
            o = self.shoot(v, orbit.period, prev.x0)
            if not _is_orbit_of_period(o) or not self.returns(o, prev, v_prev):
                return None
            prev, v_prev = o, v
        return o

    def returns(self, o: Orbit, prev: Orbit, v_prev: float) -> bool:
        """The round trip of a continuation step: Newton shooting at v_prev from ``o`` gives
        ``prev`` back (study.orbit_rules.same_orbit). Past a fold, Newton from the branch's
        last orbit can converge to another stable orbit of the same period (a coexisting
        branch); that orbit exists at v_prev too, and shooting back lands on it, not on
        ``prev``: the step left the branch."""
        back = self.shoot(v_prev, prev.period, o.x0)
        return _is_orbit_of_period(back) and same_orbit(back, prev)

    def continues(self, orbit: Orbit, v_from: float, v_to: float,
                  att: Attractor) -> tuple[bool, Orbit | None]:
        """(does the attractor ``att`` at v_to lie on ``orbit``'s branch, the branch's orbit at
        v_to or None): the identity rule between att's orbit and the branch continued into
        v_to (directly, then in FOLLOW_SUBSTEPS substeps when the direct shot fails or gives
        another orbit than a periodic att of the same period).

        An attractor of period k m (k > 1) for a branch of period m is the branch's orbit when
        shooting period m from its start point gives the branch's orbit, stable: next to a flip
        (a multiplier ~ -1) the transient's points repeat with period 2m before they do with m,
        and the 2m solve (its Jacobian M^2 - I near singular) stops ~1e-7 off the m orbit, which
        the kernel's minimal-period test then calls a 2m orbit."""
        m = orbit.period
        followed = self.follow(orbit, v_from, v_to, 1)
        periodic = att.periodic and att.orbit is not None
        same_period = periodic and att.period == m
        multiple = periodic and att.period > m and att.period % m == 0
        if same_period and followed is not None and same_orbit(att.orbit, followed):
            return True, followed
        if followed is None or same_period or multiple:
            followed = self.follow(orbit, v_from, v_to, FOLLOW_SUBSTEPS) or followed
        if followed is None:
            return False, None
        if same_period and same_orbit(att.orbit, followed):
            return True, followed
        if multiple and followed.stable:
            o = self.shoot(v_to, m, att.orbit.x0)
            if _is_orbit_of_period(o) and same_orbit(o, followed):
                return True, followed
        return False, followed

    def strobe_points(self, orbit: Orbit) -> np.ndarray:
        """The orbit's m stroboscopic points (q, q') at tau = 0, T, ..., (m - 1) T: (m, 2)."""
        if orbit.period == 1:
            return orbit.x0[None, :]
        r = api.simulate(orbit.omega, orbit.sigma, orbit.zeta, orbit.x0, periods=orbit.period,
                         samples_per_period=1, exponent=self.exponent, model=self.model,
                         rtol=self.rtol)
        return np.column_stack([r["q"][:orbit.period], r["v"][:orbit.period]])

    def judge(self, orbit: Orbit, v_from: float, v_to: float, att: Attractor,
              start) -> tuple[int, Orbit | None]:
        """Does the branch of ``orbit`` (at v_from) still attract at v_to, for the transient
        ``att`` started from ``start``? (verdict, the branch's orbit at v_to or None):
        SETTLED_ON (att settled on it), APPROACHING (att did not settle within the budget,
        on nothing else: the branch's orbit at v_to is stable and the transient ended no
        farther from it than it started, or within APPROACH_FLOOR of it: the slow approach
        near a fold or a flip, where the multiplier nearest the unit circle makes settling
        take ~1 / (1 - |mu|) periods), or OFF."""
        on, followed = self.continues(orbit, v_from, v_to, att)
        if on:
            return SETTLED_ON, followed
        if (att.status in (st.UNSETTLED, st.UNCONFIRMED) and followed is not None
                and followed.stable):
            pts = self.strobe_points(followed)
            d0 = float(np.min(np.hypot(*(pts - np.asarray(start, float)).T)))
            end = np.array([att["q_end"], att["v_end"]])
            d1 = float(np.min(np.hypot(*(pts - end).T)))
            floor = APPROACH_FLOOR * (1.0 + float(np.max(np.hypot(*pts.T))))
            if np.isfinite(d1) and d1 <= max(d0, floor):
                return APPROACHING, followed
        return OFF, followed

    def make_step(self, value: float, x, att: Attractor | None, branch: int,
                  approached: Orbit | None = None) -> Step:
        """The record of one step: the orbit att settled on; or ``approached``, the stable
        orbit of the branch it followed, when it did not settle but was approaching it
        (settled False) or settled on it as a multiple of its period (Sweeper.continues); or
        the record window's measures. att None: no transient ran, ``approached`` is the
        followed branch's stable orbit reached by continuation (stepped_sweep's
        ``follow_first``): the step is on it (status CONVERGED, settled, periods_run 0)."""
        if att is None:
            return self._continued_step(value, x, approached, branch)
        o = approached if approached is not None else att.orbit if att.periodic else None
        if o is not None:
            end = o.x0 if att.periodic else np.array([att["q_end"], att["v_end"]])
            mult = o.multipliers
            stable, lo, hi, ptp = o.stable, o.min_q, o.max_q, o.ptp
            lc = o.loses_contact
            harm, rms = o.force_harmonics, o.rms_force
            code = class_code(o)
        else:
            end = np.array([att["q_end"], att["v_end"]])
            mult = np.full(2, complex(np.nan, 0.0))
            stable, lo, hi = False, att.min_q, att.max_q
            ptp = hi - lo
            lc = bool(np.isfinite(lo) and lo <= -self.exponent)
            harm, rms = np.full(4, np.nan), math.nan
            code = 0
        omega, sigma, zeta = self.point(value)
        return Step(value=float(value), omega=omega, sigma=sigma, zeta=zeta,
                    start=np.array([float(x[0]), float(x[1])]), end=np.array(end, float),
                    status=int(att.status), settled=bool(att.periodic),
                    period=int(o.period) if o is not None else 0,
                    periods_run=int(att.periods_run), orbit=o, multipliers=mult,
                    stable=bool(stable), min_q=float(lo), max_q=float(hi), ptp=float(ptp),
                    loses_contact=bool(lc), force_harmonics=np.array(harm, float),
                    rms_force=float(rms), class_code=int(code), branch=branch, attractor=att)

    def continued(self, orbit: Orbit, v_from: float, v_to: float) -> Orbit | None:
        """The quasi-static rule (follow_first): the orbit ``orbit``'s branch continues into at
        v_to (:meth:`follow`, directly, then in FOLLOW_SUBSTEPS substeps), when it is stable
        there; else None (the branch ended or lost its stability in between)."""
        o = self.follow(orbit, v_from, v_to, 1) or self.follow(orbit, v_from, v_to,
                                                                FOLLOW_SUBSTEPS)
        return o if o is not None and o.stable else None

    def _continued_step(self, value: float, x, o: Orbit, branch: int) -> Step:
        omega, sigma, zeta = self.point(value)
        return Step(value=float(value), omega=omega, sigma=sigma, zeta=zeta,
                    start=np.array([float(x[0]), float(x[1])]), end=np.array(o.x0, float),
                    status=st.CONVERGED, settled=True, period=int(o.period), periods_run=0,
                    orbit=o, multipliers=o.multipliers, stable=bool(o.stable),
                    min_q=float(o.min_q), max_q=float(o.max_q), ptp=float(o.ptp),
                    loses_contact=bool(o.loses_contact),
                    force_harmonics=np.array(o.force_harmonics, float),
                    rms_force=float(o.rms_force), class_code=int(class_code(o)), branch=branch,
                    attractor=None)

    def locate(self, prev: Step, nxt: Step, index: int) -> Jump:
        """Bisect the jump between the periodic step ``prev`` and the step ``nxt`` (where
        prev's branch no longer attracts) until the bracket is at most jump_tol wide."""
        before, after = prev.value, nxt.value
        orbit = prev.orbit
        log = []
        while abs(after - before) > self.jump_tol:
            mid = 0.5 * (before + after)
            if mid == before or mid == after:    # the bracket is at the rounding of a double
                break
            if self.follow_first:
                followed = self.continued(orbit, before, mid)
                verdict = OFF if followed is None else SETTLED_ON
                log.append((mid, float(st.CONVERGED if followed is not None
                                       else st.NOT_CONVERGED), float(verdict)))
            else:
                start = orbit.x0
                att = self.settle(mid, start)
                verdict, followed = self.judge(orbit, before, mid, att, start)
                log.append((mid, float(att.status), float(verdict)))
            if verdict != OFF:
                before, orbit = mid, followed
            else:
                after = mid
        self.probes += len(log)
        kind, margin = jump_kind(orbit.multipliers, self.kind_tol)
        if kind == "loss" and self.follow(orbit, before, after, FOLLOW_SUBSTEPS) is None:
            # the followed orbit no longer exists at ``after``: it disappeared in the bracket,
            # a fold whose multiplier runs to +1 faster than kind_tol sees (past a grazing:
            # 0.92 +- 0.04i at 3e-7 before the fold of the 1T branch at sigma 0.5, omega 0.7535)
            kind, margin = "fold", float(np.min(np.abs(np.asarray(orbit.multipliers) - 1.0)))
        return Jump(value=0.5 * (before + after), accuracy=abs(after - before), before=before,
                    after=after, located=True, kind=kind, from_period=prev.period,
                    to_period=nxt.period, from_orbit=orbit, multipliers=orbit.multipliers,
                    margin=margin, to_step=nxt, step_index=index,
                    probe_log=np.array(log, float).reshape(-1, 3))


def _check_options(axis, values, fixed, direction, x0, jump_tol, kind_tol, settle_periods,
                   record_periods):
    if axis not in AXES:
        raise ValueError(f"axis must be one of {AXES}, got {axis!r}")
    if direction not in DIRECTIONS:
        raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")
    others = [a for a in AXES if a != axis]
    fixed = dict(fixed)
    if set(fixed) != set(others):
        raise ValueError(f"fixed must give exactly {others} (the parameters not swept), got "
                         f"{sorted(fixed)}")
    fixed = {k: float(v) for k, v in fixed.items()}
    values = np.asarray(values, float).ravel()
    if values.size < 1 or not np.all(np.isfinite(values)):
        raise ValueError("values must be one or more finite numbers")
    values = np.sort(values)
    if np.any(np.diff(values) <= 0.0):
        raise ValueError("values must not repeat")
    if direction == "down":
        values = values[::-1].copy()
    x = np.asarray(x0, float)
    if x.shape != (2,) or not np.all(np.isfinite(x)):
        raise ValueError(f"x0 must be two finite numbers (q, q'), got {x0!r}")
    if not (np.isfinite(jump_tol) and jump_tol > 0.0):
        raise ValueError(f"jump_tol must be a number > 0, got {jump_tol!r}")
    if not (np.isfinite(kind_tol) and 0.0 < kind_tol < 1.0):
        raise ValueError(f"kind_tol must be in (0, 1), got {kind_tol!r}")
    if int(settle_periods) != settle_periods or settle_periods < 0:
        raise ValueError(f"settle_periods must be an integer >= 0, got {settle_periods!r}")
    if int(record_periods) != record_periods or record_periods < 1:
        raise ValueError(f"record_periods must be an integer >= 1, got {record_periods!r}")
    return values, fixed, x


def stepped_sweep(axis: str, values, fixed: dict[str, float], direction: str = "up",
                  x0=(0.0, 0.0), *, exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
                  rtol: float = DEFAULT_RTOL, transient_rtol: float = api.DEFAULT_ATTRACTOR_RTOL,
                  settle_periods: int = 1000, record_periods: int = 200,
                  cycle_tol: float = 1e-6, lyapunov: bool = False, jump_tol: float = 1e-6,
                  kind_tol: float | None = None, follow_first: bool = False) -> Sweep:
    """A stepped-sine sweep of paper Eq. 7 along ``axis`` ("omega", "sigma" or "zeta") over
    ``values`` (swept in increasing order for direction "up", decreasing for "down"), the other
    two parameters in ``fixed`` (e.g. {"sigma": 0.5, "zeta": 0.01}), starting from x0 = (q, q')
    at tau = 0. All dimensionless (module docstring).

    exponent: n of the contact law (3/2 Hertz); model: kernels.model's law ("hertz", "taylor").
    rtol: the shooting tolerance (refined orbits, branch continuation); transient_rtol: the
    transients' integrator tolerance. Each step and each bisection probe runs at most
    settle_periods + record_periods forcing periods; cycle_tol: the relative tolerance of the
    stroboscopic period detection (kernels.attractors); lyapunov: the largest Lyapunov
    exponent over the record window of a step that does not settle (in its attractor record).
    jump_tol: the width in the swept parameter to which each jump is bracketed. kind_tol: how
    near +1 / -1 a multiplier of the followed orbit at the bracket's attracting end must be for
    a fold / flip (default max(KIND_TOL, 10 sqrt(jump_tol))).
    follow_first: the quasi-static sweep, the limit of a rig that waits at every step until
    the response has settled (study.identify's forward model): a step after a periodic step
    first continues the followed branch by Newton shooting from its orbit, each shot checked
    by its round trip (``_Sweeper.continued``); when that orbit is stable the step is on it
    and runs no transient (status CONVERGED, settled, periods_run 0, ``attractor`` None);
    otherwise the step runs its transient as without the option (where the sweep lands). Its
    jumps are bisected by the same rule, by shooting alone (no transient probes): where the
    followed branch ends or loses its stability. The same steps and jumps as the default
    wherever the transient would settle on the followed orbit (everywhere but a "loss" across
    a basin boundary, which it does not see), about 30 times cheaper a step on a branch at
    zeta 0.005 (two shots of ~0.1 ms against a transient of ~500 forcing periods) and a
    jump's probes ~100 times cheaper.
    Returns a :class:`Sweep`.
    """
    t0 = time.perf_counter()
    if kind_tol is None:
        kind_tol = max(KIND_TOL, 10.0 * math.sqrt(float(jump_tol)))
    values, fixed, x = _check_options(axis, values, fixed, direction, x0, jump_tol, kind_tol,
                                      settle_periods, record_periods)
    sw = _Sweeper(axis, fixed, exponent=float(exponent), model=model, rtol=float(rtol),
                  transient_rtol=float(transient_rtol), settle_periods=int(settle_periods),
                  record_periods=int(record_periods), cycle_tol=float(cycle_tol),
                  lyapunov=bool(lyapunov), jump_tol=float(jump_tol), kind_tol=float(kind_tol),
                  follow_first=bool(follow_first))
    steps: list[Step] = []
    jumps: list[Jump] = []
    branch = 0
    for i, value in enumerate(values):
        value = float(value)
        prev = steps[-1] if steps else None
        if follow_first and prev is not None and prev.periodic:
            continued = sw.continued(prev.orbit, prev.value, value)
            if continued is not None:
                steps.append(sw.make_step(value, x, None, branch, continued))
                x = steps[-1].end
                continue
        att = sw.settle(value, x)
        if prev is None:
            steps.append(sw.make_step(value, x, att, branch))
        elif prev.periodic:
            verdict, followed = sw.judge(prev.orbit, prev.value, value, att, x)
            if verdict == OFF:
                branch += 1
            own = (verdict == APPROACHING
                   or (verdict == SETTLED_ON and att.period != prev.orbit.period))
            step = sw.make_step(value, x, att, branch, followed if own else None)
            steps.append(step)
            if verdict == OFF:
                jumps.append(sw.locate(prev, step, i))
        else:
            branch += 1
            step = sw.make_step(value, x, att, branch)
            steps.append(step)
            if step.periodic:
                jumps.append(Jump(value=0.5 * (prev.value + value),
                                  accuracy=abs(value - prev.value), before=prev.value,
                                  after=value, located=False, kind="unlocated",
                                  from_period=0, to_period=step.period, from_orbit=None,
                                  multipliers=np.full(2, complex(np.nan, 0.0)),
                                  margin=math.nan, to_step=step, step_index=i,
                                  probe_log=np.empty((0, 3))))
        x = steps[-1].end
    settings = dict(exponent=float(exponent), model=model, rtol=float(rtol),
                    transient_rtol=float(transient_rtol), settle_periods=int(settle_periods),
                    record_periods=int(record_periods), cycle_tol=float(cycle_tol),
                    lyapunov=bool(lyapunov), jump_tol=float(jump_tol), kind_tol=float(kind_tol),
                    x0=(float(x0[0]), float(x0[1])), shoots=sw.shoots,
                    follow_first=bool(follow_first))
    return Sweep(axis=axis, direction=direction, fixed=fixed, values=values,
                 steps=tuple(steps), jumps=tuple(jumps), probes=sw.probes,
                 seconds=time.perf_counter() - t0, settings=settings)


# ---- swept sine at a finite rate ---------------------------------------------------------------
