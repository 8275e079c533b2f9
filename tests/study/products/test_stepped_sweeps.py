"""study.products.stepped_sweeps: the ``sweeps`` product on a small real store (sigma 0.5, zeta
0.01, omega 1.96-2.0 listed downwards, the paper's rig): its layout (steps in increasing value
order for both directions, the jumps' steps), metadata, harmonics read off the force harmonics,
rig units, the store's orbits linked into branches, and the store opening as one DataTree with
it. The sweeps' numbers themselves are checked against the scipy oracle in
tests/study/solve/test_sweep.py and, through a run, in tests/scheduler/stages/test_sweep_tasks.py."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import xarray as xr

from hertzmap.scheduler.store import write_product
from hertzmap.study import products as P
from hertzmap.study.analytic.rig import Rig
from hertzmap.study.products.stepped_sweeps import sweeps_dataset
from hertzmap.study.solve.sweep import force_components
from hertzmap.study.solve.sweep_runs import (JUMP_KIND_CODES, SWEPT_SAMPLES, run_sweep, run_swept,
                                             sweep_specs, swept_specs)
from hertzmap.study.schema import study_from_attrs
from tests.helpers import RIG_TABLE, small_study_toml, solved_results

#: omega listed downwards (the study's order): the product's steps are increasing all the same
STUDY = small_study_toml("s", omega=[2.0, 1.99, 1.98, 1.97, 1.96], sigma=0.5, zeta=0.01,
                         outputs=["orbits", "measures", "force_harmonics", "sweeps"]) + RIG_TABLE


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


@pytest.fixture(scope="module")
def swept(store):
    """The product of the same store with two swept-sine rates ([sweep] rates): computed in
    this process as the run's sweeps stage does on its workers."""
    ds = P.open_store(store)
    study = study_from_attrs(ds.attrs)
    rated = dataclasses.replace(study, sweep=tuple(sorted(
        {**study.sweep_dict, "rates": (1e-4, 1e-5)}.items())))
    records = {(s["line"], s["direction"]): run_sweep(s) for s in sweep_specs(rated)}
    specs = swept_specs(rated, records)
    assert [(s["line"], s["direction"], s["rate_index"]) for s in specs] == [
        (0, "up", 0), (0, "up", 1), (0, "down", 0), (0, "down", 1)]
    runs = {(s["line"], s["direction"], s["rate_index"]): run_swept(s) for s in specs}
    return sweeps_dataset(ds, records, rated, runs), rated, records, runs


