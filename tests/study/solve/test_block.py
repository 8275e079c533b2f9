"""study.solve.block (with study.solve.point and seeds): results do not depend on batching or
on the eig pre-check of the flip seeds; a 2T solve landing on the 1T orbit keeps the 1T
multipliers; the time budget cuts a block and records it."""
from __future__ import annotations

from math import pi
import time

import numpy as np

from hertzmap.kernels import status
from hertzmap.kernels import status as st
from hertzmap.study.schema import ATTRACTOR_KINDS
from hertzmap.study.solve import point
from hertzmap.study.solve.block import solve_block
from hertzmap.study.solve.point import MAX_ITER_1T, MAX_ITER_2T, shoot_seeds
from hertzmap.study.solve.seeds import FLIP_SEED_OFFSETS, flip_seeds, linear_response_seed


W, S, Z = 1.2, 0.5, 0.01


def _flip_seeds_always_eig(sol):
    """study.solve.seeds.flip_seeds without the pre-check."""
    if sol["period"] != 1 or sol["status"] != st.CONVERGED:
        return []
    w, V = np.linalg.eig(sol["monodromy"])
    seeds = []
    for k in range(2):
        if abs(w[k].imag) < 1e-12 and w[k].real < -0.95:
            e = np.real(V[:, k])
            e /= np.linalg.norm(e)
            for d in FLIP_SEED_OFFSETS:
                seeds.append(tuple(sol["x0"] + d * e))
                seeds.append(tuple(sol["x0"] - d * e))
    return seeds


def test_results_do_not_depend_on_batching():
    for period, seeds in ((1, [linear_response_seed(W, S, Z), (0.3, -0.2), (-1.0, 0.5)]),
                          (2, [(-3.06, -1.40), (0.5, 0.5), (-2.0, 1.0)])):
        options = dict(max_iter=MAX_ITER_1T if period == 1 else MAX_ITER_2T)
        batch = shoot_seeds(W, S, Z, period, seeds, options)
        alone = [shoot_seeds(W, S, Z, period, [seed], options)[0] for seed in seeds]
        assert any(s["status"] == st.CONVERGED for s in batch)
        for a, b in zip(batch, alone):
            assert a.keys() == b.keys()
            for key in a:
                np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_flip_seed_precheck_drops_no_seed(monkeypatch):
    with_seeds, checked = [], []
    fast = flip_seeds

    def compare(sol):
        got = fast(sol)
        assert got == _flip_seeds_always_eig(sol)
        checked.append(sol["period"] == 1 and sol["status"] == st.CONVERGED)
        with_seeds.append(bool(got))
        return got

    monkeypatch.setattr(point, "flip_seeds", compare)
    solve_block(np.linspace(0.5, 2.5, 41), [0.2, 0.5, 0.8], [Z], harmonics=False)
    assert sum(checked) > 50 and any(with_seeds)        # past a flip, seeds were made
    assert sum(with_seeds) < sum(checked)                # elsewhere, none


def test_block_keeps_1t_multipliers_when_a_2t_solve_lands_on_the_1t_orbit():
    """Regression: a 2T solve landing on the 1T orbit must not store the 2T monodromy."""
    from hertzmap.study.solve.block import solve_block
    omega = np.linspace(1.0, 2.4, 8)
    r = solve_block(omega, np.array([0.3]), np.array([0.01]))
    one = r["period"] == 1
    T = 2 * pi / omega[:, None, None, None] * np.ones_like(r["q0"])
    det = (r["multipliers"][..., 0] * r["multipliers"][..., 1]).real
    np.testing.assert_allclose(det[one], np.exp(-2 * 0.01 * T[one]), rtol=1e-6)
    # no duplicated 1T orbit at a point
    for i in range(omega.size):
        q = r["min_q"][i, 0, 0][r["period"][i, 0, 0] == 1]
        assert np.unique(np.round(q, 8)).size == q.size


