"""Python entry points over the numba kernels: ``shoot``, ``shoot_batch``, ``simulate``.

Everything is dimensionless (paper Eq. 5-8): omega = excitation frequency / Omega, sigma =
force amplitude / static load N, zeta = damping ratio, q = n (z - z_s) / z_s, tau = Omega t.
"""
from __future__ import annotations

from dataclasses import dataclass
from math import pi

import numpy as np

from kernels import status as st
from kernels.integrate import N_HARMONICS, N_STATS, integrate
from kernels.model import MODELS, rhs_force
from kernels.shooting import FIELDS, N_FIELDS, shoot_batch_into, shoot_into

DEFAULT_RTOL = 1e-10
DEFAULT_MAX_ITER = 40
DEFAULT_MAX_STEPS = 200_000


def _model_code(model: str) -> int:
    try:
        return MODELS[model]
    except KeyError:
        raise ValueError(f"model must be one of {sorted(MODELS)}, got {model!r}") from None


def _check_exponent(exponent: float) -> float:
    exponent = float(exponent)
    if not (np.isfinite(exponent) and exponent > 0.0):
        raise ValueError(f"exponent must be a finite number > 0, got {exponent!r}")
    return exponent


@dataclass(frozen=True)
class Orbit:
    """A periodic orbit of period ``period`` T (T = 2 pi / omega), dimensionless.

    x0: (q, q') at tau = 0 mod T. multipliers: Floquet multipliers (eigenvalues of the
    monodromy matrix ``monodromy``). Orbit measures are over one period of the orbit.
    """

    omega: float
    sigma: float
    zeta: float
    period: int
    status: int
    x0: np.ndarray
    multipliers: np.ndarray
    monodromy: np.ndarray
    stable: bool
    min_q: float
    max_q: float
    ptp: float
    loses_contact: bool
    flight_fraction: float
    max_impact_velocity: float
    force_harmonics: np.ndarray   # amplitudes of F at k omega / period, k = 1..4
    mean_force: float             # must be 1 (the static load) for a periodic orbit
    iterations: int
    residual: float
    liouville_error: float        # |det M - exp(-2 zeta P)| / max(exp(-2 zeta P), |m11 m22| + |m12 m21|)
    minimal_period: int           # 1 for a 2T solve that landed on the 1T orbit
    steps: int

    @property
    def converged(self) -> bool:
        return self.status == st.CONVERGED

    @property
    def status_name(self) -> str:
        return st.NAMES[self.status]

    @classmethod
    def from_row(cls, omega, sigma, zeta, period, row) -> "Orbit":
        r = {name: row[i] for i, name in enumerate(FIELDS)}
        mult = np.array([complex(r["multiplier1_re"], r["multiplier1_im"]),
                         complex(r["multiplier2_re"], r["multiplier2_im"])])
        return cls(
            omega=float(omega), sigma=float(sigma), zeta=float(zeta), period=int(period),
            status=int(r["status"]), x0=np.array([r["q0"], r["v0"]]), multipliers=mult,
            monodromy=np.array([[r["m11"], r["m12"]], [r["m21"], r["m22"]]]),
            stable=bool(r["stable"] == 1.0), min_q=float(r["min_q"]), max_q=float(r["max_q"]),
            ptp=float(r["ptp"]), loses_contact=bool(r["loses_contact"] == 1.0),
            flight_fraction=float(r["flight_fraction"]),
            max_impact_velocity=float(r["max_impact_velocity"]),
            force_harmonics=np.array([r[f"force_h{k}"] for k in range(1, N_HARMONICS + 1)]),
            mean_force=float(r["mean_force"]), iterations=int(r["iterations"]),
            residual=float(r["residual"]), liouville_error=float(r["liouville_error"]),
            minimal_period=int(r["minimal_period"]) if np.isfinite(r["minimal_period"]) else 0,
            steps=int(r["steps"]),
        )


