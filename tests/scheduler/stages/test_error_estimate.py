"""scheduler.stages.error_estimate: the sampled orbits are re-solved at a tighter tolerance, the deviation
reported and stored; orbits only continuation reaches are found again from their own start
point."""
from __future__ import annotations

import math

import numpy as np
import pytest

from tests.helpers import placeholder_run, placeholder_study


def test_error_estimate_and_summary(tmp_path, client):
    summary = placeholder_run(tmp_path / "f.zarr", client, error_sample=8)
    e = summary["error"]
    assert e["n"] == 8 and e["matched"] == 8 and e["max_deviation"] == 0.0
    assert e["rtol_ref"] == pytest.approx(1e-13)
    assert 0 <= summary["converged_fraction"] <= 1 and summary["orbits"] > 0
    assert math.isfinite(summary["overhead"])


def test_error_estimate_finds_orbits_that_only_continuation_reaches(client):
    # The error estimate re-solves each sampled orbit alone at a tight tolerance. Orbits that
    # the block solver reaches only by continuation along omega are missed by a point's own
    # automatic seeds; seeded with the stored start point, every sample is found again.
    import io

    from hertzmap.scheduler.stages.error_estimate import estimate_error
    from hertzmap.scheduler.interrupt import DeferInterrupt
    from hertzmap.scheduler.stages.stage import TaskRunner
    from hertzmap.study.solve.block import solve_block

    s = placeholder_study('[study]\nname = "err"\n[grid]\nomega = {start = 0.5, stop = 2.5, num = 41}\n'
              'sigma = 0.5\nzeta = 0.01\n[solver]\nrtol = 1e-10\n')
    kw = s.solver_kwargs()
    omega = s.axis("omega")
    line = solve_block(omega, s.axis("sigma"), s.axis("zeta"), **kw)
    alone_only, found_alone = [], []
    for i, w in enumerate(omega):
        single = solve_block(np.array([w]), s.axis("sigma"), s.axis("zeta"), **kw)
        for slot in np.flatnonzero(line["status"][i, 0, 0] == 0):
            p, q0, v0 = (line[k][i, 0, 0, slot] for k in ("period", "q0", "v0"))
            ok = (single["status"][0, 0, 0] == 0) & (single["period"][0, 0, 0] == p)
            near = ok.any() and np.min(np.abs(single["q0"][0, 0, 0][ok] - q0)) < 1e-6
            (found_alone if near else alone_only).append(
                (float(w), 0.5, 0.01, int(p), float(q0), float(v0)))
    assert len(alone_only) >= 2, "the line should have orbits that only continuation reaches"
    samples = alone_only[:4] + found_alone[:4]
    runner = TaskRunner(client, DeferInterrupt(), io.StringIO())
    e = estimate_error(runner, s, samples)
    assert runner.costs["error sample"].tasks == 1
    assert e["n"] == len(samples) and e["matched"] == len(samples)
    assert 0.0 < e["max_deviation"] < 1e-8
