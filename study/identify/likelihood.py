"""The noise model and the log-likelihood of a measurement under the model, maximised over f0.

Each reading y (a harmonic's amplitude at one measured step, N) is the model's m (N times the
forward model's harmonic at omega = f / f0 on the branch its sweep is on there: study.identify.
forward_model) plus a normal error of standard deviation

    sd = sqrt((a m)^2 + b^2),

a multiplicative part a (a transducer's calibration, the step-to-step scatter of a response
that is a fixed fraction of its size) and an additive floor b (N: the noise floor a subharmonic
H1/2 reads where the response has none). a and b are the same for every harmonic and both
directions, and are estimated with the other parameters by maximum likelihood: for a given
model the log-likelihood

    log L = -sum(log sd_i) - sum((y_i - m_i)^2 / sd_i^2) / 2 - (n / 2) log(2 pi)

is maximised over (a, b) exactly (:func:`noise_fit`: with b / a = s tan(t), s the readings'
rms, the best overall scale is closed-form for each angle t, and t is searched over the
ratios NOISE_RATIOS, then by Brent's method in the log of the ratio),
so every log-likelihood a fit compares is profiled over the noise. f0 only stretches the
model's frequency axis, so for one forward model :func:`best_f0` maximises over f0 within its
bounds by a scan fine enough that no jump of the model passes more than one measured point
between two scanned values, refined by Brent's bounded search around the best maxima.

A reading whose model is near 0 (H1/2 where the model's response is 1T) and which is measured
as an amplitude |m + e| is not normal but folded; its second moment is that of the normal
model, so a and b are estimated without bias from such readings (docs/identify.md).

Pure numpy and scipy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from hertzmap.study.identify.forward_model import ForwardModel
from hertzmap.study.identify.measurement import DIRECTIONS
from hertzmap.study.identify.problem import FitProblem

__all__ = ["NoiseFit", "NOISE_RATIOS", "model_amplitudes", "noise_fit", "loglik", "best_f0",
           "f0_scan_step", "Readings", "pseudo_residuals", "pseudo_residuals_dm",
           "loglik_of_squares"]

#: the ratios b / (a s) of the coarse search of the noise model (s: the readings' rms)
NOISE_RATIOS = np.logspace(-5.0, 5.0, 41)
_HALF_LOG_2PI = 0.5 * math.log(2.0 * math.pi)


@dataclass(frozen=True)
class NoiseFit:
    """The log-likelihood of a model maximised over the noise model: loglik, the
    multiplicative part a (relative) and the floor b (N)."""

    loglik: float
    a: float
    b: float


@dataclass(frozen=True)
class Readings:
    """A problem's readings flattened: y (r,) N, the index (r,) into the (point, harmonic)
    array of each, and the readings' rms (the noise search's scale)."""

    y: np.ndarray
    index: np.ndarray
    scale: float

    @classmethod
    def of(cls, problem: FitProblem) -> "Readings":
        flat = problem.amplitude.ravel()
        index = np.flatnonzero(np.isfinite(flat))
        y = flat[index]
        scale = float(np.sqrt(np.mean(y * y))) or 1.0
        return cls(y=y, index=index, scale=scale)


def model_amplitudes(problem: FitProblem, fm: ForwardModel, f0):
    """(m, period, segment, dm_dlogf0): the model's harmonics in N (..., n, 3) at each
    measured point for each f0 (a number or an array of shape (...)), the period of the
    response the model's sweep is on there (..., n), the index of that branch's run along
    its sweep (..., n; study.identify.forward_model.ModelSweep.at) and d m / d log f0
    (..., n, 3) along that branch (= -N omega dh/domega, omega = f / f0)."""
    f0 = np.asarray(f0, float)
    n = problem.frequency.size
    m = np.full(f0.shape + (n, 3), np.nan)
    dm = np.zeros(f0.shape + (n, 3))
    period = np.zeros(f0.shape + (n,), int)
    segment = np.zeros(f0.shape + (n,), int)
    for d, name in enumerate(DIRECTIONS):
        idx = np.flatnonzero(problem.direction == d)
        if idx.size == 0:
            continue
        omega = problem.frequency[idx] / f0[..., None]
        h, p, seg, slope = fm.at(omega, name)
        m[..., idx, :] = problem.N * h
        dm[..., idx, :] = -problem.N * omega[..., None] * slope
        period[..., idx] = p
        segment[..., idx] = seg
    return m, period, segment, dm


def pseudo_residuals(y: np.ndarray, m: np.ndarray, a: float, b: float) -> np.ndarray:
    """The residual vector (2 r,) whose sum of squares is -2 log L up to a constant for the
    noise model (a, b) held: the standardised residuals (y - m) / sd and sqrt(2 log(sd / b))
    (sd >= b), so that a least-squares solver maximises the exact likelihood, sd's dependence
    on the model included (log L = -sum of squares / 2 - r log b - (r / 2) log 2 pi)."""
    sd = np.sqrt((a * m) ** 2 + b * b)
    return np.concatenate([(y - m) / sd, np.sqrt(2.0 * np.log(np.maximum(sd / b, 1.0)))])


def pseudo_residuals_dm(y: np.ndarray, m: np.ndarray, a: float, b: float) -> np.ndarray:
    """d pseudo_residuals / d m, reading by reading (2 r,)."""
    sd2 = (a * m) ** 2 + b * b
    sd = np.sqrt(sd2)
    deps = -1.0 / sd - (y - m) * a * a * m / (sd2 * sd)
    c = np.sqrt(2.0 * np.log(np.maximum(sd / b, 1.0)))
    dc = np.where(c > 1e-12, a * a * m / (sd2 * np.where(c > 1e-12, c, 1.0)), 0.0)
    return np.concatenate([deps, dc])


def loglik_of_squares(squares: float, r: int, b: float) -> float:
    """log L from the sum of squares of :func:`pseudo_residuals` of r readings."""
    return -0.5 * squares - r * math.log(b) - r * _HALF_LOG_2PI


def _loglik_at(y, m, scale, t) -> tuple[float, float, float]:
    """(log L, a, b) at the angle t, with the best overall scale."""
    c, s = math.cos(t), math.sin(t)
    w = (c * m / scale) ** 2 + s * s
    rho2 = float(np.mean((y - m) ** 2 / w))
    if not rho2 > 0.0:
        return -math.inf, math.nan, math.nan
    n = y.size
    ll = -0.5 * n * math.log(rho2) - 0.5 * float(np.sum(np.log(w))) - 0.5 * n - n * _HALF_LOG_2PI
    rho = math.sqrt(rho2)
    return ll, rho * c / scale, rho * s


def noise_fit(y: np.ndarray, m: np.ndarray, scale: float) -> NoiseFit:
    """The log-likelihood of readings y (r,) under the model m (r,), both in N, maximised over
    the noise model (a, b) (module docstring). A non-finite model gives -inf."""
    if not np.all(np.isfinite(m)):
        return NoiseFit(-math.inf, math.nan, math.nan)
    lls = _coarse_loglik(y, m[None, :], scale, per_angle=True)[0]
    k = int(np.argmax(lls))
    # refined in the log of the ratio b / (a s) (the coarse grid's spacing), to 1e-6 of it
    logs = np.log(NOISE_RATIOS)
    step = logs[1] - logs[0]
    res = minimize_scalar(lambda v: -_loglik_at(y, m, scale, math.atan(math.exp(v)))[0],
                          bounds=(logs[k] - step, logs[k] + step), method="bounded",
                          options={"xatol": 1e-6})
    t = math.atan(math.exp(float(res.x))) if -res.fun >= lls[k] else math.atan(
        NOISE_RATIOS[k])
    ll, a, b = _loglik_at(y, m, scale, t)
    return NoiseFit(ll, a, b)


def _coarse_loglik(y: np.ndarray, m: np.ndarray, scale: float,
                   per_angle: bool = False) -> np.ndarray:
    """The log-likelihood of each row of m (F, r) maximised over the coarse angles only
    (NOISE_RATIOS): a scan's ranking; ``per_angle``: (F, angles), each angle's."""
    angles = np.arctan(NOISE_RATIOS)
    c2, s2 = np.cos(angles) ** 2, np.sin(angles) ** 2
    n = y.size
    ok = np.all(np.isfinite(m), axis=1)
    r2 = (y[None, :] - m) ** 2
    q = (m / scale) ** 2
    # all the angles at once: (F, angles, r)
    w = c2[None, :, None] * q[:, None, :] + s2[None, :, None]
    rho2 = np.mean(r2[:, None, :] / w, axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = -0.5 * n * np.log(rho2) - 0.5 * np.sum(np.log(w), axis=2)
    out = np.where(ok[:, None], out, -np.inf) - (0.5 * n + n * _HALF_LOG_2PI)
    return out if per_angle else out.max(axis=1)


def loglik(problem: FitProblem, fm: ForwardModel, f0: float,
           readings: Readings | None = None) -> NoiseFit:
    """The log-likelihood of the problem's measurement under the forward model ``fm`` at
    ``f0``, maximised over the noise model."""
    r = readings or Readings.of(problem)
    m = model_amplitudes(problem, fm, f0)[0]
    return noise_fit(r.y, m.ravel()[r.index], r.scale)


def f0_scan_step(problem: FitProblem) -> float:
    """The relative step of the f0 scan: half the smallest relative step between measured
    frequencies of a sweep (a jump of the model at omega_j passes the measured point f when f0
    passes f / omega_j: between two scanned values at most one point changes branch), within
    [1e-4, 2e-3]."""
    steps = []
    for d in range(len(DIRECTIONS)):
        f = problem.frequency[problem.direction == d]
        if f.size > 1:
            steps.append(np.min(np.abs(np.diff(f)) / np.maximum(f[1:], f[:-1])))
    step = 0.5 * min(steps) if steps else 1e-3
    return float(np.clip(step, 1e-4, 2e-3))


def best_f0(problem: FitProblem, fm: ForwardModel, bounds: tuple[float, float] | None = None,
            readings: Readings | None = None, candidates: int = 3,
            block: int = 8) -> tuple[float, NoiseFit, np.ndarray, np.ndarray]:
    """(f0, NoiseFit, scanned f0, their coarse log-likelihoods): the log-likelihood of the
    forward model ``fm`` maximised over f0 within ``bounds`` (default the problem's): the
    scan (:func:`f0_scan_step`, geometric), then Brent's bounded search within one scan step
    of each of the ``candidates`` best local maxima."""
    r = readings or Readings.of(problem)
    lo, hi = bounds or problem.bounds["f0"]
    step = f0_scan_step(problem)
    count = max(3, int(math.ceil(math.log(hi / lo) / math.log1p(step))) + 1)
    grid = np.geomspace(lo, hi, count)
    coarse = np.empty(count)
    for k in range(0, count, block):
        m = model_amplitudes(problem, fm, grid[k:k + block])[0]
        flat = m.reshape(m.shape[0], -1)[:, r.index]
        coarse[k:k + block] = _coarse_loglik(r.y, flat, r.scale)
    # local maxima of the scan, best first
    padded = np.r_[-np.inf, coarse, -np.inf]
    peaks = np.flatnonzero((padded[1:-1] >= padded[:-2]) & (padded[1:-1] >= padded[2:]))
    peaks = peaks[np.argsort(coarse[peaks])[::-1]][:candidates]
    best_f, best = math.nan, NoiseFit(-math.inf, math.nan, math.nan)
    for k in peaks:
        if not np.isfinite(coarse[k]):
            continue
        a, b = grid[max(k - 1, 0)], grid[min(k + 1, count - 1)]
        res = minimize_scalar(lambda x: -loglik(problem, fm, x, r).loglik, bounds=(a, b),
                              method="bounded", options={"xatol": 1e-7 * grid[k]})
        for x in (float(res.x), float(grid[k])):
            fit = loglik(problem, fm, x, r)
            if fit.loglik > best.loglik:
                best_f, best = x, fit
    return best_f, best, grid, coarse
