"""The problem a fit solves: a validated measurement and rig table, the parameters fitted and
their bounds, and the omega grid of the forward model, checked against what the model covers.

The parameters (PARAMETERS): f0 (Hz), sigma, zeta, and on request the contact exponent n
(``exponent``). The forward model works in omega = f / f0 (paper Eq. 8): its sweeps cover the
measured frequencies at every f0 within the bounds, from OMEGA_MARGIN below the lowest
measured frequency at the highest f0 to OMEGA_MARGIN above the highest at the lowest f0, on
one grid (study.identify.forward_model.omega_grid) for every (sigma, zeta, n) of the fit. A
measurement the model cannot cover (a frequency whose omega at an f0 bound falls outside
OMEGA_COVERED) is refused, naming its row and column.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hertzmap.study.identify.forward_model import FORWARD_STEP, omega_grid
from hertzmap.study.identify.measurement import DIRECTIONS, FitInputError, Measurement
from hertzmap.study.identify.rig_table import RigTable

__all__ = ["PARAMETERS", "OMEGA_COVERED", "OMEGA_MARGIN", "FitProblem", "fit_problem"]

#: the parameters a fit can identify, declared once: name -> (long_name, units)
PARAMETERS = {
    "f0": ("linearised natural frequency f0", "Hz"),
    "sigma": ("excitation amplitude sigma (force amplitude / N)", "1"),
    "zeta": ("damping ratio zeta", "1"),
    "exponent": ("contact exponent n", "1"),
}
#: the omega range the fit's forward model covers: from the lowest order-4 superharmonic
#: resonance (omega 1/4) to twice the order-2 subharmonic resonance (omega 4); its sweeps
#: take at most (4 - 1/4) / FORWARD_STEP = 1500 steps a direction (about 1 s a pair)
OMEGA_COVERED = (0.25, 4.0)
#: the model's sweeps start and end this far (relative) beyond the measured range at the f0
#: bounds
OMEGA_MARGIN = 0.01


@dataclass(frozen=True)
class FitProblem:
    """Everything a fit's tasks need (picklable: shipped to the workers).

    frequency (n,) Hz, direction (n,) 0 up / 1 down, amplitude (n, 3) N: the measurement
    (study.identify.measurement.Measurement, NaN where a harmonic was not measured). N: the
    preload (N). free: the parameters fitted, in order (f0 first); bounds, nominal: per
    parameter (nominal: the rig table's, NaN where it has none). exponent: the contact
    exponent when not fitted. omega: the forward model's grid.
    """

    frequency: np.ndarray
    direction: np.ndarray
    amplitude: np.ndarray
    N: float
    free: tuple[str, ...]
    bounds: dict[str, tuple[float, float]]
    nominal: dict[str, float]
    exponent: float
    omega: np.ndarray

    @property
    def directions(self) -> tuple[str, ...]:
        return tuple(d for i, d in enumerate(DIRECTIONS) if np.any(self.direction == i))

    @property
    def shape_parameters(self) -> tuple[str, ...]:
        """The fitted parameters besides f0: each value of them is one forward model."""
        return tuple(p for p in self.free if p != "f0")


def fit_problem(measurement: Measurement, rig: RigTable) -> FitProblem:
    """The fit's problem of a measurement and a rig table. Raises FitInputError (naming the
    row and column frequency_hz) when a measured frequency lies outside what the model
    covers at an f0 bound."""
    f = measurement.frequency
    lo_f0, hi_f0 = rig.f0_bounds
    i_lo, i_hi = int(np.argmin(f)), int(np.argmax(f))
    w_lo, w_hi = f[i_lo] / hi_f0, f[i_hi] / lo_f0
    a, b = OMEGA_COVERED
    for i, w, bound, edge in ((i_lo, w_lo, hi_f0, "upper"), (i_hi, w_hi, lo_f0, "lower")):
        if not a <= w <= b:
            raise FitInputError(
                f"{f[i]:g} Hz is omega = f / f0 = {w:.4g} at the {edge} f0 bound {bound:g} Hz; "
                f"the model covers {a:g} <= omega <= {b:g} (f = {a * hi_f0:.4g} .. "
                f"{b * lo_f0:.4g} Hz over the f0 bounds {lo_f0:g} .. {hi_f0:g} Hz): narrow "
                "the rig table's f0 bounds (rig.f0_tolerance, rig.f0_bounds) or leave out "
                "the rows beyond", **measurement.where(i, "frequency_hz"))
    grid = omega_grid(max(a, w_lo * (1.0 - OMEGA_MARGIN)), min(b, w_hi * (1.0 + OMEGA_MARGIN)),
                      FORWARD_STEP)
    free = ("f0", "sigma", "zeta") + (("exponent",) if rig.fit_exponent else ())
    bounds = {"f0": tuple(rig.f0_bounds), "sigma": tuple(rig.sigma_bounds),
              "zeta": tuple(rig.zeta_bounds), "exponent": tuple(rig.exponent_bounds)}
    nominal = {"f0": rig.f0, "sigma": rig.sigma, "zeta": rig.zeta,
               "exponent": rig.exponent}
    return FitProblem(frequency=f.copy(), direction=measurement.direction.copy(),
                      amplitude=measurement.amplitude.copy(), N=rig.N, free=free,
                      bounds={p: bounds[p] for p in free}, nominal=nominal,
                      exponent=rig.exponent, omega=grid)

