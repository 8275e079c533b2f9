"""kernels.api: the batch entry point equals single calls, bad arguments are reported (not
crashed on), the harmonics switch changes nothing else."""
from __future__ import annotations

import numpy as np
import pytest

from kernels import shoot, shoot_batch, status


def test_batch_equals_single_calls():
    om = np.array([1.5, 0.8])
    r = shoot_batch(om, [0.2, 1.5], 0.01, 1, [-0.16, -7.7], [0.006, 0.17])
    for i in range(2):
        o = shoot(om[i], [0.2, 1.5][i], 0.01, 1, guess=([-0.16, -7.7][i], [0.006, 0.17][i]))
        assert r["q0"][i] == o.x0[0] and r["v0"][i] == o.x0[1]


def test_bad_arguments_are_reported_not_crashed():
    o = shoot(-1.0, 0.5, 0.01)
    assert o.status == status.DIVERGED and not o.converged
    o = shoot(1.0, float("nan"), 0.01)
    assert not o.converged
    with pytest.raises(ValueError, match="exponent"):
        shoot(1.0, 0.5, 0.01, exponent=-1)
    with pytest.raises(ValueError, match="model"):
        shoot(1.0, 0.5, 0.01, model="linear")


@pytest.mark.parametrize("omega, sigma, zeta, m, guess", [
    (1.5, 0.2, 0.01, 1, (-0.16, 0.006)),     # in contact
    (0.8, 1.5, 0.01, 1, (-7.7, 0.17)),       # long flights
    (1.9, 0.5, 0.01, 2, (-0.09, 1.5)),       # 2T with contact loss (minimal-period check)
])
def test_harmonics_off_changes_nothing_else(omega, sigma, zeta, m, guess):
    """harmonics=False only skips the force quadrature: every other field is bit-identical."""
    on = shoot_batch(omega, sigma, zeta, m, guess[0], guess[1], rtol=1e-10)
    off = shoot_batch(omega, sigma, zeta, m, guess[0], guess[1], rtol=1e-10, harmonics=False)
    assert on["status"] == 0
    for name, value in on.items():
        if name.startswith("force_h") or name == "mean_force":
            assert np.isfinite(value).all() and np.isnan(off[name]).all(), name
        else:
            np.testing.assert_array_equal(off[name], value, err_msg=name)
