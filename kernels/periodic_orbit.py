"""The periodic orbit seen from Python: ``shoot`` (one orbit by Newton shooting, paper section
3.2), ``shoot_batch`` (over arrays) and ``Orbit``, the read-only view of the kernel's result row
(kernels.shooting.FIELDS).

Everything is dimensionless (paper Eq. 5-8): omega = excitation frequency / Omega, sigma =
force amplitude / static load N, zeta = damping ratio, q = n (z - z_s) / z_s, tau = Omega t.
"""
from __future__ import annotations

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.model import (DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL, check_exponent,
                                    model_code)
from hertzmap.kernels.records import ORBIT
from hertzmap.kernels.shooting import (FIELDS, I_M11, I_M22, I_Q0, I_STATUS, I_V0, N_FIELDS, F,
                                       shoot_batch_into, shoot_into)

DEFAULT_MAX_ITER = 40
DEFAULT_MAX_STEPS = 200_000


def _column_reader(field):
    """A property reading ``field`` (kernels.records.ORBIT) from the row: a bool, an int (0 for
    NaN), a float, a complex vector or a float vector, by its declared dtype and dim."""
    cols = [F[c] for c in field.kernel_columns]
    if field.dim is not None and field.dtype == "complex128":
        def get(self):
            r = self._row
            return np.array([complex(r[cols[k]], r[cols[k + 1]]) for k in range(0, len(cols), 2)])
    elif field.dim is not None:
        def get(self):
            return self._row[cols].copy()
    elif field.dtype == "bool":
        def get(self):
            return bool(self._row[cols[0]] == 1.0)
    elif field.dtype.startswith("int"):
        def get(self):
            v = self._row[cols[0]]
            return int(v) if np.isfinite(v) else 0
    else:
        def get(self):
            return float(self._row[cols[0]])
    return property(get, doc=f"{field.long_name} [{field.units}]: {field.description}")


class Orbit:
    """A periodic orbit of period ``period`` T (T = 2 pi / omega), dimensionless.

    A read-only view of the kernel's result row (``row``, layout kernels.shooting.FIELDS): every
    field of the orbit record (kernels.records.ORBIT) is an attribute, read from the row when
    asked for (building all of them at once cost as much as a 1T solve); plus ``x0`` = (q, q')
    at tau = 0 mod T, ``monodromy`` as a 2 x 2 matrix, ``converged`` and ``status_name``.
    """

    __slots__ = ("omega", "sigma", "zeta", "period", "_row")

    omega: float
    sigma: float
    zeta: float
    period: int

    def __init__(self, omega: float, sigma: float, zeta: float, period: int, row: np.ndarray):
        object.__setattr__(self, "omega", omega)
        object.__setattr__(self, "sigma", sigma)
        object.__setattr__(self, "zeta", zeta)
        object.__setattr__(self, "period", period)
        object.__setattr__(self, "_row", row)

    def __setattr__(self, name, value):
        raise AttributeError(f"Orbit is read-only (cannot set {name!r})")

    @classmethod
    def from_row(cls, omega, sigma, zeta, period, row) -> "Orbit":
        """The orbit of a kernel result row (a copy of it: the view never changes)."""
        return cls(float(omega), float(sigma), float(zeta), int(period), np.array(row, float))

    @property
    def row(self) -> np.ndarray:
        """The kernel's result row (a copy), layout kernels.shooting.FIELDS."""
        return self._row.copy()

    def __getitem__(self, name: str) -> float:
        """Any column of the result row by name (kernels.shooting.FIELDS)."""
        return float(self._row[F[name]])

    def __repr__(self) -> str:
        return (f"Orbit(omega={self.omega!r}, sigma={self.sigma!r}, zeta={self.zeta!r}, "
                f"period={self.period}, status={self.status_name}, x0={self.x0.tolist()}, "
                f"stable={self.stable}, steps={self.steps})")

    @property
    def converged(self) -> bool:
        return self._row[I_STATUS] == st.CONVERGED

    @property
    def status_name(self) -> str:
        return st.NAMES[self.status]

    @property
    def x0(self) -> np.ndarray:
        """(q, q') at tau = 0 mod T."""
        return self._row[I_Q0:I_V0 + 1].copy()

    @property
    def monodromy(self) -> np.ndarray:
        """The monodromy matrix M (2 x 2)."""
        return self._row[I_M11:I_M22 + 1].reshape(2, 2).copy()


