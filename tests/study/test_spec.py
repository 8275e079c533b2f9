"""study.spec, the study file: parsing, defaults, canonical form and hash, validation errors,
the scene files in scenes/."""
from __future__ import annotations

import json
import math

from hypothesis import given, settings, strategies as hs
import numpy as np
import pytest

from hertzmap.study.spec import (DEFAULT_OUTPUTS, MAX_GRID_POINTS, Study, StudyError, load_study,
                        parse_study)
from tests.helpers import REPO


def test_scene_files_are_valid_studies():
    root = REPO / "scenes"
    scenes = sorted(root.glob("fig*.toml"))
    assert len(scenes) >= 10
    for f in scenes:
        s = load_study(f)
        assert s.name == f.stem
        assert s.size <= 20_000, f        # a few minutes at most on 2 cores


MINIMAL = """
[grid]
omega = {start = 0.5, stop = 2.5, num = 5}
sigma = [0.1, 0.2]
zeta = 0.01
"""


def parse(text: str, name: str = "t") -> Study:
    return parse_study(text, default_name=name)


def with_grid(omega="[1.0]", sigma="[0.1]", zeta="[0.01]", extra="") -> str:
    return f"[grid]\nomega = {omega}\nsigma = {sigma}\nzeta = {zeta}\n{extra}"


# -- validation errors name the field and the allowed range ------------------------------------

#: the paper's rig (f0 = 271.01 Hz: a rate of 1 in omega per unit tau is 2 pi f0^2 = 461482 Hz/s)
RIG = "[rig]\nE = 2.1e11\nnu = 0.29\nR = 0.0127\nm = 7.1\nN = 69.7\n"

