"""Python entry points over the numba kernels: ``shoot``, ``shoot_batch``, ``simulate``,
``attractor``, ``attractor_batch``, ``lyapunov``.

Everything is dimensionless (paper Eq. 5-8): omega = excitation frequency / Omega, sigma =
force amplitude / static load N, zeta = damping ratio, q = n (z - z_s) / z_s, tau = Omega t.
"""
from __future__ import annotations

from dataclasses import dataclass
from math import pi

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.integrate import N_HARMONICS, N_STATS, integrate
from hertzmap.kernels.model import (DEFAULT_EXPONENT, DEFAULT_LAW, check_exponent, model_code,
                                    rhs_force)
from hertzmap.kernels.periodic_orbit import (DEFAULT_MAX_ITER, DEFAULT_MAX_STEPS, DEFAULT_RTOL, Orbit,  # noqa: F401
                                    shoot, shoot_batch)
from hertzmap.kernels.shooting import N_FIELDS


def section_times(T: float, t_end: float, samples_per_period: int = 1) -> np.ndarray:
    """Sampling times k T / samples_per_period, k = 0..K, for a transient over [0, t_end].

    K is t_end / (T / samples_per_period) rounded to the nearest integer when it is one to
    within 1e-9 (relative): t_end = periods T carries a rounding error of either sign, and
    ceil() of a quotient one ulp above an integer added a sample off the section.
    Otherwise K is the quotient's floor. Each time is computed as (k T) / samples_per_period
    from k, never accumulated, so that with samples_per_period = 1 every sample is on the
    stroboscopic section tau = 0 mod T to the rounding of one product.
    """
    s = int(samples_per_period)
    x = float(t_end) * s / T
    K = int(round(x))
    if abs(x - K) > 1e-9 * max(1.0, abs(x)):
        K = int(np.floor(x))
    K = max(K, 0)
    t = np.arange(K + 1, dtype=float) * T / s
    # (K T) / s and t_end = periods T may differ by an ulp: no sample beyond the end
    t[-1] = min(t[-1], float(t_end))
    return t


def simulate(omega: float, sigma: float, zeta: float, x0=(0.0, 0.0), *, t_end: float | None = None,
             periods: float = 50.0, t_eval=None, samples_per_period: int = 64,
             exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW, rtol: float = DEFAULT_RTOL,
             atol: float | None = None, max_steps: int = 10_000_000) -> dict[str, np.ndarray]:
    """Transient from x0 = (q, q') at tau = 0 to t_end (default ``periods`` excitation periods).

    Returns {"t", "q", "v", "force", "status", "final"}: force is the contact force F(q) / N, so
    F_exp = force - 1 (paper Eq. 30). Outputs are on the integrator's continuous extension
    (7th order) in contact and on the closed form in flight. "final" is the state at t_end.

    Without ``t_eval`` the samples are at tau_k = k T / samples_per_period (T = 2 pi / omega),
    k = 0, 1, ... while tau_k <= t_end: with samples_per_period = 1 they lie on the
    stroboscopic section tau = 0 mod T, and a whole number of periods gives periods + 1 of them.
    """
    if not (np.isfinite(omega) and omega > 0.0):
        raise ValueError(f"omega must be a finite number > 0, got {omega!r}")
    T = 2.0 * pi / omega
    if t_end is None:
        t_end = periods * T
    if t_eval is None:
        if int(samples_per_period) < 1:
            raise ValueError(f"samples_per_period must be an integer >= 1, got "
                             f"{samples_per_period!r}")
        t_eval = section_times(T, t_end, int(samples_per_period))
    t_eval = np.ascontiguousarray(np.asarray(t_eval, float))
    if t_eval.size and (np.any(np.diff(t_eval) < 0) or t_eval[0] < 0
                         or t_eval[-1] > t_end * (1 + 1e-12)):
        raise ValueError("t_eval must be sorted and inside [0, t_end]")
    n = check_exponent(exponent)
    code_model = model_code(model)
    y = np.array([float(x0[0]), float(x0[1])])
    out = np.full((3, t_eval.size), np.nan)
    stats = np.zeros(N_STATS)
    code = integrate(y, 0.0, float(t_end), float(omega), float(sigma), float(zeta), n, code_model,
                     float(rtol), float(rtol if atol is None else atol), 0.1, int(max_steps),
                     False, False, False, T, np.zeros((3, N_HARMONICS + 1)), t_eval, out, stats,
                     np.empty(2), np.empty(2), np.empty(2), np.empty((16, 2)), np.empty((7, 2)))
    if t_eval.size and t_eval[0] == 0.0:
        out[:, 0] = (x0[0], x0[1], rhs_force(float(x0[0]), n, code_model))
    return {"t": t_eval, "q": out[0], "v": out[1], "force": out[2], "status": int(code),
            "final": y.copy()}


