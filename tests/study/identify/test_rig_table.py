"""study.identify.rig_table: the rig table of a fit, its defaults and every field's refusal."""
from __future__ import annotations

import math

import pytest

from hertzmap.study.identify.measurement import FitInputError
from hertzmap.study.identify.rig_table import (F0_TOLERANCE, SIGMA_TOLERANCE, ZETA_BOUNDS,
                                               rig_table)

#: paper section 4: E = 210 GPa, nu = 0.29, R = 12.7 mm, m = 7.1 kg, N = 69.7 N, a ball between
#: two flats: f0 = 271 Hz (paper Eq. 29c)
PAPER_RIG = """\
[rig]
N = 69.7
m = 7.1
E = 2.1e11
nu = 0.29
R = 0.0127
contact = "double"
[excitation]
force_N = 20.91
"""


def test_hertz_theory_gives_the_papers_f0_and_the_defaults_give_the_bounds():
    rig = rig_table(PAPER_RIG)
    assert rig.f0_source == "hertz" and abs(rig.f0 - 271.0) < 0.5        # paper Eq. 29c
    assert rig.f0_bounds == pytest.approx((rig.f0 * (1 - F0_TOLERANCE),
                                           rig.f0 * (1 + F0_TOLERANCE)))
    assert rig.sigma == pytest.approx(0.3) and rig.N == 69.7
    assert rig.sigma_bounds == pytest.approx((0.3 * (1 - SIGMA_TOLERANCE),
                                              0.3 * (1 + SIGMA_TOLERANCE)))
    assert rig.zeta_bounds == ZETA_BOUNDS and math.isnan(rig.zeta)
    assert not rig.fit_exponent and rig.text == PAPER_RIG


def test_a_measured_f0_is_the_nominal_one_and_bounds_can_be_given():
    rig = rig_table({"rig": {"N": 69.7, "f0": 270.6, "f0_bounds": [260.0, 280.0]},
                     "excitation": {"sigma": 0.3, "sigma_bounds": [0.2, 0.5]},
                     "damping": {"zeta": 0.005, "bounds": [0.002, 0.02]},
                     "model": {"fit_exponent": True, "exponent_bounds": [1.2, 1.8]}})
    assert rig.f0 == 270.6 and rig.f0_source == "measured" and math.isnan(rig.f0_hertz)
    assert rig.f0_bounds == (260.0, 280.0) and rig.sigma_bounds == (0.2, 0.5)
    assert rig.zeta == 0.005 and rig.zeta_bounds == (0.002, 0.02)
    assert rig.fit_exponent and rig.exponent_bounds == (1.2, 1.8)


@pytest.mark.parametrize("table, field, message", [
    ({"excitation": {"sigma": 0.3}}, "rig", "missing"),
    ({"rig": {"f0": 270.0}, "excitation": {"sigma": 0.3}}, "rig.N", "missing"),
    ({"rig": {"N": -1.0, "f0": 270.0}, "excitation": {"sigma": 0.3}}, "rig.N",
     "-1.0 N is out of range; give N > 0"),
    ({"rig": {"N": 69.7}, "excitation": {"sigma": 0.3}}, "rig.f0", "missing"),
    ({"rig": {"N": 69.7, "m": 7.1}, "excitation": {"sigma": 0.3}}, "rig.E",
     "needs all of m, E, nu, R"),
    ({"rig": {"N": 69.7, "m": 7.1, "E": 2e11, "nu": 0.6, "R": 0.01},
      "excitation": {"sigma": 0.3}}, "rig.nu", "give -1 < nu < 0.5"),
    ({"rig": {"N": 69.7, "f0": 270.0, "contact": "triple", "m": 1, "E": 1, "nu": 0.3, "R": 1},
      "excitation": {"sigma": 0.3}}, "rig.contact", "'triple'"),
    ({"rig": {"N": 69.7, "f0": 270.0, "f0_tolerance": 0.9}, "excitation": {"sigma": 0.3}},
     "rig.f0_tolerance", "give 0.001 <= f0_tolerance <= 0.5"),
    ({"rig": {"N": 69.7, "f0": 270.0, "f0_bounds": [280.0, 290.0]},
      "excitation": {"sigma": 0.3}}, "rig.f0_bounds", "does not hold the nominal f0"),
    ({"rig": {"N": 69.7, "f0": 270.0, "f0_bounds": [280.0]}, "excitation": {"sigma": 0.3}},
     "rig.f0_bounds", "expected two numbers"),
    ({"rig": {"N": 69.7, "f0": 270.0}}, "excitation", "missing"),
    ({"rig": {"N": 69.7, "f0": 270.0}, "excitation": {"sigma": 0.3, "force_N": 20.0}},
     "excitation", "exactly one of force_N"),
    ({"rig": {"N": 69.7, "f0": 270.0}, "excitation": {"force_N": 500.0}},
     "excitation.force_N", "a fit searches sigma <= 4"),
    ({"rig": {"N": 69.7, "f0": 270.0}, "excitation": {"sigma": "0.3"}}, "excitation.sigma",
     "expected a number"),
    ({"rig": {"N": 69.7, "f0": 270.0}, "excitation": {"sigma": 0.3, "tolerance": 1.5}},
     "excitation.tolerance", "give 0.01 <= tolerance <= 0.9"),
    ({"rig": {"N": 69.7, "f0": 270.0}, "excitation": {"sigma": 0.3},
      "damping": {"zeta": 0.2}}, "damping.zeta", "outside damping.bounds"),
    ({"rig": {"N": 69.7, "f0": 270.0}, "excitation": {"sigma": 0.3},
      "damping": {"bounds": [0.05, 0.01]}}, "damping.bounds", "low < high"),
    ({"rig": {"N": 69.7, "f0": 270.0}, "excitation": {"sigma": 0.3},
      "model": {"exponent_bounds": [1.0, 2.0]}}, "model.exponent_bounds",
     "only with fit_exponent = true"),
    ({"rig": {"N": 69.7, "f0": 270.0}, "excitation": {"sigma": 0.3},
      "model": {"exponent": 4.0}}, "model.exponent", "give 0 < exponent <= 3"),
    ({"rig": {"N": 69.7, "f0": 270.0, "mass": 7.1}, "excitation": {"sigma": 0.3}},
     "rig.mass", "unknown key"),
    ({"rig": {"N": 69.7, "f0": 270.0}, "excitation": {"sigma": 0.3}, "sweep": {}}, "sweep",
     "unknown table"),
])
def test_each_bad_field_is_named_with_what_is_allowed(table, field, message):
    with pytest.raises(FitInputError) as exc:
        rig_table(table, source="rig.toml")
    assert exc.value.field == field, str(exc.value)
    assert message in str(exc.value) and str(exc.value).startswith(f"rig.toml: {field}: ")


def test_a_file_that_is_not_toml_or_is_missing_is_refused(tmp_path):
    bad = tmp_path / "rig.toml"
    bad.write_text("[rig\nN = 1\n")
    with pytest.raises(FitInputError, match="not valid TOML"):
        rig_table(bad)
    with pytest.raises(FitInputError, match="cannot read the rig table"):
        rig_table(tmp_path / "none.toml")
