"""study.block's shortcuts change no result: the kernel's result for a seed does not depend on
the batch it is shot in (the block shoots all seeds of one period at a point in one batch), and
the pre-check that spares np.linalg.eig in _flip_seeds drops no flip seed."""
import numpy as np

from kernels import status as st
from study import block

W, S, Z = 1.2, 0.5, 0.01


def _flip_seeds_always_eig(sol):
    """block._flip_seeds without the pre-check."""
    if sol["period"] != 1 or sol["status"] != st.CONVERGED:
        return []
    w, V = np.linalg.eig(sol["monodromy"])
    seeds = []
    for k in range(2):
        if abs(w[k].imag) < 1e-12 and w[k].real < -0.95:
            e = np.real(V[:, k])
            e /= np.linalg.norm(e)
            for d in block.FLIP_SEED_OFFSETS:
                seeds.append(tuple(sol["x0"] + d * e))
                seeds.append(tuple(sol["x0"] - d * e))
    return seeds


def test_results_do_not_depend_on_batching():
    for period, seeds in ((1, [block.linear_response_seed(W, S, Z), (0.3, -0.2), (-1.0, 0.5)]),
                          (2, [(-3.06, -1.40), (0.5, 0.5), (-2.0, 1.0)])):
        options = dict(max_iter=block.MAX_ITER_1T if period == 1 else block.MAX_ITER_2T)
        batch = block._solve(W, S, Z, period, seeds, options)
        alone = [block._solve(W, S, Z, period, [seed], options)[0] for seed in seeds]
        assert any(s["status"] == st.CONVERGED for s in batch)
        for a, b in zip(batch, alone):
            assert a.keys() == b.keys()
            for key in a:
                np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_flip_seed_precheck_drops_no_seed(monkeypatch):
    with_seeds, checked = [], []
    fast = block._flip_seeds

    def compare(sol):
        got = fast(sol)
        assert got == _flip_seeds_always_eig(sol)
        checked.append(sol["period"] == 1 and sol["status"] == st.CONVERGED)
        with_seeds.append(bool(got))
        return got

    monkeypatch.setattr(block, "_flip_seeds", compare)
    block.solve_block(np.linspace(0.5, 2.5, 41), [0.2, 0.5, 0.8], [Z], harmonics=False)
    assert sum(checked) > 50 and any(with_seeds)        # past a flip, seeds were made
    assert sum(with_seeds) < sum(checked)                # elsewhere, none
