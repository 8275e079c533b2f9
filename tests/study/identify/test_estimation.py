"""study.identify.estimation: a measurement that never leaves the 1T response (sigma 0.05 far
from every resonance, made by the scipy oracle, benchmarks/oracle_sweep.py, seed 3) cannot
separate zeta from the others: the fit says so from zeta's profile (its interval the bounds,
not identified) instead of printing a number, and still brackets f0 and sigma. The global
stage's grid and the mapper's contract."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.oracle_sweep import columns, measured_sweeps
from hertzmap.study.identify.estimation import (GLOBAL_SIGMA, fit, global_grid, in_process,
                                                run_task)
from hertzmap.study.identify.measurement import measurement_from_columns
from hertzmap.study.identify.problem import fit_problem
from hertzmap.study.identify.rig_table import rig_table

TRUTH = {"f0": 271.0, "sigma": 0.05, "zeta": 0.01}
RIG = {"rig": {"N": 69.7, "f0": 271.0, "f0_tolerance": 0.05},
       "excitation": {"sigma": 0.05}}


@pytest.fixture(scope="module")
def problem_1t():
    """23 steps up and down over 380 .. 490 Hz (omega 1.40 .. 1.81): the 1T response only."""
    rows, clean = measured_sweeps(np.linspace(380.0, 490.0, 23), N=69.7, a=0.03, b=0.01,
                                  seed=3, **TRUTH)
    assert {c["period"] for c in clean} == {1}
    return fit_problem(measurement_from_columns(columns(rows)), rig_table(RIG))


def test_a_1t_only_measurement_leaves_zeta_not_identified_and_brackets_the_rest(problem_1t):
    lines = []
    result = fit(problem_1t, in_process, report=lines.append)
    lo, hi, lo_c, hi_c = result.intervals["zeta"]
    assert not result.identified("zeta") and not lo_c and not hi_c
    assert (lo, hi) == pytest.approx(problem_1t.bounds["zeta"])
    # zeta's profile stays within the threshold over its whole range
    _, lls, _ = result.profiles["zeta"]
    assert np.all(2.0 * (result.loglik - lls) < 3.84)
    for name in ("f0", "sigma"):
        lo, hi, lo_c, hi_c = result.intervals[name]
        assert result.identified(name) and lo <= TRUTH[name] <= hi, (name, lo, hi)
    assert lines[0].startswith("global: ") and any(l.startswith("local: ") for l in lines)
    assert set(result.stages) >= {"global", "local", "profiles", "total"}


def test_the_global_grid_covers_the_bounds_and_tasks_run_by_kind(problem_1t):
    cells = global_grid(problem_1t)
    sigmas = sorted({c[0] for c in cells})
    zetas = sorted({c[1] for c in cells})
    assert len(sigmas) == GLOBAL_SIGMA and (sigmas[0], sigmas[-1]) == pytest.approx(
        problem_1t.bounds["sigma"])
    assert (zetas[0], zetas[-1]) == pytest.approx(problem_1t.bounds["zeta"])
    assert max(np.diff(np.log(zetas))) <= np.log(2.0) + 1e-12
    assert len(cells) == len(sigmas) * len(zetas)
    out = in_process("global grid", [{"kind": "cell", "problem": problem_1t,
                                      "theta": (0.05, 0.01, 1.5)}])
    assert out[0]["theta"] == (0.05, 0.01, 1.5) and np.isfinite(out[0]["loglik"])
    with pytest.raises(KeyError):
        run_task({"kind": "nothing"})