BAD = [
    # (text, field in the message, words of the allowed range)
    (with_grid(omega="[0.0]"), "grid.omega[0]", "> 0"),
    (with_grid(omega="[-1.0, 1.0]"), "grid.omega[0]", "> 0"),
    (with_grid(sigma="[-0.1]"), "grid.sigma[0]", ">= 0"),
    (with_grid(zeta="-0.5"), "grid.zeta", ">= 0"),
    (with_grid(omega="[nan]"), "grid.omega[0]", "finite"),
    (with_grid(omega="[inf]"), "grid.omega[0]", "finite"),
    (with_grid(sigma='["a"]'), "grid.sigma[0]", "number"),
    (with_grid(omega="[]"), "grid.omega", "at least one"),
    (with_grid(omega="[1.0, 2.0, 1.0]"), "grid.omega", "duplicated"),
    (with_grid(sigma="{start = 0.1, stop = 0.1, num = 3}"), "grid.sigma", "duplicated"),
    (with_grid(omega="{start = 0.5, stop = 2.0, num = 0}"), "grid.omega.num", ">= 1"),
    (with_grid(omega="{start = 0.5, stop = 2.0, num = 2.5}"), "grid.omega.num", "integer"),
    (with_grid(omega="{start = 0.5, stop = 2.0, num = 1}"), "grid.omega.num", "ambiguous"),
    (with_grid(omega="{start = 0.5, num = 3}"), "grid.omega.stop", "missing"),
    (with_grid(omega="{start = 0.0, stop = 2.0, num = 3}"), "grid.omega.start", "> 0"),
    (with_grid(omega="{start = 0.5, stop = 2.0, num = 3, step = 1}"), "grid.omega.step", "unknown key"),
    (with_grid(omega='"1.0"'), "grid.omega", "expected a number"),
    ("[grid]\nomega = [1.0]\nsigma = [0.1]\n", "grid.zeta", "missing"),
    ("[grid]\nomega = [1.0]\nsigma = [0.1]\nzeta = [0.1]\ntheta = [1.0]\n", "grid.theta", "unknown key"),
    ("[study]\nname = 'x'\n", "grid", "missing required table"),
    (with_grid(omega="{start = 0.1, stop = 10.0, num = 5000}",
               sigma="{start = 0.1, stop = 1.0, num = 5000}"), "grid", str(MAX_GRID_POINTS)),
    (with_grid(extra='[model]\nkind = "linear"\n'), "model.kind", "'hertz', 'taylor'"),
    (with_grid(extra="[model]\nexponent = 0.0\n"), "model.exponent", "0 < exponent <= 3"),
    (with_grid(extra="[model]\nexponent = 3.5\n"), "model.exponent", "0 < exponent <= 3"),
    (with_grid(extra='[model]\nkind = "taylor"\nexponent = 1.5\n'), "model.exponent", "only allowed"),
    (with_grid(extra="[solver]\nrtol = 1e-3\n"), "solver.rtol", "1e-13 <= rtol <= 0.0001"),
    (with_grid(extra="[solver]\nrtol = 1e-15\n"), "solver.rtol", "1e-13 <= rtol <= 0.0001"),
    # removed with store format 2 (every orbit stored): the message says to delete it
    (with_grid(extra="[solver]\nmax_solutions = 4\n"), "solver.max_solutions", "delete this key"),
    (with_grid(extra='[search]\ncontinue_unstable = "some"\n'), "search.continue_unstable",
     "'searched-periods', 'all'"),
    (with_grid(extra="[solver]\natol = 1e-9\n"), "solver.atol", "unknown key"),
    (with_grid(extra="[search]\nperiods = [17]\n"), "search.periods", "1..16"),
    (with_grid(extra="[search]\nperiods = [0, 1]\n"), "search.periods", "1..16"),
    (with_grid(extra='[search]\nattractors = "sometimes"\n'), "search.attractors",
     "where-none-stable"),
    (with_grid(extra="[search]\ninitial_states = 0\n"), "search.initial_states", "1..64"),
    (with_grid(extra="[search]\ninitial_states = 65\n"), "search.initial_states", "1..64"),
    (with_grid(extra="[search]\ntransient_periods = 5\n"), "search.transient_periods",
     "10..100000"),
    (with_grid(extra="[search]\nrecord_periods = 1.5\n"), "search.record_periods", "32..10000"),
    (with_grid(extra='[search]\nattractors = "never"\ninitial_states = 8\n'),
     "search.initial_states", "only meaningful"),
    (with_grid(extra="[search]\nperiods = []\n"), "search.periods", "non-empty"),
    (with_grid(extra="[search]\nperiods = [1, 1]\n"), "search.periods", "duplicated"),
    (with_grid(extra='[products]\noutputs = ["orbits", "movies"]\n'), "products.outputs", "measures"),
    (with_grid(extra='[products]\noutputs = "orbits"\n'), "products.outputs", "list"),
    (with_grid(extra='[study]\nname = "a b"\n'), "study.name", "letters, digits"),
    (with_grid(extra='[study]\nowner = "me"\n'), "study.owner", "unknown key"),
    (with_grid(extra="[rig]\nE = 2e11\nnu = 0.3\nR = 0.01\nm = 1.0\n"), "rig.N", "missing"),
    (with_grid(extra="[rig]\nE = -2e11\nnu = 0.3\nR = 0.01\nm = 1.0\nN = 10\n"), "rig.E", "> 0"),
    (with_grid(extra="[rig]\nE = 2e11\nnu = 0.6\nR = 0.01\nm = 1.0\nN = 10\n"), "rig.nu", "0.5"),
    (with_grid(extra='[rig]\nE = 2e11\nnu = 0.3\nR = 0.01\nm = 1.0\nN = 10\ncontact = "triple"\n'),
     "rig.contact", "'double', 'single'"),
    (with_grid(extra="[cluster]\nworkers = 4\n"), "cluster", "unknown key"),
    # the sweeps output and its [sweep] table
    (with_grid(extra='[products]\noutputs = ["sweeps"]\n'), "products.outputs",
     "grid.omega (sweep.axis), which has 1 value"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\n'
               'axis = "sigma"\n'), "products.outputs", "grid.sigma (sweep.axis)"),
    (with_grid(omega="[1.0, 1.1]", extra='[sweep]\naxis = "omega"\n'), "sweep",
     '"sweeps" in products.outputs'),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\naxis = "zeta"\n'), "sweep.axis", "'omega', 'sigma'"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\njump_tol = 0.0\n'), "sweep.jump_tol", "1e-10 <= jump_tol <= 0.1"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\njump_tol = 0.5\n'), "sweep.jump_tol", "1e-10 <= jump_tol <= 0.1"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\njump_tol = "fine"\n'), "sweep.jump_tol", "1e-10 <= jump_tol <= 0.1"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\nsettle_periods = 5\n'), "sweep.settle_periods", "10..1000000"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\nsettle_periods = 100.5\n'), "sweep.settle_periods", "10..1000000"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\nrecord_periods = 20000\n'), "sweep.record_periods", "32..10000"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\nsteps = 10\n'), "sweep.steps", "unknown key"),
    # [sweep] rates: the swept sines (per unit tau), or rates_hz_per_s on a [rig]
    *[(with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\n'
                 f"rates = {r}\n"), "sweep.rates", words)
      for r, words in (("[0.0]", "1e-09 <= rate <= 0.01"), ("[-1e-5]", "1e-09 <= rate <= 0.01"),
                       ("[0.1]", "1e-09 <= rate <= 0.01"), ("[1e-12]", "1e-09 <= rate <= 0.01"),
                       ('["fast"]', "expected a number"), ("[nan]", "finite"),
                       ("[inf]", "finite"), ("1e-5", "expected a list"),
                       ("[1e-5, 1e-5]", "duplicated"), ("[true]", "expected a number"),
                       # 1.1^2 - 1^2 over 4 pi rate: 2e7 forcing cycles, over the limit
                       ("[1e-9]", "at least 1.67e-09"))],
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\n'
               "rates = [1e-5]\nrates_hz_per_s = [4.6]\n" + RIG), "sweep.rates_hz_per_s",
     "not both"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\n'
               "rates_hz_per_s = [4.6]\n"), "sweep.rates_hz_per_s", "needs a [rig]"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\n'
               "rates_hz_per_s = [0.0]\n" + RIG), "sweep.rates_hz_per_s", "Hz/s"),
    (with_grid(omega="[1.0, 1.1]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\n'
               "rates_hz_per_s = [1e5]\n" + RIG), "sweep.rates_hz_per_s", "<= 4615 Hz/s"),
    (with_grid(sigma="[0.1, 0.2]", extra='[products]\noutputs = ["sweeps"]\n[sweep]\n'
               'axis = "sigma"\nrates_hz_per_s = [4.6]\n' + RIG), "sweep.rates_hz_per_s",
     'only with axis = "omega"'),
    ("[grid\nomega = 1", "toml", "not valid TOML"),
]


