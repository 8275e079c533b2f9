"""scheduler.stages.plan: chunks depend on the study only, and tasks tile any grid exactly once."""
from __future__ import annotations

from hypothesis import given, settings, strategies as hs
import numpy as np

from hertzmap.scheduler.stages.plan import choose_chunks, make_plan
from hertzmap.study.spec import parse_study
from tests.helpers import placeholder_study


def test_chunks_depend_on_the_study_only():
    s = placeholder_study()
    assert choose_chunks(s) == choose_chunks(s)
    big = parse_study("[grid]\nomega = {start = 0.5, stop = 2.5, num = 201}\n"
                      "sigma = {start = 0.05, stop = 1.0, num = 77}\nzeta = 0.01\n", default_name="b")
    c = choose_chunks(big)
    assert c[0] == 201 and c[2] == 1
    plan = make_plan(big, c)
    covered = np.zeros(big.shape, int)
    for t in plan.tasks:
        covered[t.slices] += 1
    assert (covered == 1).all()       # tasks tile the grid exactly once


@settings(max_examples=40, deadline=None)
@given(n_o=hs.integers(1, 5000), n_s=hs.integers(1, 60), n_z=hs.integers(1, 5),
       task_seconds=hs.floats(0.01, 10))
def test_tasks_tile_any_grid_exactly_once(n_o, n_s, n_z, task_seconds):
    def axis(start, stop, num):
        return f"[{start}]" if num == 1 else f"{{start = {start}, stop = {stop}, num = {num}}}"
    s = parse_study(f"[grid]\nomega = {axis(0.1, 5.0, n_o)}\nsigma = {axis(0.0, 1.0, n_s)}\n"
                    f"zeta = {axis(0.0, 0.5, n_z)}\n", default_name="h")
    chunks = choose_chunks(s, task_seconds)
    assert all(1 <= c <= n for c, n in zip(chunks, s.shape))
    assert chunks[0] == n_o or chunks[0] <= 4096
    plan = make_plan(s, chunks)
    covered = np.zeros(s.shape, np.int8)
    for t in plan.tasks:
        covered[t.slices] += 1
    assert (covered == 1).all()
