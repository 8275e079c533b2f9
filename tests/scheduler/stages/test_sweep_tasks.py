"""scheduler.stages.sweep_tasks: the ``sweeps`` output as a stage of a real run (issue 45). Through
``hertzmap run`` (scheduler.doors.cli.main) on paper Fig. 6's line (sigma 0.5, zeta 0.01, omega 0.44
to 2.0 by 0.01): the down sweep drops from the 2T to the 1T response at the 2T fold (omega
0.4720910 by continuation, VALIDATION.md row 8), named fold; the up sweep leaves the 1T response
for the 2T one at the 1T flip, against the scipy oracle's own flip (benchmarks/oracle.py,
flip_omega: brentq on 1 + tr M + det M along omega, each 1T orbit by scipy root on its period
map), named flip; a rerun computes nothing; the product opens in the store's DataTree. Then the
stage's other paths: resumed from a staged sweep, on the user's Dask client, on the embedded
local cluster."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import xarray as xr

import hertzmap
from benchmarks import oracle
from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.store import (list_products, read_product, remove_stage, stage_sweep,
                                      stage_swept)
from hertzmap.study.solve.sweep_runs import (JUMP_KIND_CODES, run_sweep, run_swept, sweep_specs,
                                             swept_specs)
from hertzmap.study.schema import study_from_attrs
from tests.helpers import RIG_TABLE, assert_rerun_leaves_product, small_study_toml

S, Z = 0.5, 0.01
#: the fold ending the 2T branch towards low omega at sigma 0.5, zeta 0.01, by continuation
#: (VALIDATION.md row 8, docs/discovery.md; 1.2e-9)
FOLD_FIG6 = 0.4720910
#: beyond a jump's own bracket: the continuation's value and the oracle's root (xtol 1e-10,
#: rtol 1e-11) against the kernels' shooting (rtol 1e-10) and a fold value given to 1e-7
MARGIN = 1e-7

LINE = small_study_toml("sweep-stage", omega={"start": 0.44, "stop": 2.0, "num": 157},
                        sigma=0.5, zeta=0.01,
                        outputs=["orbits", "force_harmonics", "sweeps"]) + RIG_TABLE

#: a few omega values across the 1T flip near 1.9776 (the other paths' study)
FLIP = small_study_toml("sweep-flip", omega=[1.96, 1.97, 1.98, 1.99], sigma=0.5, zeta=0.01,
                        outputs=["orbits", "sweeps"])


def _jumps(sweeps, direction):
    d = {"up": 0, "down": 1}[direction]
    return [j for j in range(sweeps.sizes["jump"]) if int(sweeps["jump_direction"][j]) == d]


@pytest.mark.slow
def test_the_sweeps_stage_finds_the_fold_and_the_flip_through_hertzmap_run(tmp_path, capsys):
    study, store = tmp_path / "line.toml", tmp_path / "line.zarr"
    study.write_text(LINE)
    assert main(["run", str(study), "--store", str(store)]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("sweeps:"))
    assert "2 stepped sweeps" in line and "products/sweeps" in line, out
    assert "sweeps 2 tasks" in next(ln for ln in out.splitlines() if ln.startswith("stages:"))
    assert "sweeps" in list_products(store)
    assert not (store / "sweeps_stage").exists()          # the staged sweeps removed
    sw = read_product(store, "sweeps")
    kinds = {v: k for k, v in JUMP_KIND_CODES.items()}

    # down from rest at omega 2.0: on the 2T response to its fold, then the 1T one
    (j,) = [j for j in _jumps(sw, "down")]
    assert kinds[int(sw["jump_kind"][j])] == "fold" and bool(sw["jump_located"][j])
    assert (int(sw["jump_from_period"][j]), int(sw["jump_to_period"][j])) == (2, 1)
    value, accuracy = float(sw["jump_value"][j]), float(sw["jump_accuracy"][j])
    assert 0 < accuracy <= 1e-6
    assert abs(value - FOLD_FIG6) <= accuracy + MARGIN, (value, accuracy)
    down = sw.isel(line=0, direction=1)
    assert np.all(down["period"].values[down["value"].values > value] == 2)
    assert np.all(down["period"].values[down["value"].values < value] == 1)

    # up from rest at omega 0.44: 1T (over two folds of its own, onto larger 1T orbits), then
    # the 2T response at the 1T flip
    up_jumps = _jumps(sw, "up")
    (f,) = [j for j in up_jumps if (int(sw["jump_from_period"][j]),
                                    int(sw["jump_to_period"][j])) == (1, 2)]
    assert kinds[int(sw["jump_kind"][f])] == "flip" and bool(sw["jump_located"][f])
    value, accuracy = float(sw["jump_value"][f]), float(sw["jump_accuracy"][f])
    assert 0 < accuracy <= 1e-6
    k = int(sw["jump_from_step"][f])                        # the last 1T step before the flip
    up = sw.isel(line=0, direction=0)
    guess = (float(up["q0"][k]), float(up["v0"][k]))
    w_o, _ = oracle.flip_omega((1.965, 1.985), S, Z, guess, rtol=1e-11, xtol=1e-10)
    assert abs(value - w_o) <= accuracy + MARGIN, (value, w_o)
    assert {kinds[int(sw["jump_kind"][j])] for j in up_jumps} == {"fold", "flip"}
    # the rig's units: the jump in Hz
    assert float(sw["jump_frequency_hz"][f]) == pytest.approx(value * sw.attrs["rig_f0_hz"])

    # a rerun: nothing pending, nothing computed, the product untouched
    out = assert_rerun_leaves_product(main, study, store, "sweeps", capsys, "sweeps:")
    assert "nothing to compute" in out, out

    # the product in the store's DataTree (hertzmap.open: xarray.open_datatree)
    tree = hertzmap.open(store)
    got = tree["products/sweeps"].to_dataset()
    assert {"line", "direction", "step", "jump", "branch_point"} <= set(got.dims)
    np.testing.assert_array_equal(got["jump_value"].values, sw["jump_value"].values)
    assert xr.open_datatree(store, engine="zarr")["products/sweeps"]["H1"].shape == (1, 2, 157)


def test_a_run_resumes_the_sweeps_not_staged(tmp_path, capsys):
    """A run killed after one sweep was staged: the rerun runs only the other, and the product
    is the one an undisturbed run writes."""
    study, store = tmp_path / "flip.toml", tmp_path / "flip.zarr"
    study.write_text(FLIP)
    assert main(["run", str(study), "--store", str(store)]) == 0
    whole = read_product(store, "sweeps")
    # as if killed before the product was written, with the up sweep staged
    shutil.rmtree(store / "products" / "sweeps")
    spec = next(s for s in sweep_specs(study_from_attrs(xr.open_zarr(store).attrs))
                if s["direction"] == "up")
    stage_sweep(store, 0, "up", run_sweep(spec))
    capsys.readouterr()
    assert main(["run", str(study), "--store", str(store)]) == 0
    out = capsys.readouterr().out
    assert "resuming the sweeps" in out and "1/2 staged" in out, out
    assert "sweeps 1 task," in next(ln for ln in out.splitlines() if ln.startswith("stages:"))
    again = read_product(store, "sweeps")
    drop = ["sweep_seconds"]
    xr.testing.assert_allclose(again.drop_vars(drop), whole.drop_vars(drop), rtol=1e-12)
    (j,) = range(again.sizes["jump"])
    assert int(again["jump_kind"][j]) == JUMP_KIND_CODES["flip"] and abs(float(again["jump_value"][j])
                                                   - 1.97757924) < 1e-6
    remove_stage(store, "sweeps_stage")


def test_the_sweeps_stage_on_the_users_client(client, tmp_path):
    tree = hertzmap.run(FLIP, tmp_path / "client.zarr", client=client, quiet=True)
    sw = tree["products/sweeps"].to_dataset()
    assert int(sw.sizes["jump"]) == 1 and int(sw["jump_kind"][0]) == JUMP_KIND_CODES["flip"]
    assert abs(float(sw["jump_value"][0]) - 1.97757924) < 1e-6


@pytest.mark.slow
def test_the_sweeps_stage_on_the_embedded_local_cluster(tmp_path, capsys):
    study, store = tmp_path / "local.toml", tmp_path / "local.zarr"
    study.write_text(FLIP)
    assert main(["run", str(study), "--store", str(store), "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert "sweeps 2 tasks" in next(ln for ln in out.splitlines() if ln.startswith("stages:"))
    sw = read_product(store, "sweeps")
    assert int(sw["jump_kind"][0]) == JUMP_KIND_CODES["flip"] and abs(float(sw["jump_value"][0]) - 1.97757924) < 1e-6


#: up in omega from rest at 0.44 (the 1T response in contact) across the fold where that
#: response ends, near 0.4665 (the bend of the 2:1 superharmonic resonance: VALIDATION.md,
#: "Stepped sweeps"), stepped and swept at three rates (4.6, 0.46 and 0.046 Hz/s on the rig)
RATES = small_study_toml("swept-fold", omega=[0.44, 0.45, 0.46, 0.47, 0.48], sigma=0.5,
                         zeta=0.01, outputs=["orbits", "force_harmonics", "sweeps"],
                         sweep={"rates": [1e-7, 1e-5, 1e-6]}) + RIG_TABLE
#: how near the oracle's fold the slowest rate's swept jump must be: the slow passage through
#: a fold delays it by about c rate^(2/3) (8e-5 at 1e-7 here; 1.9e-4 at the 2T fold,
#: tests/study/solve/test_sweep.py)
SLOWEST_TOL = 2e-4


@pytest.mark.slow
def test_swept_sines_jump_later_the_faster_and_tend_to_the_fold(tmp_path, capsys):
    """Through hertzmap run: the swept sines' readings of the up sweep's fold come after it,
    the later the faster the rate (the delay shrinking monotonically, about as rate^(2/3) by
    10^(-2/3) = 0.22 a decade of rate), the slowest within SLOWEST_TOL of the fold that the
    scipy oracle finds on its own (benchmarks/oracle.py fold_point: scipy root on the period
    map and its monodromy's det(M - I), started from the stored 1T orbit before the jump); the
    stepped sweep's fold within its bracket of it. The rates in the rig's Hz/s."""
    study, store = tmp_path / "rates.toml", tmp_path / "rates.zarr"
    study.write_text(RATES)
    assert main(["run", str(study), "--store", str(store)]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("sweeps:"))
    assert "2 stepped sweeps" in line and "6 swept sines (3 rates x up, down)" in line, out
    assert "sweeps 8 tasks" in next(ln for ln in out.splitlines() if ln.startswith("stages:"))
    assert not (store / "sweeps_stage").exists()
    sw = read_product(store, "sweeps")
    np.testing.assert_array_equal(sw["rate"], [1e-5, 1e-6, 1e-7])          # fastest first
    assert np.all(sw["swept_status"] == 0)
    kinds = {v: k for k, v in JUMP_KIND_CODES.items()}
    (j,) = _jumps(sw, "up")
    assert kinds[int(sw["jump_kind"][j])] == "fold" and bool(sw["jump_located"][j])
    assert (int(sw["jump_from_period"][j]), int(sw["jump_to_period"][j])) == (1, 1)
    value, accuracy = float(sw["jump_value"][j]), float(sw["jump_accuracy"][j])
    # the oracle's fold, from the last stored 1T step before it
    up = sw.isel(line=0, direction=0)
    k = int(sw["jump_from_step"][j])
    guess = np.array([float(up["q0"][k]), float(up["v0"][k])]) + 1e-3
    x_o, w_o, (fixed_res, fold_res) = oracle.fold_point(
        guess, float(sw["jump_before"][j]) - 1e-5, S, Z, 1, rtol=1e-11)
    assert fixed_res < 1e-8 * (1.0 + np.abs(x_o).max()) and fold_res < 1e-8
    assert abs(value - w_o) <= accuracy + MARGIN, (value, w_o)
    # the swept jumps: later than the fold, the later the faster, tending to it
    where = sw["swept_jump_value"].values[j]
    delay = sw["swept_jump_delay"].values[j]
    np.testing.assert_allclose(delay, where - value, rtol=1e-12)
    assert np.all(where > w_o) and delay[0] > delay[1] > delay[2] > 0.0, (where, w_o)
    for faster, slower in zip(delay, delay[1:]):
        assert 0.1 < slower / faster < 0.4, delay
    assert abs(where[2] - w_o) < SLOWEST_TOL, (where, w_o)
    # the rig's units: 1 in omega per unit tau is 2 pi f0^2 Hz/s
    f0 = sw.attrs["rig_f0_hz"]
    np.testing.assert_allclose(sw["rate_hz_per_s"], sw["rate"] * 2 * np.pi * f0 ** 2, rtol=1e-12)
    np.testing.assert_allclose(sw["swept_jump_frequency_hz"].values[j], where * f0, rtol=1e-12)
    assert 4.5 < float(sw["rate_hz_per_s"][0]) < 4.7


def test_a_run_resumes_the_swept_sines_not_staged(tmp_path, capsys):
    """A run killed after the stepped sweeps and one of the swept runs were staged: the rerun
    runs only the other swept runs, and the product is the one an undisturbed run writes."""
    study, store = tmp_path / "flip.toml", tmp_path / "flip.zarr"
    study.write_text(FLIP + "[sweep]\nrates = [1e-4, 1e-5]\n")
    assert main(["run", str(study), "--store", str(store)]) == 0
    out = capsys.readouterr().out
    assert "4 swept sines" in next(ln for ln in out.splitlines() if ln.startswith("sweeps:"))
    whole = read_product(store, "sweeps")
    # as if killed before the product was written: both stepped sweeps and one swept staged
    shutil.rmtree(store / "products" / "sweeps")
    study_ = study_from_attrs(xr.open_zarr(store).attrs)
    records = {(s["line"], s["direction"]): run_sweep(s) for s in sweep_specs(study_)}
    for (i, direction), rec in records.items():
        stage_sweep(store, i, direction, rec)
    spec = next(s for s in swept_specs(study_, records)
                if (s["direction"], s["rate_index"]) == ("down", 1))
    stage_swept(store, 0, "down", 1, run_swept(spec))
    assert main(["run", str(study), "--store", str(store)]) == 0
    out = capsys.readouterr().out
    assert "resuming the sweeps" in out and "2/2 staged" in out, out
    assert "resuming the swept sines" in out and "1/4 staged" in out, out
    assert "sweeps 3 tasks," in next(ln for ln in out.splitlines() if ln.startswith("stages:"))
    assert not (store / "sweeps_stage").exists()
    again = read_product(store, "sweeps")
    drop = ["sweep_seconds", "swept_seconds"]
    xr.testing.assert_allclose(again.drop_vars(drop), whole.drop_vars(drop), rtol=1e-12)
    assert again.sizes["rate"] == 2 and np.all(again["swept_cycles"] > 0)
