"""A simulated rig made of the scipy oracle alone (benchmarks/oracle.py: solve_ivp across the
contact switches, scipy's root, the monodromy from the variational equations; no code of
kernels/ or study/): the quasi-static stepped-sine sweep a lab measures when it waits at every
step until the response has settled, and the transmitted force's harmonics it reads.

Used to make the synthetic measurements the fit (study.identify) is tested and benchmarked on:

    from benchmarks.oracle_sweep import measured_sweeps
    rows, clean = measured_sweeps(freqs_hz, f0=271.0, sigma=0.3, zeta=0.005, N=69.7, a=0.03,
                                  b=0.05, seed=7)    # noisy readings, as a lab exports them

The sweep (:func:`quasi_static_sweep`), its own rule written from the physics, not from
study.solve.sweep: each step's orbit is the last one's continued by the oracle's Newton
(scipy root on Phi_mT(x) - x with the exact monodromy), kept while it exists near the last
one and is stable (both Floquet multipliers inside the unit circle, its minimal period m);
where it is not, the response leaves it: a transient from the state the sweep arrived with,
of TRANSIENT_PERIODS forcing periods, then the oracle's Newton for orbits of period 1, 2, 4
(and twice the lost orbit's, from points along the transient's departure from it: past a flip
the 2m T orbit is born a distance ~ sqrt(past the flip) away) from the transient's end, the
first stable one kept. The harmonics (:func:`orbit_harmonics`): the amplitudes of F/N at
omega, 2 omega and omega / 2, integrated along the orbit over 2 m forcing periods by solve_ivp
as three more pairs of components (F cos, F sin).

Dimensionless inside (paper Eq. 7, n = 3/2 unless given); measured_sweeps converts to the rig:
omega = f / f0, harmonics in N = N x those of F/N.
"""
from __future__ import annotations

from math import pi

import numpy as np

from benchmarks import oracle

#: forcing periods of the transient after the followed orbit is lost
TRANSIENT_PERIODS = 400
#: the oracle's integration tolerance for orbits and harmonics; for transients
RTOL, TRANSIENT_RTOL = 1e-10, 1e-8


def orbit_harmonics(x0, omega, sigma, zeta, m, *, n=1.5, rtol=RTOL):
    """(H1, H2, H1/2): 2 |integral of F exp(-i k omega t / 2) dt| / P over P = 2 m T from
    x0, k = 2, 4, 1 (F = (1 + q/n)^n in contact, 0 in flight), by solve_ivp with the six
    integrals as components (oracle.piecewise: restarts at every contact switch)."""
    ks = (2.0, 4.0, 1.0)

    def rhs(t, y):
        F = oracle.force(y[0], n)
        out = [y[1], 1.0 + sigma * np.cos(omega * t) - 2.0 * zeta * y[1] - F]
        for k in ks:
            out += [F * np.cos(0.5 * k * omega * t), F * np.sin(0.5 * k * omega * t)]
        return out

    P = 2 * m * 2.0 * pi / omega
    y, _ = oracle.piecewise(rhs, [x0[0], x0[1]] + [0.0] * 6, 0.0, P, n=n, rtol=rtol,
                            atol=rtol)
    return tuple(2.0 * np.hypot(y[2 + 2 * i], y[3 + 2 * i]) / P for i in range(3))


def _orbit(guess, omega, sigma, zeta, m, n):
    """(x, multipliers) of the oracle's m T orbit from guess, or None (no convergence, or
    not of minimal period m)."""
    try:
        x, M, _ = oracle.shoot(guess, omega, sigma, zeta, m, n=n, rtol=RTOL)
    except (ArithmeticError, oracle.IntegrationFailed, RuntimeError):
        return None
    if not np.all(np.isfinite(x)):
        return None
    for d in range(1, m):
        if m % d == 0:
            y = oracle.flow(x, 0.0, d * 2.0 * pi / omega, omega, sigma, zeta, n=n, rtol=RTOL,
                            atol=RTOL)
            if np.hypot(*(y - x)) <= 1e-6 * (1.0 + np.hypot(*x)):
                return None
    return x, np.linalg.eigvals(M)


def _stable(mu) -> bool:
    return bool(np.max(np.abs(mu)) < 1.0)


def _strobe(x0, omega, sigma, zeta, periods, n):
    """The stroboscopic points of a transient from x0 at tau = 0, 1, ..., periods T."""
    T = 2.0 * pi / omega
    pts = [np.asarray(x0, float)]
    x = np.asarray(x0, float)
    for _ in range(periods):
        x = oracle.flow(x, 0.0, T, omega, sigma, zeta, n=n, rtol=TRANSIENT_RTOL,
                        atol=TRANSIENT_RTOL)
        pts.append(x)
    return np.array(pts)


