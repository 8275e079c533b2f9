"""study.products.stepped_sweeps: the ``sweeps`` product on a small real store (sigma 0.5, zeta
0.01, omega 1.96-2.0 listed downwards, the paper's rig): its layout (steps in increasing value
order for both directions, the jumps' steps), metadata, harmonics read off the force harmonics,
rig units, the store's orbits linked into branches, and the store opening as one DataTree with
it. The sweeps' numbers themselves are checked against the scipy oracle in
tests/study/solve/test_sweep.py and, through a run, in tests/scheduler/test_sweep_tasks.py."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from hertzmap.scheduler.store import write_product
from hertzmap.study import products as P
from hertzmap.study.analytic.rig import Rig
from hertzmap.study.products.stepped_sweeps import (JUMP_KIND_CODES, force_components,
                                                    run_sweep, sweep_specs, sweeps_dataset)
from hertzmap.study.schema import study_from_attrs
from tests.helpers import RIG_TABLE, solved_results

#: omega listed downwards (the study's order): the product's steps are increasing all the same
STUDY = """
[grid]
omega = [2.0, 1.99, 1.98, 1.97, 1.96]
sigma = 0.5
zeta = 0.01
[search]
periods = [1, 2]
attractors = "never"
[products]
outputs = ["orbits", "measures", "force_harmonics", "sweeps"]
""" + RIG_TABLE


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return solved_results(STUDY, tmp_path_factory.mktemp("sweeps") / "s.zarr", "s")


@pytest.fixture(scope="module")
def sweeps(store):
    return P.stepped_sweeps(P.open_store(store))


def test_force_components_of_orbits_of_each_period():
    fh = np.array([[1.0, 2.0, 3.0, 4.0]] * 5)
    h1, h2, h12 = force_components(fh, np.array([0, 1, 2, 3, 4]))
    np.testing.assert_array_equal(h1, [np.nan, 1.0, 2.0, 3.0, 4.0])     # k = m
    np.testing.assert_array_equal(h2, [np.nan, 2.0, 4.0, np.nan, np.nan])  # k = 2m <= 4
    np.testing.assert_array_equal(h12, [np.nan, 0.0, 1.0, 0.0, 2.0])   # k = m/2, 0 for odd m


def test_the_product_holds_both_sweeps_on_increasing_steps_with_their_jump(sweeps):
    assert dict(sweeps.sizes) == {"line": 1, "direction": 2, "step": 5, "multiplier": 2,
                                  "jump": 1, "branch_point": int(sweeps.sizes["branch_point"])}
    np.testing.assert_array_equal(sweeps["value"], [1.96, 1.97, 1.98, 1.99, 2.0])
    assert sweeps["direction"].attrs["flag_meanings"] == "up down"
    for v in list(sweeps.data_vars) + list(sweeps.coords):
        assert {"long_name", "units", "description"} <= set(sweeps[v].attrs), v
    assert sweeps.attrs["sweep_axis"] == "omega" and sweeps.attrs["sweep_jump_tol"] == 1e-6
    up, down = sweeps.isel(line=0, direction=0), sweeps.isel(line=0, direction=1)
    # up from rest: 1T up to the flip at 1.97758, then the 2T born there; down from rest at
    # omega 2 (past the flip: the 1T orbit unstable) on the 2T all the way
    np.testing.assert_array_equal(up["period"], [1, 1, 2, 2, 2])
    np.testing.assert_array_equal(down["period"], [2, 2, 2, 2, 2])
    assert up["settled"].all() and down["settled"].all() and up["stable"].all()
    (j,) = range(sweeps.sizes["jump"])
    assert int(sweeps["jump_direction"][j]) == 0 and int(sweeps["jump_line"][j]) == 0
    assert int(sweeps["jump_kind"][j]) == JUMP_KIND_CODES["flip"]
    assert (int(sweeps["jump_from_period"][j]), int(sweeps["jump_to_period"][j])) == (1, 2)
    assert (int(sweeps["jump_from_step"][j]), int(sweeps["jump_to_step"][j])) == (1, 2)
    assert abs(float(sweeps["jump_value"][j]) - 1.97757924) < 1e-6
    assert 0 < float(sweeps["jump_accuracy"][j]) <= 1e-6
    assert P.jumps_of(sweeps) == [{
        "line": 0, "sigma": 0.5, "zeta": 0.01, "direction": "up",
        "value": float(sweeps["jump_value"][j]), "accuracy": float(sweeps["jump_accuracy"][j]),
        "kind": "flip", "from_period": 1, "to_period": 2, "located": True}]
    # the harmonics: H1/2 only on the 2T responses, H1 and H2 on all
    np.testing.assert_array_equal(up["H1_2"].values[:2], [0.0, 0.0])
    assert np.all(up["H1_2"].values[2:] > 0.05) and np.all(down["H1_2"] > 0.05)
    assert np.all(up["H1"] > 0) and np.all(np.isfinite(up["H2"]))
    assert int(sweeps["sweep_jumps"].sum()) == 1 and np.all(sweeps["sweep_seconds"] > 0)


def test_the_harmonics_and_steps_are_the_sweeps_own(store, sweeps):
    """Each step of the product is the sweep's step of that value (the down sweep reversed)
    and its H1, H2, H1/2 are the orbit's force harmonics at k omega / m."""
    ds = P.open_store(store)
    study = study_from_attrs(ds.attrs)
    specs = sweep_specs(study)
    assert [(s["line"], s["direction"]) for s in specs] == [(0, "up"), (0, "down")]
    down = run_sweep(specs[1])
    np.testing.assert_array_equal(down["value"], [2.0, 1.99, 1.98, 1.97, 1.96])
    fh = down["force_harmonics"][::-1]                  # on increasing steps; all 2T
    got = sweeps.isel(line=0, direction=1)
    np.testing.assert_allclose(got["H1_2"], fh[:, 0], rtol=1e-6)
    np.testing.assert_allclose(got["H1"], fh[:, 1], rtol=1e-6)
    np.testing.assert_allclose(got["H2"], fh[:, 3], rtol=1e-6)
    np.testing.assert_allclose(got["ptp"], down["ptp"][::-1], rtol=1e-6)
    # a sweep whose task failed is left empty
    empty = sweeps_dataset(ds, {(0, "down"): down}, study)
    assert np.all(empty["period"].isel(direction=0) == 0)
    assert np.all(np.isnan(empty["H1"].isel(direction=0)))
    assert empty.sizes["jump"] == 0


