"""kernels.api: the batch entry point equals single calls, bad arguments are reported (not
crashed on), the harmonics switch changes nothing else."""
from __future__ import annotations

import numpy as np
import pytest

from hertzmap.kernels import shoot, shoot_batch, status


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
        if name.startswith("force_h") or name in ("mean_force", "rms_force"):
            assert np.isfinite(value).all() and np.isnan(off[name]).all(), name
        else:
            np.testing.assert_array_equal(off[name], value, err_msg=name)


@pytest.mark.parametrize("omega, sigma, zeta, m, guess, exponent", [
    (1.5, 0.2, 0.01, 1, (-0.15, 0.016), 1.5),    # in contact
    (0.8, 1.5, 0.01, 1, (-7.69, 0.18), 1.5),     # long flights
    (1.9, 0.5, 0.01, 2, (-0.08, 1.51), 1.5),     # 2T with contact loss
    (0.5, 0.8, 0.05, 1, (0.71, 0.01), 1.0),      # impacts, n = 1
])
def test_shoot_is_the_batch_kernel_field_for_field(omega, sigma, zeta, m, guess, exponent):
    """kernels.shoot (a read-only view of the kernel's row) gives, bit for bit, what
    shoot_batch gives for the same solve, in every field and every Orbit attribute."""
    from hertzmap.kernels.shooting import FIELDS
    o = shoot(omega, sigma, zeta, m, guess=guess, rtol=1e-9, exponent=exponent)
    b = shoot_batch(omega, sigma, zeta, m, guess[0], guess[1], rtol=1e-9, exponent=exponent)
    assert o.converged
    row = o.row
    for i, name in enumerate(FIELDS):
        np.testing.assert_array_equal(row[i], b[name], err_msg=name)
        np.testing.assert_array_equal(o[name], b[name], err_msg=name)
    assert np.array_equal(o.x0, [b["q0"], b["v0"]])
    assert np.array_equal(o.multipliers, [complex(b["multiplier1_re"], b["multiplier1_im"]),
                                          complex(b["multiplier2_re"], b["multiplier2_im"])])
    assert np.array_equal(o.monodromy, [[b["m11"], b["m12"]], [b["m21"], b["m22"]]])
    assert np.array_equal(o.force_harmonics, [b[f"force_h{k}"] for k in range(1, 5)])
    assert (o.stable, o.loses_contact) == (b["stable"] == 1.0, b["loses_contact"] == 1.0)
    assert (o.steps, o.newton_iterations, o.minimal_period) == (
        b["steps"], b["newton_iterations"], b["minimal_period"])
    for name in ("min_q", "max_q", "ptp", "flight_fraction", "max_impact_velocity",
                 "mean_force", "residual", "liouville_residual", "peak_force", "rms_force"):
        assert getattr(o, name) == b[name], name


def test_an_orbit_cannot_be_changed():
    o = shoot(1.5, 0.2, 0.01, 1, guess=(-0.16, 0.006))
    with pytest.raises(AttributeError):
        o.omega = 2.0
    x0 = o.x0
    x0[0] = 99.0          # a copy: the orbit keeps its start point
    assert o.x0[0] != 99.0 and o.row[1] != 99.0