# every field of the record the kernel computes (the period is the solve's: set above)
for _field in ORBIT.fields:
    if _field.kernel_columns and _field.name not in vars(Orbit):
        setattr(Orbit, _field.name, _column_reader(_field))
del _field


def _check_stall_ratio(stall_ratio) -> None:
    if not 0.0 < float(stall_ratio) <= 1.0:
        raise ValueError(f"stall_ratio must be in (0, 1], got {stall_ratio!r}")


def shoot(omega: float, sigma: float, zeta: float, period: int = 1, guess=(0.0, 0.0), *,
          exponent: float = DEFAULT_EXPONENT, model: str = DEFAULT_LAW, rtol: float = DEFAULT_RTOL,
          atol: float | None = None, max_iter: int = DEFAULT_MAX_ITER, stall_ratio: float = 1.0,
          max_steps: int = DEFAULT_MAX_STEPS, harmonics: bool = True) -> Orbit:
    """Find the period-``period`` orbit of paper Eq. 7 (or Eq. 11 with model="taylor") by Newton
    shooting from ``guess`` = (q0, q'0) at tau = 0. Never raises for a failed solve: look at
    ``orbit.status`` (kernels.status). ``rtol``/``atol``: local error tolerances of the integrator.
    ``harmonics=False`` skips the contact-force harmonics and mean force (NaN then): a
    quadrature on every step of the last integration, about a quarter of a 1T solve's time.
    ``stall_ratio`` in (0, 1]: Newton gives up after two damped steps running that each leave
    the residual at or above this share of the last (1: only when it does not decrease at all).
    """
    # the kernel checks the parameters itself (status DIVERGED): only what it cannot check here
    period = int(period)
    if period < 1:
        raise ValueError(f"period must be an integer >= 1, got {period!r}")
    _check_stall_ratio(stall_ratio)
    omega, sigma, zeta, rtol = float(omega), float(sigma), float(zeta), float(rtol)
    row = np.empty(N_FIELDS)
    shoot_into(omega, sigma, zeta, period, float(guess[0]), float(guess[1]),
               check_exponent(exponent), model_code(model), rtol,
               rtol if atol is None else float(atol), int(max_iter), float(stall_ratio),
               int(max_steps), bool(harmonics), row)
    return Orbit(omega, sigma, zeta, period, row)


def shoot_batch(omega, sigma, zeta, period, q_guess, v_guess, *, exponent: float = DEFAULT_EXPONENT,
                model: str = DEFAULT_LAW, rtol: float = DEFAULT_RTOL, atol: float | None = None,
                max_iter: int = DEFAULT_MAX_ITER, stall_ratio: float = 1.0,
                max_steps: int = DEFAULT_MAX_STEPS,
                harmonics: bool = True) -> dict[str, np.ndarray]:
    """Vectorised ``shoot`` over broadcast 1-D arrays; returns {field: array} (kernels.shooting.FIELDS)."""
    _check_stall_ratio(stall_ratio)
    omega, sigma, zeta, period, q_guess, v_guess = np.broadcast_arrays(
        np.asarray(omega, float), np.asarray(sigma, float), np.asarray(zeta, float),
        np.asarray(period, np.int64), np.asarray(q_guess, float), np.asarray(v_guess, float))
    shape = omega.shape
    args = [np.array(a.ravel(), copy=True) for a in (omega, sigma, zeta, period, q_guess, v_guess)]
    out = np.empty((args[0].size, N_FIELDS))
    shoot_batch_into(*args, check_exponent(exponent), model_code(model), float(rtol),
                     float(rtol if atol is None else atol), int(max_iter), float(stall_ratio),
                     int(max_steps), bool(harmonics), out)
    return {name: out[:, i].reshape(shape) for i, name in enumerate(FIELDS)}