# -- the CLI: exit code 2, message on stderr, nothing on disk -----------------------------------


# -- parsing and defaults -------------------------------------------------------------------

def test_minimal_study_defaults():
    s = parse(MINIMAL)
    assert s.name == "t" and s.description == ""
    assert s.omega == (0.5, 1.0, 1.5, 2.0, 2.5)
    assert s.sigma == (0.1, 0.2) and s.zeta == (0.01,)
    assert s.shape == (5, 2, 1) and s.size == 10
    assert (s.model, s.exponent, s.rtol) == ("hertz", 1.5, 1e-10)
    assert s.periods == (1, 2)
    # the attractor census runs by default at every point, so its variables are stored
    assert s.outputs == DEFAULT_OUTPUTS + ("attractors",)
    assert s.rig is None
    # force_harmonics is not among the default products: the solver skips their quadrature
    assert s.solver_kwargs() == {"periods": (1, 2), "exponent": 1.5, "model": "hertz",
                                 "rtol": 1e-10, "harmonics": False,
                                 "attractors": "always", "initial_states": 16,
                                 "transient_periods": 500, "record_periods": 128,
                                 "max_transient_periods": 20_000, "point_steps": 2_000_000}


def test_full_study():
    s = parse("""
[study]
name = "full-1"
description = "everything"
[grid]
omega = [2.0, 1.0]
sigma = {start = 0.0, stop = 1.0, num = 3}
zeta = [0.0, 0.5]
[model]
kind = "hertz"
exponent = 1.0
[solver]
rtol = 1e-8
[search]
periods = [2]
[products]
outputs = ["force_harmonics", "diagnostics"]
[rig]
E = 2.1e11
nu = 0.3
R = 0.0127
m = 1.2
N = 50
contact = "single"
""")
    assert s.name == "full-1" and s.description == "everything"
    assert s.omega == (2.0, 1.0)          # order kept (a downward sweep)
    assert s.sigma == (0.0, 0.5, 1.0)
    assert (s.exponent, s.rtol, s.periods) == (1.0, 1e-8, (2,))
    assert s.outputs == ("orbits", "force_harmonics", "diagnostics", "attractors")  # orbits always
    assert s.rig_dict == {"E": 2.1e11, "nu": 0.3, "R": 0.0127, "m": 1.2, "N": 50.0,
                          "contact": "single"}