def test_rig_units_and_the_stored_branches(store, sweeps):
    rig = Rig.hertz(2.1e11, 0.29, 0.0127, 7.1, 69.7)
    np.testing.assert_allclose(sweeps["frequency_hz"], sweeps["value"] * rig.f0, rtol=1e-12)
    np.testing.assert_allclose(sweeps["H1_N"], sweeps["H1"] * 69.7, rtol=1e-12)
    np.testing.assert_allclose(sweeps["jump_frequency_hz"], sweeps["jump_value"] * rig.f0,
                               rtol=1e-12)
    np.testing.assert_allclose(sweeps["ptp_m"], sweeps["ptp"] * rig.z_s / 1.5, rtol=1e-12)
    # the store's orbits along the line: every valid orbit once, the stable 1T ones on one
    # branch, each branch of one period
    ds = P.open_store(store)
    assert sweeps.sizes["branch_point"] == int(P.valid_orbits(ds).sum())
    per, bid = sweeps["branch_period"].values, sweeps["branch_id"].values
    for b in np.unique(bid):
        assert np.unique(per[bid == b]).size == 1
    lower = sweeps["branch_value"].values <= 1.97
    one = (per == 1) & sweeps["branch_stable"].values & lower
    assert one.sum() == 2 and np.unique(bid[one]).size == 1
    # the branches' harmonics are the sweeps' where the sweep is on them (the 2T at 1.99)
    at = (sweeps["branch_value"].values == 1.99) & (per == 2) & sweeps["branch_stable"].values
    assert float(sweeps["branch_H1_2"].values[at][0]) == pytest.approx(
        float(sweeps["H1_2"].sel(direction=1).isel(line=0, step=3)), rel=1e-6)


def test_the_store_with_the_product_opens_as_one_datatree(store, sweeps, tmp_path):
    import shutil

    copy = shutil.copytree(store, tmp_path / "tree.zarr")
    write_product(copy, "sweeps", sweeps)
    tree = xr.open_datatree(copy, engine="zarr")
    assert "sweeps" in tree["products"].children
    own = xr.open_zarr(copy, group="products/sweeps").load()
    root = xr.open_zarr(copy)
    for d in set(own.dims) & set(root.dims):
        assert own.sizes[d] == root.sizes[d], d
    assert "omega" not in own.dims and own.sizes["step"] == root.sizes["omega"]
    got = tree["products/sweeps"].to_dataset()
    np.testing.assert_array_equal(got["jump_value"], sweeps["jump_value"])


def test_sweeps_along_sigma(tmp_path):
    """[sweep] axis = "sigma": the lines are the (omega, zeta) of the grid, the steps its sigma
    values; the rig's force amplitude in N. At omega 1.98 the 1T orbit flips on the way up
    (study.solve.sweep's own test checks that flip against the oracle) and the 2T response folds
    back on the way down, below it: hysteresis in the force amplitude."""
    toml = STUDY.replace("omega = [2.0, 1.99, 1.98, 1.97, 1.96]", "omega = 1.98").replace(
        "sigma = 0.5", "sigma = {start = 0.3, stop = 0.5, num = 5}").replace(
        '"sweeps"]', '"sweeps"]\n[sweep]\naxis = "sigma"\njump_tol = 1e-5')
    sw = P.stepped_sweeps(P.open_store(solved_results(toml, tmp_path / "sig.zarr", "sig")))
    assert sw.attrs["sweep_axis"] == "sigma" and sw.attrs["sweep_jump_tol"] == 1e-5
    np.testing.assert_array_equal(sw["line_omega"], [1.98])
    np.testing.assert_allclose(sw["value"], [0.3, 0.35, 0.4, 0.45, 0.5])
    np.testing.assert_allclose(sw["force_amplitude_N"], sw["value"] * 69.7, rtol=1e-12)
    assert "frequency_hz" not in sw.coords
    rows = P.jumps_of(sw)
    assert [(r["direction"], r["kind"], r["from_period"], r["to_period"]) for r in rows] == [
        ("up", "flip", 1, 2), ("down", "fold", 2, 1)]
    up, down = rows[0]["value"], rows[1]["value"]
    assert 0.45 < up < 0.5 and 0.3 < down < 0.35 and rows[0]["accuracy"] <= 1e-5
    np.testing.assert_allclose(sw["jump_force_amplitude_N"], [up * 69.7, down * 69.7])