# ---- attractors ------------------------------------------------------------------------------

DEFAULT_ATTRACTOR_RTOL = 1e-8


def _attractors():
    """kernels.attractors, imported on first use: its kernels have fixed signatures and compile
    (or load from the cache) when imported, which a study that only shoots need not pay for."""
    from hertzmap.kernels import attractors
    return attractors


@dataclass(frozen=True)
class Attractor:
    """The long-time response of paper Eq. 7 from one initial state (kernels.attractors).

    status: kernels.status code: CONVERGED (a stable periodic orbit of period ``period`` T,
    refined by shooting: ``orbit``), UNSETTLED (no repeating stroboscopic cycle of period <= 16
    within the budget: the exponent and measures describe the record window; a positive,
    converged exponent says the window was chaotic, not that the attractor is), UNCONFIRMED
    (the points repeat with period ``period`` but shooting confirmed no stable orbit), or an
    integrator failure. Exponents are per unit tau; all quantities dimensionless.
    """

    omega: float
    sigma: float
    zeta: float
    x0: np.ndarray
    status: int
    period: int                   # m of the detected cycle (0: none)
    periods_run: int              # forcing periods integrated from x0
    strobe: np.ndarray            # (k, 2) last stroboscopic points (q, q') at tau = 0 mod T
    lyapunov: float               # largest Lyapunov exponent (per unit tau)
    lyapunov_error: float         # standard error over 8 blocks (Benettin; NaN for an orbit)
    lyapunov_halves: float        # |first half's estimate - second half's| (Benettin)
    lyapunov_periods: int         # periods averaged (0: from the orbit's multipliers)
    lyapunov_sum_error: float     # |lambda1 + lambda2 + 2 zeta| (Liouville: the sum is -2 zeta)
    window_periods: int           # periods the measures are over
    flight_fraction: float
    max_impact_velocity: float
    min_q: float
    max_q: float
    peak_force: float             # F(max q) / N
    rms_force: float              # sqrt(<F^2>) / N
    mean_force: float             # <F> / N
    force_quadrature_error: float  # |sampled <F> - exact <F> (Eq. 7 over the window)|
    orbit: Orbit | None           # the refined orbit (or the last shooting attempt; None: none)
    row: np.ndarray               # the kernel's row (kernels.attractors.ATTRACTOR_FIELDS)

    @property
    def status_name(self) -> str:
        return st.NAMES[self.status]

    @property
    def periodic(self) -> bool:
        return self.status == st.CONVERGED and self.period > 0

    def __getitem__(self, name: str) -> float:
        return float(self.row[_attractors().ATTRACTOR_FIELDS.index(name)])

    @classmethod
    def from_rows(cls, omega, sigma, zeta, x0, row, orbit_row, strobe) -> "Attractor":
        r = {name: float(row[i]) for i, name in enumerate(_attractors().ATTRACTOR_FIELDS)}
        period = int(r["period"])
        orbit_period = int(r["orbit_period"])
        return cls(
            omega=float(omega), sigma=float(sigma), zeta=float(zeta),
            x0=np.array([float(x0[0]), float(x0[1])]), status=int(r["status"]), period=period,
            periods_run=int(r["periods_run"]), strobe=np.array(strobe[:int(r["strobe_count"])]),
            lyapunov=r["lyapunov"], lyapunov_error=r["lyapunov_error"],
            lyapunov_halves=r["lyapunov_halves"],
            lyapunov_periods=int(r["lyapunov_periods"]) if np.isfinite(r["lyapunov_periods"])
            else 0,
            lyapunov_sum_error=r["lyapunov_sum_error"],
            window_periods=int(r["window_periods"]) if np.isfinite(r["window_periods"]) else 0,
            flight_fraction=r["flight_fraction"], max_impact_velocity=r["max_impact_velocity"],
            min_q=r["min_q"], max_q=r["max_q"], peak_force=r["peak_force"],
            rms_force=r["rms_force"], mean_force=r["mean_force"],
            force_quadrature_error=r["force_quadrature_error"],
            orbit=Orbit.from_row(omega, sigma, zeta, orbit_period, orbit_row) if orbit_period
            else None,
            row=np.array(row))