def test_the_swept_sines_layout_metadata_and_rig_units(swept, sweeps):
    """With [sweep] rates the product holds the swept runs on (line, rate, direction, sample)
    and their readings of the stepped jumps on (jump, rate), every variable with its metadata,
    the rig's units; the stepped sweeps unchanged. Without rates none of it (the fixture
    ``sweeps``: the product as before)."""
    sw, study, _, _ = swept
    assert dict(sw.sizes) == {**dict(sweeps.sizes), "rate": 2, "sample": SWEPT_SAMPLES}
    assert "rate" not in sweeps.dims and not any(v.startswith("swept_") for v in sweeps)
    keep = [v for v in sweeps.data_vars if v != "sweep_seconds"]
    xr.testing.assert_equal(sw[keep], sweeps[keep])
    for v in list(sw.data_vars) + list(sw.coords):
        assert {"long_name", "units", "description"} <= set(sw[v].attrs), v
    np.testing.assert_array_equal(sw["rate"], [1e-4, 1e-5])          # fastest first
    assert sw["swept_ptp"].dims == ("line", "rate", "direction", "sample")
    assert sw["swept_cycles"].dims == ("line", "rate", "direction")
    assert sw["swept_jump_value"].dims == sw["swept_jump_delay"].dims == ("jump", "rate")
    assert sw.attrs["sweep_rates"] == [1e-4, 1e-5] and sw.attrs["swept_window"] == 2
    # the samples: the middles of equal bins of the line's range, each read at the first
    # cycle at or past it (omega moves by rate T a cycle)
    lo, hi = 1.96, 2.0
    middles = lo + (hi - lo) * (np.arange(SWEPT_SAMPLES) + 0.5) / SWEPT_SAMPLES
    np.testing.assert_allclose(sw["sample_value"], middles, rtol=1e-12)
    for k, rate in enumerate((1e-4, 1e-5)):
        for d, sign in ((0, 1.0), (1, -1.0)):
            got = sw["swept_value"].isel(line=0, rate=k, direction=d).values
            past = (got - sw["sample_value"].values) * sign
            assert np.all(past >= 0) and np.all(past <= rate * 2 * np.pi / 1.96 * (1 + 1e-9))
            # the whole range, in forcing cycles of T = 2 pi / omega: (hi^2 - lo^2) / (4 pi r)
            n = int(sw["swept_cycles"].isel(line=0, rate=k, direction=d))
            assert abs(n - (hi ** 2 - lo ** 2) / (4 * np.pi * rate)) < 2
    assert np.all(sw["swept_status"] == 0) and np.all(sw["swept_seconds"] > 0)
    # the rig's units: tau = Omega t, omega = f / f0
    rig = Rig.hertz(2.1e11, 0.29, 0.0127, 7.1, 69.7)
    np.testing.assert_allclose(sw["rate_hz_per_s"], sw["rate"] * 2 * np.pi * rig.f0 ** 2,
                               rtol=1e-12)
    np.testing.assert_allclose(sw["sample_frequency_hz"], sw["sample_value"] * rig.f0,
                               rtol=1e-12)
    np.testing.assert_allclose(sw["swept_frequency_hz"], sw["swept_value"] * rig.f0, rtol=1e-12)
    np.testing.assert_allclose(sw["swept_H1_2_N"], sw["swept_H1_2"] * 69.7, rtol=1e-12)
    np.testing.assert_allclose(sw["swept_ptp_m"], sw["swept_ptp"] * rig.z_s / 1.5, rtol=1e-12)
    np.testing.assert_allclose(sw["swept_time_s"], sw["swept_tau"] / rig.Omega, rtol=1e-12)
    np.testing.assert_allclose(sw["swept_jump_delay_hz"], sw["swept_jump_delay"] * rig.f0,
                               rtol=1e-12)
    # one line of it: its runs and its jumps' readings
    one = P.sweep_line(sw, 0)
    assert one["swept_H1"].dims == ("rate", "direction", "sample")
    assert one["swept_jump_value"].dims == ("jump", "rate")


def test_the_swept_runs_follow_the_stepped_sweep_away_from_its_jumps(swept):
    """Down from the 2T orbit at omega 2.0 (the stepped sweep's first step: the swept run
    starts where it settled), the stepped sweep stays on the 2T response: so does the swept
    run, its two-cycle H1, H2, H1/2 and amplitude those of the steps' orbits at each step's
    value, the closer the slower. Each run is the record of study.solve.swept_sine.swept_sine
    read at the samples; the down sweep has no jump."""
    sw, _, records, runs = swept
    down = sw.isel(line=0, direction=1)
    at = np.array([int(np.argmin(np.abs(sw["sample_value"].values - v)))
                   for v in down["value"].values[:-1]])     # each step's sample (not 2.0)
    err = []
    for k in range(2):
        run = down.isel(rate=k)
        for name in ("H1", "H2", "H1_2", "ptp"):
            step = down[name].values[:-1]
            got = run[f"swept_{name}"].values[at]
            err.append(np.abs(got - step).max() / np.abs(step).max())
    # within 1 % to 30 % at 1e-4, within 1 % at 1e-5 (the response's lag behind its branch)
    assert max(err[4:]) < 0.02 and max(err[4:]) < 0.2 * max(err[:4]), err
    np.testing.assert_array_equal(down["swept_H1_2"].isel(rate=1).values,
                                  runs[(0, "down", 1)]["H1_2"])
    assert records[(0, "down")]["jump_value"].size == 0


def test_a_swept_run_without_its_record_is_left_empty(swept, store):
    sw, study, records, runs = swept
    part = {key: rec for key, rec in runs.items() if key != (0, "up", 1)}
    empty = sweeps_dataset(P.open_store(store), records, study, part)
    gone = empty.isel(line=0, rate=1, direction=0)
    assert np.all(np.isnan(gone["swept_ptp"])) and int(gone["swept_cycles"]) == 0
    assert int(gone["swept_status"]) == -1 and np.all(np.isnan(empty["swept_jump_value"][:, 1]))
    xr.testing.assert_identical(empty.isel(rate=0).drop_vars("sweep_seconds"),
                                sw.isel(rate=0).drop_vars("sweep_seconds"))
