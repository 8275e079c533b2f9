"""scheduler.stages.progress: the time left of a stage from the costs of its done tasks, and
scheduler.stages.plan.spread_order, the order the grid's blocks are shipped in."""
from __future__ import annotations

import io

import numpy as np
import pytest

from hertzmap.scheduler.stages.plan import spread_order
from hertzmap.scheduler.stages.progress import Progress, WorkEstimate


def test_spread_order_is_a_permutation_whose_first_tasks_cover_the_grid():
    """After any j tasks shipped of n, no stretch of the plan without one is longer than
    about three times n / j (as a bisection leaves it; in plan order, n - j)."""
    for n in (1, 2, 7, 77, 128, 1000, 12397):
        order = spread_order(range(n))
        assert sorted(order) == list(range(n))
        for j in range(1, n + 1, max(1, n // 200)):
            shipped = sorted(order[:j])
            gaps = np.diff([-1] + shipped + [n])
            assert gaps.max() <= 3.0 * n / j + 1, (n, j, gaps.max())


def _grid_tasks(n_sigma=40):
    """Tasks of one line each; cost per point rising with sigma (as on the default scene)
    and a bump in the middle."""
    keys = [f"t{j}" for j in range(n_sigma)]
    places = {k: (0, j, 0) for j, k in enumerate(keys)}
    sizes = {k: 161 for k in keys}
    per_point = {k: 0.01 * (1.0 + 2.0 * j / n_sigma + (1.5 if 15 <= j < 20 else 0.0))
                 for j, k in enumerate(keys)}
    return keys, places, sizes, per_point


def test_the_work_left_is_the_plan_s_before_any_task_and_exact_when_all_are_done():
    keys, places, sizes, per_point = _grid_tasks()
    w = WorkEstimate(places, sizes, prior=0.02)
    assert w.remaining() == pytest.approx(0.02 * 161 * len(keys))
    for k in keys:
        w.done(k, per_point[k] * sizes[k])
    assert w.remaining() == 0.0


def test_the_work_left_interpolates_the_done_tasks_over_the_grid():
    """With a quarter of the tasks done, shipped spread over the grid, the estimate of what is
    left is within 15 % of the truth; from the first quarter of a plan-ordered (ascending)
    run the points' rate alone would say 40 % too little."""
    keys, places, sizes, per_point = _grid_tasks()
    truth = lambda done: sum(per_point[k] * sizes[k] for k in keys if k not in done)
    w = WorkEstimate(places, sizes, prior=0.02)
    done = spread_order(keys)[:len(keys) // 4]
    for k in done:
        w.done(k, per_point[k] * sizes[k])
    assert w.remaining() == pytest.approx(truth(set(done)), rel=0.15)
    first = keys[:len(keys) // 4]
    rate_guess = np.mean([per_point[k] for k in first]) * 161 * (len(keys) - len(first))
    assert rate_guess < 0.6 * truth(set(first))


def test_the_eta_is_the_compute_left_over_the_compute_done_per_second():
    keys, places, sizes, per_point = _grid_tasks(8)
    w = WorkEstimate(places, sizes, prior=1.0)
    p = Progress(io.StringIO(), "grid", len(keys), sum(sizes.values()), 0, work=w)
    p.t0 = 100.0
    for k in keys[:4]:
        p.update(sizes[k], key=k, seconds=2.0)      # 8 s of compute ...
    p.t_last = 104.0                                # the last came back at 104 s
    # at 105 s: 8 s of compute done in 5 s of wall (1.6 s a second); 4 tasks left at 2 s
    # each (the done ones' cost per point, all equal here), less the 1.6 s the tasks in
    # flight did since the last came back
    assert p.eta(105.0) == pytest.approx((8.0 - 1.6 * 1.0) / 1.6, rel=1e-9)
    assert 0.0 <= p.eta(105.5) < p.eta(105.0)


def test_a_line_without_an_estimate_keeps_the_points_rate():
    p = Progress(io.StringIO(), "atlas round 2", 4, 400, 0)
    p.t0 = 0.0
    p.update(100)
    p.update(100)
    # 200 points in (now - t0) seconds, 200 left
    assert p.eta(p.t0 + 10.0) == pytest.approx(10.0)