def _check_parameters(omega, sigma, zeta):
    omega, sigma, zeta = float(omega), float(sigma), float(zeta)
    if not (np.isfinite(omega) and omega > 0.0):
        raise ValueError(f"omega must be a finite number > 0, got {omega!r}")
    if not (np.isfinite(sigma) and sigma >= 0.0):
        raise ValueError(f"sigma must be a finite number >= 0, got {sigma!r}")
    if not (np.isfinite(zeta) and zeta >= 0.0):
        raise ValueError(f"zeta must be a finite number >= 0, got {zeta!r}")
    return omega, sigma, zeta


def _check_int(name, value, lo, hi=None):
    try:
        v = int(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an integer, got {value!r}") from None
    if v != value or v < lo or (hi is not None and v > hi):
        rng = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise ValueError(f"{name} must be an integer {rng}, got {value!r}")
    return v


def _check_tolerance(name, value, hi=1e-3):
    v = float(value)
    if not (np.isfinite(v) and 0.0 < v <= hi):
        raise ValueError(f"{name} must be a number in (0, {hi:g}], got {value!r}")
    return v


def _attractor_options(transient_periods, record_periods, lyapunov, lyapunov_discard,
                       force_samples, cycle_tol, cycle_repeats, rtol, atol, shoot_rtol,
                       max_steps, strobe_capacity):
    transient_periods = _check_int("transient_periods", transient_periods, 0)
    record_periods = _check_int("record_periods", record_periods, 1)
    if lyapunov_discard is None:
        lyapunov_discard = min(32, record_periods // 4)
    lyapunov_discard = _check_int("lyapunov_discard", lyapunov_discard, 0, record_periods - 1)
    force_samples = _check_int("force_samples", force_samples, 0)
    cycle_repeats = _check_int("cycle_repeats", cycle_repeats, 1, _attractors().MAX_REPEATS)
    cycle_tol = _check_tolerance("cycle_tol", cycle_tol, 1e-2)
    rtol = _check_tolerance("rtol", rtol)
    atol = rtol if atol is None else _check_tolerance("atol", atol)
    shoot_rtol = _check_tolerance("shoot_rtol", shoot_rtol)
    max_steps = _check_int("max_steps", max_steps, 1)
    strobe_capacity = record_periods if strobe_capacity is None else _check_int(
        "strobe_capacity", strobe_capacity, 1)
    return (transient_periods, record_periods, bool(lyapunov), lyapunov_discard, force_samples,
            cycle_tol, cycle_repeats, rtol, atol, shoot_rtol, max_steps), strobe_capacity


def attractor(omega: float, sigma: float, zeta: float, x0=(0.0, 0.0), *,
              transient_periods: int = 1000, record_periods: int = 500, lyapunov: bool = True,
              lyapunov_discard: int | None = None, force_samples: int = 0, cycle_tol: float = 1e-6,
              cycle_repeats: int = 3, exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
              rtol: float = DEFAULT_ATTRACTOR_RTOL, atol: float | None = None,
              shoot_rtol: float = DEFAULT_RTOL, max_steps: int = DEFAULT_MAX_STEPS,
              harmonics: bool = True, strobe_capacity: int | None = None) -> Attractor:
    """Where the transient of paper Eq. 7 from x0 = (q, q') at tau = 0 goes (kernels.attractors).

    Budget: at most transient_periods + record_periods forcing periods (T = 2 pi / omega),
    each limited to max_steps integrator steps; the transient stops early once its
    stroboscopic points repeat with a period m <= 16 (within cycle_tol relative, over
    cycle_repeats returns) and shooting (at shoot_rtol) confirms a stable orbit there. The
    record window (the last record_periods periods) gives the strobe points, the measures and,
    with ``lyapunov``, the largest Lyapunov exponent (Benettin, after lyapunov_discard periods;
    default min(32, record_periods // 4)).
    force_samples: contact-force samples per period for the rms (0: every 0.05 in tau, >= 32).
    rtol/atol: the transient's integrator tolerances. strobe_capacity: how many of the last
    stroboscopic points to return (default record_periods).
    """
    att = _attractors()
    omega, sigma, zeta = _check_parameters(omega, sigma, zeta)
    q0, v0 = float(x0[0]), float(x0[1])
    if not (np.isfinite(q0) and np.isfinite(v0)):
        raise ValueError(f"x0 must be two finite numbers (q, q'), got {x0!r}")
    opts, cap = _attractor_options(transient_periods, record_periods, lyapunov,
                                   lyapunov_discard, force_samples, cycle_tol, cycle_repeats,
                                   rtol, atol, shoot_rtol, max_steps, strobe_capacity)
    row = np.empty((1, att.N_ATTRACTOR_FIELDS))
    orbit = np.empty((1, N_FIELDS))
    strobe = np.empty((1, cap, 2))
    # the batch kernel with one state: one compiled entry point serves both calls
    att.attractor_batch_into(omega, sigma, zeta, np.array([q0]), np.array([v0]),
                             check_exponent(exponent), model_code(model), *opts,
                             bool(harmonics), *att.known_attractors((), (), (), ()),
                             att.NO_LABEL, row, orbit, strobe)
    return Attractor.from_rows(omega, sigma, zeta, (q0, v0), row[0], orbit[0], strobe[0])


def attractor_batch(omega: float, sigma: float, zeta: float, x0, *,
                    transient_periods: int = 1000, record_periods: int = 500,
                    lyapunov: bool = True, lyapunov_discard: int | None = None,
                    force_samples: int = 0, cycle_tol: float = 1e-6, cycle_repeats: int = 3,
                    exponent: float = DEFAULT_EXPONENT,
                    model: str = DEFAULT_LAW, rtol: float = DEFAULT_ATTRACTOR_RTOL,
                    atol: float | None = None, shoot_rtol: float = DEFAULT_RTOL,
                    max_steps: int = DEFAULT_MAX_STEPS, harmonics: bool = True,
                    strobe_capacity: int | None = None) -> dict[str, np.ndarray]:
    """``attractor`` for k initial states x0 (shape (k, 2)) at one parameter point, in one
    kernel call. Returns {field: (k,) array} over kernels.attractors.ATTRACTOR_FIELDS, plus
    "orbit": (k, N_FIELDS) rows of kernels.shooting.FIELDS (NaN where no orbit was tried) and
    "strobe": (k, strobe_capacity, 2) (the first strobe_count[i] rows valid)."""
    att = _attractors()
    omega, sigma, zeta = _check_parameters(omega, sigma, zeta)
    x0 = np.asarray(x0, dtype=float)
    if x0.ndim != 2 or x0.shape[1] != 2 or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a finite array of shape (k, 2), got shape {x0.shape}")
    opts, cap = _attractor_options(transient_periods, record_periods, lyapunov,
                                   lyapunov_discard, force_samples, cycle_tol, cycle_repeats,
                                   rtol, atol, shoot_rtol, max_steps, strobe_capacity)
    k = x0.shape[0]
    rows = np.empty((k, att.N_ATTRACTOR_FIELDS))
    orbits = np.empty((k, N_FIELDS))
    strobes = np.empty((k, cap, 2))
    att.attractor_batch_into(omega, sigma, zeta, np.ascontiguousarray(x0[:, 0]),
                             np.ascontiguousarray(x0[:, 1]), check_exponent(exponent),
                             model_code(model), *opts, bool(harmonics),
                             *att.known_attractors((), (), (), ()), att.NO_LABEL, rows, orbits,
                             strobes)
    out = {name: rows[:, i].copy() for i, name in enumerate(att.ATTRACTOR_FIELDS)}
    out["orbit"] = orbits
    out["strobe"] = strobes
    return out


def lyapunov(omega: float, sigma: float, zeta: float, x0=(0.0, 0.0), *, periods: int = 2000,
             discard: int = 32, exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW,
             rtol: float = DEFAULT_ATTRACTOR_RTOL, atol: float | None = None,
             max_steps: int = DEFAULT_MAX_STEPS) -> dict[str, float]:
    """Largest Lyapunov exponent (per unit tau) along the trajectory from x0 at tau = 0, by
    Benettin's method with the variational equations (kernels.attractors.lyapunov_into): no
    transient beyond ``discard`` periods (the tangent vector's alignment). Returns
    {field: value} over kernels.attractors.LYAPUNOV_FIELDS."""
    att = _attractors()
    omega, sigma, zeta = _check_parameters(omega, sigma, zeta)
    periods = _check_int("periods", periods, 1)
    discard = _check_int("discard", discard, 0)
    rtol = _check_tolerance("rtol", rtol)
    atol = rtol if atol is None else _check_tolerance("atol", atol)
    out = np.empty(att.N_LYAPUNOV_FIELDS)
    att.lyapunov_into(omega, sigma, zeta, float(x0[0]), float(x0[1]),
                      check_exponent(exponent), model_code(model), periods, discard, rtol,
                      atol, _check_int("max_steps", max_steps, 1), out)
    return {name: float(out[i]) for i, name in enumerate(att.LYAPUNOV_FIELDS)}
