"""study.identify.problem: the fit's problem, its free parameters and bounds, and the model's
omega grid covering every measured frequency at every f0 within its bounds."""
from __future__ import annotations

import numpy as np
import pytest

from hertzmap.study.identify.forward_model import FORWARD_STEP
from hertzmap.study.identify.measurement import FitInputError, measurement_from_columns
from hertzmap.study.identify.problem import OMEGA_COVERED, OMEGA_MARGIN, fit_problem
from hertzmap.study.identify.rig_table import rig_table


def measurement(freqs):
    n = len(freqs)
    return measurement_from_columns({"frequency_hz": list(freqs), "direction": ["up"] * n,
                                     "H1_N": [1.0] * n, "H2_N": [0.1] * n})


def test_the_grid_covers_the_measurement_at_both_f0_bounds():
    rig = rig_table({"rig": {"N": 69.7, "f0": 271.0, "f0_bounds": [250.0, 290.0]},
                     "excitation": {"sigma": 0.3}})
    p = fit_problem(measurement(np.linspace(200.0, 600.0, 11)), rig)
    assert p.free == ("f0", "sigma", "zeta") and p.directions == ("up",)
    assert p.omega[0] <= 200.0 / 290.0 * (1 - OMEGA_MARGIN) + FORWARD_STEP
    assert p.omega[0] <= 200.0 / 290.0 and p.omega[-1] >= 600.0 / 250.0
    assert np.allclose(np.diff(p.omega), FORWARD_STEP)
    assert np.isnan(p.nominal["zeta"]) and p.bounds["f0"] == (250.0, 290.0)


def test_a_fitted_exponent_is_a_free_parameter_with_its_bounds():
    rig = rig_table({"rig": {"N": 69.7, "f0": 271.0}, "excitation": {"sigma": 0.3},
                     "model": {"fit_exponent": True, "exponent_bounds": [1.2, 1.8]}})
    p = fit_problem(measurement([500.0, 510.0, 520.0]), rig)
    assert p.free == ("f0", "sigma", "zeta", "exponent")
    assert p.bounds["exponent"] == (1.2, 1.8) and p.shape_parameters == ("sigma", "zeta",
                                                                          "exponent")


@pytest.mark.parametrize("freqs, row", [([40.0, 300.0, 500.0], 1), ([300.0, 500.0, 1300.0], 3)])
def test_a_frequency_the_model_cannot_cover_is_refused_with_its_row(freqs, row):
    rig = rig_table({"rig": {"N": 69.7, "f0": 271.0}, "excitation": {"sigma": 0.3}})
    with pytest.raises(FitInputError) as exc:
        fit_problem(measurement(freqs), rig)
    assert (exc.value.row, exc.value.column) == (row, "frequency_hz")
    assert f"the model covers {OMEGA_COVERED[0]:g} <= omega <= {OMEGA_COVERED[1]:g}" in str(
        exc.value)
