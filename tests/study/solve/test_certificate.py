"""study.solve.certificate: a stable orbit's certified neighbourhood, and the ladder's start
from a neighbouring grid point's level (LevelHints).

The contraction a certificate claims (its m-period map takes every sampled point of the rings
V = c and V = c / 4, DIRECTIONS a ring, to V <= kappa V) is checked with the scipy oracle's
period map (benchmarks/oracle.py, no kernel code) at those points. The claim is evidence, not a
proof between the sampled directions (the module's docstring; at the README's 2T orbit, omega
1.9, sigma 0.5, 32 directions of the ring V = c include one where V grows by 2 %): a transient
is recognised only once it shows the contraction itself (kernels.attractors)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels.periodic_orbit import shoot
from hertzmap.study.solve import certificate
from hertzmap.study.solve.certificate import LevelHints, certify

OPTIONS = {"exponent": 1.5, "model": "hertz", "rtol": 1e-10, "harmonics": False}
Z = 0.01


def _orbit(omega, sigma, period, guess):
    o = shoot(omega, sigma, Z, period=period, guess=guess, exponent=1.5, rtol=1e-10)
    assert o.converged and o.stable
    return {"x0": tuple(o.x0), "period": period, "stable": True, "status": 0,
            "monodromy": np.asarray(o.monodromy, float).reshape(-1)}


def _sampled_contraction(row, omega, sigma) -> float:
    """The largest V(Phi(x)) / V(x) over the points certify samples at its level c (the rings
    V = c and V = c / 4, DIRECTIONS directions each), with the oracle's m-period map."""
    x0 = row[:2]
    P = np.array([[row[2], row[3]], [row[3], row[4]]])
    c, m = row[5], int(row[7])
    L = np.linalg.cholesky(P)
    worst = 0.0
    for ring in certificate.RINGS:
        for k in range(certificate.DIRECTIONS):
            th = 2.0 * math.pi * k / certificate.DIRECTIONS
            d = np.linalg.solve(L.T, math.sqrt(c * ring) * np.array([math.cos(th), math.sin(th)]))
            y = oracle.period_map(x0 + d, omega, sigma, Z, m, rtol=1e-11, atol=1e-11) - x0
            worst = max(worst, float(y @ P @ y) / float(d @ P @ d))
    return worst


@pytest.mark.parametrize("omega, sigma, period, guess", [
    (1.5, 0.3, 1, (-0.1, 0.2)),       # 1T in contact
    (1.9, 0.5, 2, (-0.09, 1.5)),      # 2T with contact loss (README's example)
])
def test_a_certified_neighbourhood_contracts_under_the_oracle_map(omega, sigma, period, guess):
    orbit = _orbit(omega, sigma, period, guess)
    row = certify(orbit, omega, sigma, Z, OPTIONS)
    assert row is not None
    kappa = row[6]
    assert 0.0 < kappa < 1.0 and row[5] > 0.0
    assert _sampled_contraction(row, omega, sigma) <= kappa


def test_a_neighbour_s_level_starts_the_ladder_and_saves_maps(monkeypatch):
    """The level of the same orbit one grid step away (the default grid's omega step) as the
    start: a certificate whose level passes the oracle's check too, for about half the maps of
    a ladder from FIRST_RADIUS."""
    calls = []
    real = certificate._maps

    def counting(xs, *a):
        calls.append(len(xs))
        return real(xs, *a)

    monkeypatch.setattr(certificate, "_maps", counting)
    here = _orbit(1.5, 0.3, 1, (-0.1, 0.2))
    near = _orbit(1.5125, 0.3, 1, here["x0"])
    hints = LevelHints()
    hints.keep([certify(near, 1.5125, 0.3, Z, OPTIONS)])
    calls.clear()
    plain = certify(here, 1.5, 0.3, Z, OPTIONS)
    from_first = len(calls)
    calls.clear()
    start = hints.start(here)
    assert start is not None
    hinted = certify(here, 1.5, 0.3, Z, OPTIONS, start=start)
    assert hinted is not None and plain is not None
    assert len(calls) < from_first, (len(calls), from_first)
    assert _sampled_contraction(hinted, 1.5, 0.3) <= hinted[6]


def test_hints_are_of_the_same_period_and_nearby():
    hints = LevelHints()
    row = np.array([0.5, 0.0, 1.0, 0.0, 1.0, 0.04, 0.99, 1.0])
    two = np.array([0.5, 0.0, 1.0, 0.0, 1.0, 0.09, 0.99, 2.0])
    hints.keep([row, two])
    assert hints.start({"x0": (0.52, 0.01), "period": 1}) == 0.04
    assert hints.start({"x0": (0.52, 0.01), "period": 2}) == 0.09
    assert hints.start({"x0": (3.0, 0.0), "period": 1}) is None      # another orbit
    assert hints.start({"x0": (0.5, 0.0), "period": 3}) is None
    hints.keep([])
    assert hints.start({"x0": (0.5, 0.0), "period": 1}) is None
