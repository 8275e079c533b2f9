"""study.explore_sweeps: the explore page's stepped-sine sweeps through a clicked point, without
a browser: the grid values swept, the sweeps against study.solve.sweep.stepped_sweep called
directly, the store's sweeps product read back."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from hertzmap.study import explore_data as E
from hertzmap.study import explore_sweeps as ES
from hertzmap.study import products as P
from hertzmap.study.spec import parse_study
from tests.helpers import blank_results
from tests.study.test_explore_data import SWEEP_LINE


def test_sweep_values_are_the_grid_or_one_value_in_k_through_the_clicked_one():
    ds = xr.Dataset(coords={"omega": np.linspace(0.5, 2.5, 161), "sigma": [0.5],
                            "zeta": [0.01]})
    values, stride = ES.sweep_values(ds, "omega", 1.9, 0.5)
    np.testing.assert_array_equal(values, ds["omega"].values)    # 161 <= MAX_SWEEP_STEPS
    assert stride == 1 and ES.MAX_SWEEP_STEPS >= 161
    values, stride = ES.sweep_values(ds, "omega", 1.9, 0.5, max_steps=20)
    grid = ds["omega"].values
    assert stride == 9 and values.size <= 20
    assert values[0] == grid[0] and values[-1] == grid[-1]        # the map's range
    assert grid[np.argmin(np.abs(grid - 1.9))] in values          # through the clicked value
    inner = values[1:-1]
    np.testing.assert_allclose(np.diff(inner), 9 * 0.0125)         # one grid value in 9
    assert np.all(np.diff(values) > 0)
    # a grid listed downwards is swept on increasing values all the same
    down = ds.assign_coords(omega=grid[::-1])
    np.testing.assert_array_equal(ES.sweep_values(down, "omega", 1.9, 0.5)[0], grid)
    with pytest.raises(ValueError, match="one sigma value"):
        ES.sweep_values(ds, "sigma", 1.9, 0.5)
    with pytest.raises(ValueError, match="omega or sigma"):
        ES.sweep_values(ds, "zeta", 1.9, 0.5)


def _direct_sweeps(axis, values, fixed, settings):
    from hertzmap.study.solve.sweep import stepped_sweep
    return {d: stepped_sweep(axis, values, fixed, d, x0=(0.0, 0.0), **settings)
            for d in ("up", "down")}


def test_line_sweep_is_stepped_sweep_up_and_down_through_the_point():
    from hertzmap.study.solve.sweep import force_components

    ds = P.open_store(blank_results(SWEEP_LINE, "swept"))
    study = parse_study(SWEEP_LINE)
    settings = dict(exponent=1.5, model="hertz", rtol=study.rtol, jump_tol=1e-6,
                    settle_periods=4000, record_periods=200)
    assert ES.sweep_settings(ds) == {**settings, "x0": (0.0, 0.0)}
    sw = ES.line_sweep(ds, "omega", 1.981, 0.49, 0.01)        # the nearest grid point's line
    assert sw["axis"] == "omega" and sw["source"] == "computed"
    assert sw["fixed"] == {"sigma": 0.5, "zeta": 0.01} and sw["stride"] == 1
    assert sw["grid_step"] == pytest.approx(0.01)
    grid = np.array([1.96, 1.97, 1.98, 1.99, 2.0])
    np.testing.assert_array_equal(sw["value"], grid)
    direct = _direct_sweeps("omega", grid, {"sigma": 0.5, "zeta": 0.01}, settings)
    for d, ref in direct.items():
        a = ref.arrays()
        order = slice(None) if d == "up" else slice(None, None, -1)   # to increasing omega
        h1, h2, h12 = force_components(a["force_harmonics"], a["period"])
        for name, want in (("H1", h1), ("H2", h2), ("H1_2", h12), ("ptp", a["ptp"]),
                           ("period", a["period"]), ("settled", a["settled"])):
            np.testing.assert_allclose(np.asarray(sw[d][name], float),
                                       np.asarray(want, float)[order], rtol=1e-9, err_msg=name)
        assert sw["seconds"][d] > 0
    # up from rest: 1T to the flip at omega 1.97758, then 2T; down: 2T all the way
    np.testing.assert_array_equal(sw["up"]["period"], [1, 1, 2, 2, 2])
    np.testing.assert_array_equal(sw["down"]["period"], [2, 2, 2, 2, 2])
    (j,) = sw["jumps"]
    assert (j["direction"], j["kind"], j["from_period"], j["to_period"]) == ("up", "flip", 1, 2)
    assert (j["from_step"], j["to_step"]) == (1, 2) and j["located"]
    assert abs(j["value"] - 1.97757924) < 1e-6
    assert j["value"] == direct["up"].jumps[0].value

    # in the page's units: Hz, N, um; the up path broken at its jump, the down one whole
    u = E.units_of(ds)
    cols = ES.sweep_columns(sw, u)
    up, down = cols["up"], cols["down"]
    assert np.isnan(up["value"][2]) and up["value"].size == 6 and down["value"].size == 5
    np.testing.assert_array_equal(up["value"][[0, 1, 3, 4, 5]], grid)
    np.testing.assert_allclose(up["x"][[0, 1, 3, 4, 5]], grid * u.freq.factor)
    np.testing.assert_allclose(down["H1"], sw["down"]["H1"] * 69.7)
    np.testing.assert_allclose(down["ptp"], sw["down"]["ptp"] * u.disp.factor)
    jc = cols["jumps"]
    assert jc["kind"] == ["flip"] and jc["direction"] == ["up"]
    assert jc["x"][0] == pytest.approx(j["value"] * u.freq.factor)
    assert jc["H1_0"][0] == pytest.approx(sw["up"]["H1"][1] * 69.7)      # from the 1T step
    assert jc["H1_2_1"][0] == pytest.approx(sw["up"]["H1_2"][2] * 69.7)   # to the 2T step
    assert jc["H1_2_0"][0] == 0.0                   # a 1T response has no subharmonic
    assert cols["xlabel"] == u.freq.label

    # along sigma: the two sigma values of the grid at the clicked omega
    sw = ES.line_sweep(ds, "sigma", 1.98, 0.5, 0.01)
    assert sw["fixed"] == {"omega": 1.98, "zeta": 0.01}
    np.testing.assert_array_equal(sw["value"], [0.45, 0.5])
    ref = _direct_sweeps("sigma", [0.45, 0.5], {"omega": 1.98, "zeta": 0.01}, settings)
    np.testing.assert_allclose(sw["down"]["ptp"], ref["down"].arrays()["ptp"][::-1], rtol=1e-9)
    assert ES.sweep_columns(sw, u)["xlabel"] == u.amp.label


def test_stored_line_sweep_is_the_products_line_and_none_elsewhere():
    from hertzmap.study.products.stepped_sweeps import sweeps_dataset
    from hertzmap.study.solve.sweep_runs import run_sweep, sweep_specs

    ds = P.open_store(blank_results(SWEEP_LINE, "swept"))
    study = parse_study(SWEEP_LINE)
    records = {(s["line"], s["direction"]): run_sweep(s) for s in sweep_specs(study)}
    product = sweeps_dataset(ds, records, study)
    stored = ES.stored_line_sweep(product, "omega", 1.98, 0.5, 0.01)
    computed = ES.line_sweep(ds, "omega", 1.98, 0.5, 0.01)
    assert stored["source"] == "stored" and stored["fixed"] == computed["fixed"]
    np.testing.assert_array_equal(stored["value"], computed["value"])
    for d in ("up", "down"):
        for name in ("H1", "H2", "H1_2", "ptp", "period", "settled"):
            np.testing.assert_allclose(np.asarray(stored[d][name], float),
                                       np.asarray(computed[d][name], float), rtol=1e-9,
                                       err_msg=f"{d} {name}")
    assert [(j["direction"], j["kind"], j["from_step"], j["to_step"]) for j in stored["jumps"]] \
        == [(j["direction"], j["kind"], j["from_step"], j["to_step"]) for j in computed["jumps"]]
    assert stored["jumps"][0]["value"] == pytest.approx(computed["jumps"][0]["value"], abs=1e-12)
    assert stored["settings"]["jump_tol"] == 1e-6
    # the other line of the product, then none: another axis, a line it does not hold, nothing
    other = ES.stored_line_sweep(product, "omega", 1.98, 0.45, 0.01)
    assert other["fixed"] == {"sigma": 0.45, "zeta": 0.01}
    assert ES.stored_line_sweep(product, "sigma", 1.98, 0.5, 0.01) is None
    assert ES.stored_line_sweep(product, "omega", 1.98, 0.47, 0.01) is None
    assert ES.stored_line_sweep(product, "omega", 1.98, 0.5, 0.02) is None
    assert ES.stored_line_sweep(None, "omega", 1.98, 0.5, 0.01) is None