def _land(start, omega, sigma, zeta, n, lost=None):
    """The stable orbit a transient from ``start`` settles on (module docstring): (x, m, mu)
    or None. ``lost``: (x, m) of the followed orbit continued to this omega (unstable)."""
    pts = _strobe(start, omega, sigma, zeta, TRANSIENT_PERIODS, n)
    end = pts[-1]
    tries = []
    if lost is not None:
        x_m, m = lost
        away = end - x_m
        size = np.hypot(*away)
        if size > 0.0:
            tries += [(2 * m, x_m + s * r * away / size) for r in (0.01, 0.03, 0.1, 0.3, 1.0)
                      for s in (1.0, -1.0)]
    # the period of the transient's last points
    for m in (1, 2, 3, 4):
        if np.hypot(*(pts[-1] - pts[-1 - m])) <= 1e-3 * (1.0 + np.hypot(*pts[-1])):
            tries.insert(0, (m, end))
            break
    tries += [(m, end) for m in (1, 2, 4)]
    for m, guess in tries:
        got = _orbit(guess, omega, sigma, zeta, m, n)
        if got is not None and _stable(got[1]):
            return got[0], m, got[1]
    return None


def quasi_static_sweep(omegas, sigma, zeta, direction="up", *, n=1.5, x0=(0.0, 0.0)):
    """The oracle's quasi-static stepped sweep (module docstring) over ``omegas`` (swept up or
    down). Returns a list of dicts per step in sweep order: omega, period (0: no stable orbit
    found), x0, multipliers, H1, H2, H1_2 (of F/N; NaN without an orbit)."""
    values = np.sort(np.asarray(omegas, float))
    if direction == "down":
        values = values[::-1]
    out = []
    current = None          # (x, m) of the followed orbit
    state = np.asarray(x0, float)
    for w in values:
        got = None
        lost = None
        if current is not None:
            x_prev, m = current
            cont = _orbit(x_prev, w, sigma, zeta, m, n)
            near = cont is not None and np.hypot(*(cont[0] - x_prev)) <= 0.5 * (
                1.0 + np.hypot(*x_prev))
            if near and _stable(cont[1]):
                got = (cont[0], m, cont[1])
            elif near:
                lost = (cont[0], m)
        if got is None:
            got = _land(state, w, sigma, zeta, n, lost)
        if got is None:
            out.append({"omega": w, "period": 0, "x0": np.full(2, np.nan),
                        "multipliers": np.full(2, np.nan), "H1": np.nan, "H2": np.nan,
                        "H1_2": np.nan})
            current = None
            continue
        x, m, mu = got
        h1, h2, h12 = orbit_harmonics(x, w, sigma, zeta, m, n=n)
        out.append({"omega": w, "period": m, "x0": x, "multipliers": mu, "H1": h1, "H2": h2,
                    "H1_2": h12})
        current = (x, m)
        state = x
    return out


def clean_sweeps(freqs_hz, *, f0, sigma, zeta, N, n=1.5, directions=("up", "down")):
    """The oracle's quasi-static sweeps at omega = f / f0 over the frequencies ``freqs_hz``,
    up then down: a list of dicts per step in the order measured, with the CSV's columns
    (frequency_hz, direction, H1_N, H2_N, H1_2_N: N x the harmonics of F/N, no noise) and the
    period of the step's response."""
    clean = []
    freqs = np.sort(np.asarray(freqs_hz, float))
    for d in directions:
        steps = quasi_static_sweep(freqs / f0, sigma, zeta, d, n=n)
        for f, s in zip(freqs if d == "up" else freqs[::-1], steps):
            m = np.array([s["H1"], s["H2"], s["H1_2"]]) * N
            clean.append({"frequency_hz": f, "direction": d, "H1_N": m[0], "H2_N": m[1],
                          "H1_2_N": m[2], "period": s["period"]})
    return clean


def with_noise(clean, *, a, b, seed):
    """The readings of :func:`clean_sweeps` with the fit's noise model: |m + sd e|, sd =
    sqrt((a m)^2 + b^2), e standard normal from numpy's default_rng(seed), three a step (H1,
    H2, H1/2) in the order measured (the absolute value: a measured amplitude; its second
    moment is the normal model's)."""
    rng = np.random.default_rng(seed)
    rows = []
    for c in clean:
        m = np.array([c["H1_N"], c["H2_N"], c["H1_2_N"]])
        sd = np.sqrt((a * m) ** 2 + b * b)
        y = np.abs(m + sd * rng.standard_normal(3))
        rows.append({"frequency_hz": c["frequency_hz"], "direction": c["direction"],
                     "H1_N": y[0], "H2_N": y[1], "H1_2_N": y[2]})
    return rows


def measured_sweeps(freqs_hz, *, f0, sigma, zeta, N, a, b, seed, n=1.5,
                    directions=("up", "down")):
    """A synthetic measurement: (rows, clean), :func:`with_noise` of :func:`clean_sweeps`."""
    clean = clean_sweeps(freqs_hz, f0=f0, sigma=sigma, zeta=zeta, N=N, n=n,
                         directions=directions)
    return with_noise(clean, a=a, b=b, seed=seed), clean


def columns(rows) -> dict[str, list]:
    """Rows (dicts of the CSV's columns) as columns (study.identify.measurement.
    measurement_from_columns takes them)."""
    names = ("frequency_hz", "direction", "H1_N", "H2_N", "H1_2_N")
    return {k: [r[k] for r in rows] for k in names}
