"""study.solve.recognition and the census with it: the census names the same attractors with
recognition as without it (each transient its whole budget), with fewer transient periods, on
points of the vibro-impact scene (zeta 0.01) where it matters: a chaotic attractor, a long
chaotic transient whose escapes reach a stable 6T orbit, and a long transient onto a 2T orbit.
The open sets' tolerance is checked against fresh points of a set of known shape. (The scene's
lines with and without recognition: benchmarks/census_ab.py.)"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hertzmap.kernels import status as st
from hertzmap.kernels.attractors import A
from hertzmap.study.solve import census as census_module
from hertzmap.study.solve.recognition import (OPEN_QUANTILE, KnownAttractors, open_tolerance,
                                              periodic_label)

OPTIONS = {"exponent": 1.5, "model": "hertz", "rtol": 1e-10, "harmonics": False}
ZETA = 0.01
RUN_TRANSIENTS = census_module.run_transients


def test_an_open_set_s_tolerance_holds_its_share_of_fresh_points():
    """Points of a noisy ring (the shape of a torus's or a thin chaotic set's stroboscopic
    points): fresh points of the same set land within the tolerance of the known ones at
    least OPEN_QUANTILE of the time."""
    rng = np.random.default_rng(3)

    def ring(n):
        t = rng.uniform(0, 2 * math.pi, n)
        r = 2.0 + rng.normal(0, 0.02, n)
        return np.c_[r * np.cos(t), r * np.sin(t)]

    known = ring(128)
    tol = open_tolerance(known)
    fresh = ring(5000)
    d = np.hypot(fresh[:, None, 0] - known[None, :, 0],
                 fresh[:, None, 1] - known[None, :, 1]).min(axis=1)
    assert np.mean(d <= tol) >= OPEN_QUANTILE
    # and not a tolerance that swallows the plane: well below the ring's size
    assert tol < 0.5


def test_the_periodic_sets_alone_leave_the_open_ones_out():
    known = KnownAttractors()
    known.add_periodic(periodic_label(0), [(0.0, 0.0)], 1e-2, 4)
    known.add_open(5, np.c_[np.linspace(1, 2, 20), np.zeros(20)])
    assert sorted(np.unique(known.arrays()[1])) == [-1, 5]
    assert list(np.unique(known.arrays(open_sets=False)[1])) == [-1]
    known.remove_open()
    assert list(np.unique(known.arrays()[1])) == [-1]


def _census(monkeypatch, omega, sigma, recognition):
    """The census at (omega, sigma) with or without recognition, and the transient periods
    and recognised runs it took."""
    monkeypatch.setattr(census_module, "RECOGNITION", recognition)
    run = RUN_TRANSIENTS
    spent = {"periods": 0.0, "recognised": 0}

    def counted(*args, **kwargs):
        run(*args, **kwargs)
        rows = args[8]
        spent["periods"] += float(np.nansum(rows[:, A["periods_run"]]))
        spent["recognised"] += int(np.sum(rows[:, A["status"]] == st.RECOGNISED))

    monkeypatch.setattr(census_module, "run_transients", counted)
    found, _ = census_module.census(omega, sigma, ZETA, [], OPTIONS, 16, 500, 128, 20_000,
                                    2_000_000)
    return found, spent


@pytest.mark.parametrize("omega, sigma", [(0.75, 3.05), (0.7, 3.25), (1.075, 1.85)])
def test_recognition_names_the_same_attractors_with_fewer_periods(monkeypatch, omega, sigma):
    with_it, spent = _census(monkeypatch, omega, sigma, True)
    without, spent_without = _census(monkeypatch, omega, sigma, False)
    # the same kinds and periods (how many transients reach each is a sample of the escapes
    # from a long chaotic transient, not a number two runs share)
    assert {(a.kind, a.period) for a in with_it} == {(a.kind, a.period) for a in without}
    assert sum(a.count for a in with_it) == 16
    assert spent_without["recognised"] == 0
    assert spent["recognised"] > 0 and spent["periods"] < spent_without["periods"]
    for a, b in zip(sorted(with_it, key=lambda a: (a.kind, a.period)),
                    sorted(without, key=lambda a: (a.kind, a.period))):
        if a.kind == "non_periodic":
            # the same chaotic set: exponents within their stated errors (three of each)
            lam, err = a.row[A["lyapunov"]], a.row[A["lyapunov_error"]]
            ref, ref_err = b.row[A["lyapunov"]], b.row[A["lyapunov_error"]]
            assert abs(lam - ref) <= 3 * math.hypot(err, ref_err)