def test_taylor_model_has_no_exponent():
    s = parse(with_grid(extra='[model]\nkind = "taylor"\n'))
    assert s.model == "taylor" and s.exponent is None
    assert s.solver_kwargs()["model"] == "taylor"


def test_linspace_is_inclusive_and_exact_at_ends():
    s = parse(with_grid(omega="{start = 0.1, stop = 0.7, num = 7}"))
    assert s.omega[0] == 0.1 and s.omega[-1] == 0.7 and len(s.omega) == 7
    np.testing.assert_allclose(s.omega, np.linspace(0.1, 0.7, 7), rtol=0, atol=1e-15)


def test_hash_ignores_formatting_but_not_content():
    a = parse(MINIMAL)
    b = parse("# a comment\n[grid]\nzeta=[0.01]\nsigma=[0.1,0.2]\nomega=[0.5,1.0,1.5,2.0,2.5]\n"
              "[solver]\nrtol=1e-10\n")
    assert a.canonical_json() == b.canonical_json() and a.hash == b.hash
    c = parse(MINIMAL.replace("zeta = 0.01", "zeta = 0.02"))
    assert c.hash != a.hash
    d = parse(MINIMAL + "[solver]\nrtol = 1e-9\n")
    assert d.hash != a.hash
    assert len(a.hash) == 64 and int(a.hash, 16) >= 0
    doc = json.loads(a.canonical_json())
    assert doc["grid"]["omega"] == [0.5, 1.0, 1.5, 2.0, 2.5]
    assert doc["products"]["outputs"] == list(DEFAULT_OUTPUTS) + ["attractors"]


def test_study_is_frozen_and_source_text_kept():
    s = parse(MINIMAL)
    with pytest.raises(Exception):
        s.rtol = 1.0  # type: ignore[misc]
    assert s.source_text == MINIMAL
    assert s == parse(MINIMAL + "\n# trailing comment\n")   # text is not part of equality


def test_load_study_name_defaults_to_stem(tmp_path):
    p = tmp_path / "my_map.toml"
    p.write_text(MINIMAL)
    assert load_study(p).name == "my_map"
    with pytest.raises(StudyError, match="^file: cannot read"):
        load_study(tmp_path / "missing.toml")


@settings(max_examples=60, deadline=None)
@given(start=hs.floats(0.01, 10), span=hs.floats(0.01, 10), num=hs.integers(2, 400))
def test_linspace_axes_are_distinct_and_hash_stable(start, span, num):
    text = with_grid(omega=f"{{start = {start!r}, stop = {start + span!r}, num = {num}}}")
    s = parse(text)
    assert len(s.omega) == num and len(set(s.omega)) == num
    assert all(math.isfinite(x) and x > 0 for x in s.omega)
    assert parse(text).hash == s.hash


@pytest.mark.parametrize("text,field,allowed", BAD, ids=[f"{b[1]}-{i}" for i, b in enumerate(BAD)])
def test_validation_error_names_field_and_range(text, field, allowed):
    with pytest.raises(StudyError) as info:
        parse(text)
    assert isinstance(info.value, ValueError)
    assert info.value.field == field
    msg = str(info.value)
    assert msg.startswith(f"{field}: "), msg
    assert allowed in msg, msg


def test_shipped_studies_are_valid():
    for path in sorted((REPO / "scenes").glob("*.toml")):
        s = load_study(path)
        assert s.size >= 1, path