def shoot(omega: float, sigma: float, zeta: float, period: int = 1, guess=(0.0, 0.0), *,
          exponent: float = 1.5, model: str = "hertz", rtol: float = DEFAULT_RTOL,
          atol: float | None = None, max_iter: int = DEFAULT_MAX_ITER,
          max_steps: int = DEFAULT_MAX_STEPS, harmonics: bool = True) -> Orbit:
    """Find the period-``period`` orbit of paper Eq. 7 (or Eq. 11 with model="taylor") by Newton
    shooting from ``guess`` = (q0, q'0) at tau = 0. Never raises for a failed solve: look at
    ``orbit.status`` (kernels.status). ``rtol``/``atol``: local error tolerances of the integrator.
    ``harmonics=False`` skips the contact-force harmonics and mean force (NaN then): a
    quadrature on every step of the last integration, about a quarter of a 1T solve's time.
    """
    if int(period) < 1:
        raise ValueError(f"period must be an integer >= 1, got {period!r}")
    row = np.empty(N_FIELDS)
    shoot_into(float(omega), float(sigma), float(zeta), int(period), float(guess[0]),
               float(guess[1]), _check_exponent(exponent), _model_code(model), float(rtol),
               float(rtol if atol is None else atol), int(max_iter), int(max_steps),
               bool(harmonics), row)
    return Orbit.from_row(omega, sigma, zeta, period, row)


def shoot_batch(omega, sigma, zeta, period, q_guess, v_guess, *, exponent: float = 1.5,
                model: str = "hertz", rtol: float = DEFAULT_RTOL, atol: float | None = None,
                max_iter: int = DEFAULT_MAX_ITER, max_steps: int = DEFAULT_MAX_STEPS,
                harmonics: bool = True) -> dict[str, np.ndarray]:
    """Vectorised ``shoot`` over broadcast 1-D arrays; returns {field: array} (kernels.shooting.FIELDS)."""
    omega, sigma, zeta, period, q_guess, v_guess = np.broadcast_arrays(
        np.asarray(omega, float), np.asarray(sigma, float), np.asarray(zeta, float),
        np.asarray(period, np.int64), np.asarray(q_guess, float), np.asarray(v_guess, float))
    shape = omega.shape
    args = [np.array(a.ravel(), copy=True) for a in (omega, sigma, zeta, period, q_guess, v_guess)]
    out = np.empty((args[0].size, N_FIELDS))
    shoot_batch_into(*args, _check_exponent(exponent), _model_code(model), float(rtol),
                     float(rtol if atol is None else atol), int(max_iter), int(max_steps),
                     bool(harmonics), out)
    return {name: out[:, i].reshape(shape) for i, name in enumerate(FIELDS)}


def section_times(T: float, t_end: float, samples_per_period: int = 1) -> np.ndarray:
    """Sampling times k T / samples_per_period, k = 0..K, for a transient over [0, t_end].

    K is t_end / (T / samples_per_period) rounded to the nearest integer when it is one to
    within 1e-9 (relative): t_end = periods T carries a rounding error of either sign, and
    ceil() of a quotient one ulp above an integer added a sample off the section (issue 21).
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
             exponent: float = 1.5, model: str = "hertz", rtol: float = DEFAULT_RTOL,
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
    n = _check_exponent(exponent)
    code_model = _model_code(model)
    y = np.array([float(x0[0]), float(x0[1])])
    out = np.full((3, t_eval.size), np.nan)
    stats = np.zeros(N_STATS)
    code = integrate(y, 0.0, float(t_end), float(omega), float(sigma), float(zeta), n, code_model,
                     float(rtol), float(rtol if atol is None else atol), 0.1, int(max_steps),
                     False, False, False, T, np.zeros((2, N_HARMONICS + 1)), t_eval, out, stats,
                     np.empty(2), np.empty(2), np.empty(2), np.empty((16, 2)), np.empty((7, 2)))
    if t_eval.size and t_eval[0] == 0.0:
        out[:, 0] = (x0[0], x0[1], rhs_force(float(x0[0]), n, code_model))
    return {"t": t_eval, "q": out[0], "v": out[1], "force": out[2], "status": int(code),
            "final": y.copy()}
