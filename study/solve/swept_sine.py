"""What a lab measures at a finite sweep rate: the swept sine, the parameter moved while the
forcing runs, and where its response leaves the branches a stepped sweep jumps from.

Paper Eq. 7 (dimensionless): q'' + 2 zeta q' + F(q) = 1 + sigma cos(omega tau). The stepped
sweeps (the quasi-static limit of the rig's sweep) are study.solve.sweep's.

:func:`swept_sine`: the rig's other way to sweep (beside the stepped sweep), the
parameter moved continuously at ``rate`` per unit dimensionless time tau while the forcing runs,
never waiting for the response to settle. The forcing's phase is integrated with the rate: the
parameter is updated at the end of every forcing cycle (by rate x the cycle's length, as a
digital sweep generator does), so the phase omega tau runs on continuously through each cycle,
and the motion is never restarted. Each cycle is one call of the kernels' integrator, which
measures its extrema of q and its contact-force harmonics (read over two cycles as a tracking
filter reads H1, H2 and H1/2: :meth:`SweptSine.force_components`). Its jumps come later than
the stepped sweep's, the later the faster it sweeps (the response lags the branch, and near a
fold or a flip the branch attracts ever more slowly), and tend to them as the rate falls: past
the 2T fold at sigma 0.5, zeta 0.01, sweeping down, 4.0e-3, 8.5e-4, 1.9e-4 in omega at rates
1e-5, 1e-6, 1e-7, about 8.6 rate^(2/3), the slow passage through a fold. Past a flip the delay
is longer (the response stays on the unstable orbit until the deviation, decayed on the way
in, has grown back: at sigma 0.5 the swept run at 1e-5 passes the whole range 1.9776 ..
2.0168 where the 1T orbit is unstable without leaving it; at 3e-6 and 1e-6 it leaves it 0.030
and 0.014 past the flip). :func:`swept_jump` and :func:`swept_crossing` read where a swept
response leaves the branch a stepped sweep's jump left (on its subharmonic H1/2 for a 1T <->
2T jump, else on its amplitude: :func:`jump_measure`). The "sweeps" output runs them at the
study's ``[sweep] rates`` (study.products.stepped_sweeps, the run's sweeps stage).

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
from hertzmap.kernels.integrate import H_COS, H_SIN, N_STATS, S_MAX_Q, S_MIN_Q, integrate
from hertzmap.kernels.records import N_HARMONICS
from hertzmap.kernels.model import (DEFAULT_EXPONENT, DEFAULT_LAW, check_exponent,
                                    model_code)
from hertzmap.study.spec import SWEEP_MAX_CYCLES
from hertzmap.study.solve.sweep import AXES, Jump, force_components

__all__ = ["SweptSine", "SWEPT_WINDOW", "jump_measure", "swept_sine", "swept_crossing",
           "swept_jump"]

#: swept_sine's integration tolerance (a swept response is a transient: the attractors' default)
SWEPT_RTOL = api.DEFAULT_ATTRACTOR_RTOL
#: a stepped jump whose two responses differ by less than this fraction of their scale (the
#: larger amplitude; the larger H1 for a jump read on H1/2) is not read on a swept run
#: (swept_crossing: nothing jumps there)
SWEPT_JUMP_CONTRAST = 0.1
#: the harmonics of the contact force each cycle of a swept sine integrates, in multiples of
#: omega / 2 (kernels.integrate's harmonics over a period 2 T): omega / 2 (H1/2), omega (H1),
#: 2 omega (H2)
SWEPT_HARMONICS = (1, 2, 4)
#: the window of forcing cycles a swept sine's response is read over (SweptSine.
#: force_components, swept_crossing, the sweeps product's samples): two cycles, as a tracking
#: filter reads a 1T or a 2T response whole
SWEPT_WINDOW = 2


@dataclass(frozen=True)
class SweptSine:
    """A swept-sine run (module docstring): one row per forcing cycle, in the order run.

    axis: the swept parameter ("omega" or "sigma"); rate: its rate of change per unit tau
    (signed: negative sweeps down); fixed: the other two parameters. values: the parameter
    during each cycle; tau: the time each cycle starts at; start: (cycles, 2) the state (q, q')
    at each cycle's start (forcing phase 0 mod 2 pi); min_q, max_q: the extrema of q over each
    cycle (the integrator's, on the continuous extension of every step); harmonics: (cycles, 3)
    complex, the integrals over each cycle of F(q) exp(-i k omega t / 2) dt, t from the cycle's
    start, for k = SWEPT_HARMONICS (1, 2, 4: omega / 2, omega, 2 omega; F = the contact force /
    N). status: the kernels.status of the last cycle (0: every cycle integrated). seconds: wall
    time; settings: the options it ran with.
    """

    axis: str
    rate: float
    fixed: dict[str, float]
    values: np.ndarray
    tau: np.ndarray
    start: np.ndarray
    min_q: np.ndarray
    max_q: np.ndarray
    harmonics: np.ndarray
    status: int
    seconds: float
    settings: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def direction(self) -> str:
        return "up" if self.rate > 0 else "down"

    @property
    def periods(self) -> np.ndarray:
        """Each cycle's length T = 2 pi / omega (in tau)."""
        omega = self.values if self.axis == "omega" else np.full(self.values.size,
                                                                  self.fixed["omega"])
        return 2.0 * math.pi / omega

    def ptp(self, window: int = 1) -> np.ndarray:
        """Peak-to-peak q over the last ``window`` cycles at each cycle (a response of period m
        forcing cycles spans m of them); NaN for the first window - 1 cycles."""
        w = int(window)
        out = np.full(self.values.size, np.nan)
        if self.values.size >= w:
            hi = np.lib.stride_tricks.sliding_window_view(self.max_q, w).max(axis=-1)
            lo = np.lib.stride_tricks.sliding_window_view(self.min_q, w).min(axis=-1)
            out[w - 1:] = hi - lo
        return out

    def force_components(self, window: int = SWEPT_WINDOW
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(H1, H2, H1/2) at each cycle: the amplitudes of F/N at omega, 2 omega and omega / 2
        over the last ``window`` cycles (1 or 2), as a tracking filter reads them (the same
        numbers as an orbit's stored harmonics for a 1T or 2T response: 2 |integral of F
        exp(-i k omega t / 2)| / the window's length, the cycles' phases continuous); H1/2 is
        NaN with a window of one cycle; NaN for the first window - 1 cycles."""
        w = int(window)
        if w not in (1, 2):
            raise ValueError(f"window must be 1 or 2 cycles, got {window!r}")
        a, T = self.harmonics, self.periods
        n = self.values.size
        out = [np.full(n, np.nan) for _ in range(3)]
        if n < w:
            return out[0], out[1], out[2]
        if w == 1:
            out[0] = 2.0 * np.abs(a[:, 1]) / T
            out[1] = 2.0 * np.abs(a[:, 2]) / T
            return out[0], out[1], out[2]
        length = T[:-1] + T[1:]
        # the second cycle starts at t = T on the window's clock: exp(-i k omega T / 2) = (-1)^k
        out[0][1:] = 2.0 * np.abs(a[:-1, 1] + a[1:, 1]) / length
        out[1][1:] = 2.0 * np.abs(a[:-1, 2] + a[1:, 2]) / length
        out[2][1:] = 2.0 * np.abs(a[:-1, 0] - a[1:, 0]) / length
        return out[0], out[1], out[2]

    def cycle_at(self, values) -> np.ndarray:
        """The index of the first cycle that reached each of ``values`` of the swept parameter
        in the sweep's direction (its value at or past it); -1 for a value the run did not
        reach (or ran before it started)."""
        v = np.asarray(values, float)
        sign = 1.0 if self.rate > 0 else -1.0
        run = self.values * sign                     # increasing along the run
        at = np.searchsorted(run, v * sign, side="left")
        started = v * sign >= (run[0] if run.size else np.inf)
        return np.where((at < run.size) & started, at, -1)


def swept_sine(axis: str, start: float, stop: float, rate: float, fixed: dict[str, float],
               x0=(0.0, 0.0), *, exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
               rtol: float = SWEPT_RTOL, max_cycles: int = SWEEP_MAX_CYCLES) -> SweptSine:
    """A swept sine of paper Eq. 7: ``axis`` ("omega" or "sigma") moved from ``start`` to
    ``stop`` at ``rate`` (> 0, per unit dimensionless time tau; the sign of stop - start says
    up or down) with the other two parameters in ``fixed``, from x0 = (q, q') at tau = 0. The
    parameter is updated at the end of each forcing cycle T = 2 pi / omega by rate T (phase
    continuous; module docstring); the run ends with the first cycle that reaches ``stop``.
    rtol: the integrator's (kernels.integrate, one call a cycle, measuring the cycle's extrema
    of q and its contact-force harmonics). On the paper's rig (f0 = 271 Hz) a rate r in omega
    is r 2 pi f0^2 Hz/s: 1e-6 is 0.46 Hz/s. Returns a :class:`SweptSine`."""
    t0 = time.perf_counter()
    if axis not in ("omega", "sigma"):
        raise ValueError(f"axis must be 'omega' or 'sigma', got {axis!r}")
    others = [a for a in AXES if a != axis]
    fixed = {k: float(v) for k, v in dict(fixed).items()}
    if set(fixed) != set(others):
        raise ValueError(f"fixed must give exactly {others} (the parameters not swept), got "
                         f"{sorted(fixed)}")
    start, stop, rate = float(start), float(stop), float(rate)
    if not (np.isfinite(start) and np.isfinite(stop) and start != stop):
        raise ValueError(f"start and stop must be two different finite numbers, got {start!r}, "
                         f"{stop!r}")
    if not (np.isfinite(rate) and rate > 0.0):
        raise ValueError(f"rate must be a number > 0 (the direction is that of stop - start), "
                         f"got {rate!r}")
    x = np.asarray(x0, float)
    if x.shape != (2,) or not np.all(np.isfinite(x)):
        raise ValueError(f"x0 must be two finite numbers (q, q'), got {x0!r}")
    sign = 1.0 if stop > start else -1.0
    lowest_omega = min(start, stop) if axis == "omega" else fixed["omega"]
    if lowest_omega <= 0.0:
        raise ValueError("omega must stay > 0 over the sweep")
    longest = 2.0 * math.pi / lowest_omega
    if abs(stop - start) / (rate * longest) > max_cycles:
        raise ValueError(f"the sweep would run more than max_cycles = {max_cycles} forcing "
                         "cycles; sweep faster or a shorter range")
    n = check_exponent(exponent)
    code = model_code(model)
    rtol = float(rtol)
    # the kernel's work arrays, once: one call of kernels.integrate per cycle, no output times
    stats, harm = np.zeros(N_STATS), np.zeros((3, N_HARMONICS + 1))
    no_times, no_out = np.empty(0), np.empty((3, 0))
    f, y_new, f_new = np.empty(2), np.empty(2), np.empty(2)
    K, P = np.empty((16, 2)), np.empty((7, 2))
    ks = list(SWEPT_HARMONICS)
    p = dict(fixed)
    values, taus, starts, lows, highs, harmonics = [], [], [], [], [], []
    tau, value, status = 0.0, start, 0
    while (stop - value) * sign > 0.0:
        p[axis] = value
        T = 2.0 * math.pi / p["omega"]
        y = x.copy()
        harm[:] = 0.0
        status = int(integrate(y, 0.0, T, p["omega"], p["sigma"], p["zeta"], n, code, rtol, rtol,
                               0.1, 10_000_000, False, True, True, 2.0 * T, harm, no_times,
                               no_out, stats, f, y_new, f_new, K, P))
        values.append(value)
        taus.append(tau)
        starts.append(x)
        lows.append(stats[S_MIN_Q])
        highs.append(stats[S_MAX_Q])
        harmonics.append(harm[H_COS, ks] - 1j * harm[H_SIN, ks])
        if status != st.CONVERGED or not np.all(np.isfinite(y)):
            break
        x = y
        tau += T
        value += sign * rate * T
    return SweptSine(axis=axis, rate=sign * rate, fixed=fixed, values=np.array(values),
                     tau=np.array(taus), start=np.array(starts).reshape(-1, 2),
                     min_q=np.array(lows), max_q=np.array(highs),
                     harmonics=np.array(harmonics, complex).reshape(-1, len(ks)), status=status,
                     seconds=time.perf_counter() - t0,
                     settings=dict(exponent=float(exponent), model=model, rtol=rtol,
                                   x0=(float(x0[0]), float(x0[1]))))


def jump_measure(from_period: int, to_period: int) -> str:
    """What a swept run's jump between responses of these periods is read on
    (:func:`swept_crossing`): "H1_2", the contact force's subharmonic (at omega / 2), when one
    period is odd and the other even (a 1T <-> 2T jump: the subharmonic is there on one side
    only, as a lab's tracking of H1/2 sees it, while the amplitude of either response may cross
    any level on its own as the parameter moves); else "ptp", the amplitude (peak-to-peak q)."""
    return "H1_2" if (int(from_period) - int(to_period)) % 2 else "ptp"


def swept_crossing(swept: SweptSine, value: float, from_level: float, to_level: float, *,
                   measure: str = "ptp", period: int = 1, scale: float | None = None,
                   start: float | None = None, stop: float | None = None
                   ) -> tuple[float, float]:
    """(where, delay): where the swept response ``swept`` leaves a response whose ``measure``
    is ``from_level`` for one where it is ``to_level`` (the two responses of a stepped jump
    at ``value``, same line and direction): the first cycle at which the measure crosses the
    middle of the two, after a cycle on the first one's side of it. measure: "ptp", peak-to-
    peak q over ``period`` cycles (the larger of the two responses' periods), or "H1_2", the
    contact force's subharmonic over SWEPT_WINDOW cycles (:func:`jump_measure`). Only the
    cycles from ``start`` on, in the sweep's direction, and before ``stop`` are read (None:
    from the first, to the last): a run along a whole line meets every jump of the line, each
    between the step before it and the step before the next. delay: how far past ``value``
    the crossing is, in the sweep's direction (> 0: later). (NaN, NaN) when it does not cross
    there, or when the two levels differ by less than SWEPT_JUMP_CONTRAST of ``scale`` (the
    larger level by default; the responses' larger H1 for H1_2): nothing jumps there, e.g. a
    2T response ending on the 1T orbit at its flip, where the two meet."""
    a, b = float(from_level), float(to_level)
    scale = max(abs(a), abs(b)) if scale is None else float(scale)
    if not (np.isfinite(a) and np.isfinite(b)) or not abs(b - a) >= SWEPT_JUMP_CONTRAST * scale:
        return math.nan, math.nan
    if measure == "ptp":
        read = swept.ptp(max(int(period), 1))
    elif measure == "H1_2":
        read = swept.force_components(SWEPT_WINDOW)[2]
    else:
        raise ValueError(f"measure must be 'ptp' or 'H1_2', got {measure!r}")
    level, falling = 0.5 * (a + b), b < a
    sign = 1.0 if swept.rate > 0 else -1.0
    inside = np.ones(read.size, bool)
    if start is not None:
        inside &= (swept.values - float(start)) * sign >= 0.0
    if stop is not None:
        inside &= (swept.values - float(stop)) * sign < 0.0
    with np.errstate(invalid="ignore"):
        on = inside & (read >= level if falling else read <= level)
        off = inside & (read < level if falling else read > level)
    first_on = np.flatnonzero(on)
    if first_on.size == 0:
        return math.nan, math.nan
    hit = np.flatnonzero(off[first_on[0]:])
    if hit.size == 0:
        return math.nan, math.nan
    where = float(swept.values[first_on[0] + hit[0]])
    return where, (where - float(value)) * sign


def swept_jump(swept: SweptSine, jump: Jump, *, start: float | None = None,
               stop: float | None = None) -> tuple[float, float]:
    """(value, delay): where the swept response leaves the branch that a stepped sweep's
    located ``jump`` (same line, same direction) left (:func:`swept_crossing`): its measure
    (:func:`jump_measure`: the subharmonic H1/2 for a 1T <-> 2T jump, else the ptp over
    max(from_period, to_period) cycles) crossing the middle between the followed orbit's at
    jump.before and the step's it landed on; delay: how far past jump.value that is, in the
    sweep's direction (> 0: later; NaN, NaN when it never crosses). ``start``, ``stop``: the
    window of the run read (swept_crossing)."""
    if not jump.located or jump.from_orbit is None or jump.to_step.orbit is None:
        raise ValueError("swept_jump needs a located jump between two periodic responses")
    measure = jump_measure(jump.from_period, jump.to_period)
    a, b = jump.from_orbit, jump.to_step.orbit
    if measure == "H1_2":
        (h1a, _, ha), (h1b, _, hb) = (force_components(o.force_harmonics, o.period)
                                      for o in (a, b))
        return swept_crossing(swept, jump.value, float(ha), float(hb), measure=measure,
                              scale=float(np.nanmax([h1a, h1b])), start=start, stop=stop)
    return swept_crossing(swept, jump.value, a.ptp, jump.to_step.ptp, measure=measure,
                          period=max(jump.from_period, jump.to_period, 1), start=start,
                          stop=stop)