def test_search_discover_option():
    from hertzmap.study.spec import parse_study
    base = '[grid]\nomega = [1.0, 1.5]\nsigma = [0.2]\nzeta = [0.01]\n'
    plain = parse_study(base, default_name="s")
    assert plain.discover is False and "discover" not in plain.solver_kwargs()
    on = parse_study(base + '[search]\ndiscover = true\ntransients = 8\n', default_name="s")
    assert on.solver_kwargs()["discover"] is True and on.solver_kwargs()["transients"] == 8
    assert on.hash != plain.hash
    # absent and explicitly false are the same study (and the hash of studies that predate the
    # option is unchanged: the key is not in their canonical form)
    assert parse_study(base + '[search]\ndiscover = false\n', default_name="s").hash == plain.hash
    assert "discover" not in plain.to_dict()["search"]
    for bad, field in [('discover = "yes"', "search.discover"), ("discover = 1", "search.discover"),
                       ("discover = true\ntransients = 0", "search.transients"),
                       ("discover = true\ntransients = 2.5", "search.transients"),
                       ("transients = 4", "search.transients")]:
        with pytest.raises(StudyError, match=field.replace(".", r"\.")):
            parse_study(base + "[search]\n" + bad + "\n", default_name="s")


def test_search_periods_and_the_census_fields():
    base = '[grid]\nomega = [1.0, 1.5]\nsigma = [0.2]\nzeta = [0.01]\n'
    s = parse_study(base + "[search]\nperiods = [4, 1, 2]\n", default_name="s")
    assert s.periods == (1, 2, 4) and s.solver_kwargs()["periods"] == (1, 2, 4)
    three = parse_study(base + "[search]\nperiods = [3]\n", default_name="s")
    assert three.periods == (3,) and three.attractors == "always"
    # a 1T-only scene pays nothing for the census unless it asks
    one = parse_study(base + "[search]\nperiods = [1]\n", default_name="s")
    assert one.attractors == "never" and "attractors" not in one.outputs
    assert one.solver_kwargs()["attractors"] == "never"
    asked = parse_study(base + '[search]\nperiods = [1]\nattractors = "always"\n'
                        "initial_states = 4\ntransient_periods = 200\nrecord_periods = 64\n",
                        default_name="s")
    kw = asked.solver_kwargs()
    assert {k: kw[k] for k in ("attractors", "initial_states", "transient_periods",
                               "record_periods")} == {"attractors": "always", "initial_states": 4,
                                                      "transient_periods": 200,
                                                      "record_periods": 64}
    assert "attractors" in asked.outputs
    # the canonical form reads back as the same study
    again = parse_study(_toml_of(asked.to_dict()), default_name="s")
    assert again.hash == asked.hash


def test_the_exponent_error_target():
    """search.lyapunov_error: optional (absent, the study's hash is unchanged), passed to the
    census, refused out of range or without a census, naming the field."""
    base = '[grid]\nomega = [1.0, 1.5]\nsigma = [0.2]\nzeta = [0.01]\n[search]\nperiods = [1, 2]\n'
    plain = parse_study(base, default_name="s")
    assert plain.lyapunov_error is None and "lyapunov_error" not in plain.solver_kwargs()
    assert "lyapunov_error" not in plain.to_dict()["search"]
    aimed = parse_study(base + "lyapunov_error = 0.002\n", default_name="s")
    assert aimed.solver_kwargs()["lyapunov_error"] == 0.002
    assert aimed.hash != plain.hash
    assert parse_study(_toml_of(aimed.to_dict()), default_name="s").hash == aimed.hash
    for bad in ("0", "-0.1", "2.0", '"small"', "true"):
        with pytest.raises(StudyError, match=r"search\.lyapunov_error: expected a number "
                                             r"1e-06\.\.1"):
            parse_study(base + f"lyapunov_error = {bad}\n", default_name="s")
    with pytest.raises(StudyError, match=r"search\.lyapunov_error: only meaningful"):
        parse_study(base + 'attractors = "never"\nlyapunov_error = 0.01\n', default_name="s")


