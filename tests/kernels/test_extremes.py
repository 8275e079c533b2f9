"""Stiff and extreme cases (benchmarks/extreme_cases.py): every call returns a status in bounded
time, and no converged orbit is silently wrong.

A converged orbit must (1) map onto itself under kernels.simulate at rtol 1e-12 (the state-only
integration path, no variational equations, no Newton), (2) pass Liouville (det M =
exp(-2 zeta P)), (3) agree with a reference re-solved at rtol 1e-13 from it. The cases of
ROUTES must converge from the end of their continuation.
The table is printed by ``benchmarks/extreme_cases.py`` (markdown, for RELIABILITY.md)."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.extreme_cases import CASES, ROUTES, case_args, solve_case
from hertzmap.kernels import status


TIME_BOUND = 20.0     # seconds per call, generous for a busy shared machine


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_extreme_case(case):
    name, omega, sigma, zeta, m, n, extra = case_args(case)
    row = solve_case(omega, sigma, zeta, m, n, extra)
    assert row["status"] in status.NAMES.values()
    assert row["max_seconds"] < TIME_BOUND, row
    if row["converged"]:
        scale = 1 + np.abs(row["x0"]).max()
        # independent check: the state-only integration maps the start point onto itself
        assert row["self_map"] < 1e-6 * scale, row
        assert row["liouville"] < 1e-6, row
        if row["ref"] == "converged":
            assert row["err"] < 1e-6 * scale, row
    if name in ROUTES:
        # the orbit exists, continuation reaches it, and Newton converges from there
        assert extra is not None, name
        assert row["converged"] and row["guess"] == 0, row
    if name.startswith("grazing"):
        assert row["converged"] and -1.5 - 1e-6 < row["min_q"] <= -1.5 + 1e-6, row
