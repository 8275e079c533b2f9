"""study.identify.fit_dataset: the result's variables are the ones docs/identify.md lists, the
jumps a measurement shows by itself, and how a parameter the data do not determine is said."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from hertzmap.study.identify.fit_dataset import FIT_VARIABLES, measured_jumps, summary_lines
from hertzmap.study.identify.measurement import measurement_from_columns

DOC = Path(__file__).resolve().parents[3] / "docs" / "identify.md"


def test_docs_identify_lists_every_variable_of_the_result():
    text = DOC.read_text()
    missing = [name for name in FIT_VARIABLES if f"`{name}`" not in text]
    assert not missing, missing


def test_a_measured_jump_is_a_change_beyond_the_noise_and_30_percent():
    f = [500.0, 502.0, 504.0, 506.0, 508.0]
    h12 = [0.02, 0.03, 40.0, 38.0, 36.5]             # the subharmonic appears: a jump
    h1 = [10.0, 9.8, 9.6, 9.4, 9.2]                   # smooth
    m = measurement_from_columns({"frequency_hz": f, "direction": ["up"] * 5, "H1_N": h1,
                                  "H2_N": [0.1] * 5, "H1_2_N": h12})
    jumps = measured_jumps(m, a=0.03, b=0.05)
    assert [(j["before"], j["after"], j["harmonic"]) for j in jumps] == [(502.0, 504.0, 2)]
    # within the noise (b = 20 N) it is none
    assert measured_jumps(m, a=0.03, b=20.0) == []


def _ds(lower_closed, upper_closed):
    return xr.Dataset(
        {"best": ("parameter", [0.004]), "lower": ("parameter", [0.001]),
         "upper": ("parameter", [0.05]), "lower_closed": ("parameter", [lower_closed]),
         "upper_closed": ("parameter", [upper_closed]),
         "identified": ("parameter", [int(lower_closed and upper_closed)]),
         "noise_multiplicative": 0.03, "noise_floor": 0.05},
        coords={"parameter": ["zeta"], "parameter_units": ("parameter", ["1"])},
        attrs={"readings": 60})


def test_a_parameter_not_identified_is_said_so_without_a_number():
    line = summary_lines(_ds(0, 0))[0]
    assert "not identified" in line and "0.004" not in line
    assert "[0.001, 0.05]" in line
    line = summary_lines(_ds(0, 1))[0]
    assert "<= 0.05 (95 %; bounded above only" in line and "lower bound 0.001" in line
    assert "0.004" not in line
    line = summary_lines(_ds(1, 1))[0]
    assert "0.004" in line and "95 % interval [0.001, 0.05]" in line
    assert np.isfinite(float(_ds(1, 1)["best"][0]))