def _toml_of(d) -> str:
    """A study file from a canonical dict (the few value types a study has)."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)
    lines = []
    for table, body in d.items():
        if not isinstance(body, dict):
            continue
        lines.append(f"[{table}]")
        for k, v in body.items():
            if v is not None:
                lines.append(f"{k} = {value(v)}")
    return "\n".join(lines) + "\n"


def test_the_sweeps_output_and_its_sweep_table():
    """products.outputs "sweeps": the [sweep] table's defaults (axis omega, jump_tol 1e-6, 4000 +
    200 periods a step), implied measures, the lines it sweeps, the canonical form (a study
    without it hashes as before: the key is not in its canonical form)."""
    base = '[grid]\nomega = [1.0, 1.1, 1.2]\nsigma = [0.2, 0.3]\nzeta = [0.01]\n'
    plain = parse_study(base, default_name="s")
    assert plain.sweep is None and plain.sweep_lines() == [] and "sweep" not in plain.to_dict()
    s = parse_study(base + '[products]\noutputs = ["sweeps"]\n', default_name="s")
    assert s.sweep_dict == {"axis": "omega", "jump_tol": 1e-6, "settle_periods": 4000,
                            "record_periods": 200}
    assert s.outputs[:2] == ("orbits", "measures") and "sweeps" in s.outputs
    assert s.sweep_lines() == [{"sigma": 0.2, "zeta": 0.01}, {"sigma": 0.3, "zeta": 0.01}]
    assert parse_study(_toml_of(s.to_dict()), default_name="s").hash == s.hash
    written = parse_study(base + '[products]\noutputs = ["sweeps"]\n[sweep]\naxis = "omega"\n'
                          "jump_tol = 1e-6\n", default_name="s")
    assert written.hash == s.hash                   # defaults written out: the same study
    along = parse_study(base + '[products]\noutputs = ["sweeps"]\n[sweep]\naxis = "sigma"\n'
                        "jump_tol = 1e-5\nsettle_periods = 100\nrecord_periods = 64\n",
                        default_name="s")
    assert along.hash != s.hash
    assert along.sweep_dict == {"axis": "sigma", "jump_tol": 1e-5, "settle_periods": 100,
                                "record_periods": 64}
    assert along.sweep_lines() == [{"omega": w, "zeta": 0.01} for w in (1.0, 1.1, 1.2)]


def test_the_sweep_tables_rates():
    """[sweep] rates: none by default (the canonical form and hash as before; rates = [] the
    same), stored per unit tau fastest first, in the canonical form when given (another hash);
    rates_hz_per_s on the study's [rig] converted with its f0 (d omega / d tau = (d f / d t) /
    (2 pi f0^2), tau = 2 pi f0 t, omega = f / f0), the same study as those rates given per unit
    tau."""
    from hertzmap.study.analytic.rig import Rig

    base = ('[grid]\nomega = {start = 0.44, stop = 2.1, num = 167}\nsigma = 0.5\nzeta = 0.01\n'
            '[products]\noutputs = ["sweeps"]\n')
    plain = parse_study(base, default_name="s")
    assert plain.sweep_rates == () and "rates" not in plain.sweep_dict
    assert parse_study(base + "[sweep]\nrates = []\n", default_name="s").hash == plain.hash
    s = parse_study(base + "[sweep]\nrates = [1e-6, 1e-5, 3e-6]\n", default_name="s")
    assert s.sweep_rates == (1e-5, 3e-6, 1e-6) and s.sweep_dict["rates"] == (1e-5, 3e-6, 1e-6)
    assert s.hash != plain.hash and s.to_dict()["sweep"]["rates"] == (1e-5, 3e-6, 1e-6)
    assert parse_study(_toml_of(s.to_dict()), default_name="s").hash == s.hash
    f0 = Rig.hertz(2.1e11, 0.29, 0.0127, 7.1, 69.7).f0
    assert f0 == pytest.approx(271.0, abs=0.1)
    hz = parse_study(base + "[sweep]\nrates_hz_per_s = [0.5, 5.0]\n" + RIG, default_name="s")
    np.testing.assert_allclose(hz.sweep_rates, [5.0 / (2 * math.pi * f0 ** 2),
                                                0.5 / (2 * math.pi * f0 ** 2)], rtol=1e-12)
    same = parse_study(base + f"[sweep]\nrates = {list(hz.sweep_rates)!r}\n" + RIG,
                       default_name="s")
    assert same.hash == hz.hash
    # sigma swept: rates in sigma per unit tau; a study without the sweeps output has none
    sig = parse_study('[grid]\nomega = 1.98\nsigma = [0.3, 0.5]\nzeta = 0.01\n[products]\n'
                      'outputs = ["sweeps"]\n[sweep]\naxis = "sigma"\nrates = [1e-4]\n',
                      default_name="s")
    assert sig.sweep_rates == (1e-4,)
    assert parse_study(MINIMAL, default_name="t").sweep_rates == ()