def test_zero_budget_records_every_point_as_time_limited():
    r = solve_block(np.linspace(0.5, 2.0, 5), np.array([0.2, 0.4]), np.array([0.01]),
                    time_budget=0.0)
    assert np.all(r["status"][..., 0] == status.TIME_LIMIT)
    assert np.all(r["period"] == 0) and np.all(r["status"][..., 1:] == status.EMPTY)


def test_budget_cuts_a_block_part_way_and_keeps_what_was_solved():
    omega = np.linspace(0.5, 2.5, 400)
    # a budget of a third of what the whole line takes on this machine (a fixed budget stops
    # cutting anything once the kernels get fast enough)
    solve_block(omega[:10], np.array([0.5]), np.array([0.01]))           # compiled and warm
    t0 = time.perf_counter()
    solve_block(omega, np.array([0.5]), np.array([0.01]))
    whole = time.perf_counter() - t0
    r = solve_block(omega, np.array([0.5]), np.array([0.01]), time_budget=whole / 3)
    slot0 = r["status"][:, 0, 0, 0]
    cut = slot0 == status.TIME_LIMIT
    assert cut.any() and not cut.all()
    # the cut is a suffix of the upward sweep: everything solved before it is kept
    first_cut = np.argmax(cut)
    assert np.all(cut[first_cut:]) and np.all(slot0[:first_cut] == status.CONVERGED)


def test_generous_budget_changes_nothing():
    omega = np.linspace(1.5, 2.2, 8)
    a = solve_block(omega, np.array([0.5]), np.array([0.01]))
    b = solve_block(omega, np.array([0.5]), np.array([0.01]), time_budget=600.0)
    for name in a:
        np.testing.assert_array_equal(a[name], b[name])


def test_every_stored_orbit_carries_its_liouville_residual():
    """The certificate stored beside each orbit: checked here from the stored multipliers alone
    (their product against exp(-2 zeta P)), with no kernel value as the expected one."""
    omega = np.array([0.8, 1.5, 1.9, 2.3])
    sigma = np.array([0.2, 0.5])
    zeta = np.array([0.01, 0.05])
    out = solve_block(omega, sigma, zeta, periods=(1, 2))
    ok = out["status"] == st.CONVERGED
    assert ok.sum() >= 16
    r = out["liouville_residual"]
    assert np.all(np.isnan(r[out["status"] == st.EMPTY]))
    assert np.all(r[ok] < 1e-8), r[ok].max()
    w, _, z, _ = np.meshgrid(omega, sigma, zeta, np.arange(r.shape[-1]), indexing="ij")
    expected = np.exp(-2 * z * out["period"] * 2 * pi / w)
    product = np.abs(out["multipliers"][..., 0] * out["multipliers"][..., 1])
    assert np.all(np.abs(product[ok] - expected[ok]) <= 1e-7 * expected[ok])


def test_the_study_s_exponent_error_target_reaches_the_census():
    """search.lyapunov_error through solve_block (as a task calls it) to the census: at the
    chaotic point (0.75, 3.05) the stored exponent's error is at most the target, and the
    periods its average took are stored beside it."""
    kw = dict(periods=(1, 2), attractors="where-none-stable", initial_states=16,
              transient_periods=500, record_periods=128, max_transient_periods=20_000,
              harmonics=False)
    plain = solve_block(np.array([0.75]), np.array([3.05]), np.array([Z]), **kw)
    aimed = solve_block(np.array([0.75]), np.array([3.05]), np.array([Z]), lyapunov_error=0.002,
                        **kw)
    chaotic = ATTRACTOR_KINDS["non_periodic"]
    for arrays in (plain, aimed):
        assert arrays["attractor_kind"][0, 0, 0, 0] == chaotic
    assert plain["lyapunov_error"][0, 0, 0, 0] > 0.002
    assert 0 < aimed["lyapunov_error"][0, 0, 0, 0] <= 0.002
    assert aimed["lyapunov_periods"][0, 0, 0, 0] > plain["lyapunov_periods"][0, 0, 0, 0] > 0
