"""scheduler.sweep_tasks: the ``sweeps`` output as a stage of a real run (issue 45). Through
``hertzmap run`` (scheduler.cli.main) on paper Fig. 6's line (sigma 0.5, zeta 0.01, omega 0.44
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
from hertzmap.scheduler.cli import main
from hertzmap.scheduler.store import list_products, read_product, remove_stage, stage_sweep
from hertzmap.study.products.stepped_sweeps import JUMP_KIND_CODES, run_sweep, sweep_specs
from hertzmap.study.schema import study_from_attrs
from tests.helpers import RIG_TABLE

S, Z = 0.5, 0.01
#: the fold ending the 2T branch towards low omega at sigma 0.5, zeta 0.01, by continuation
#: (VALIDATION.md row 8, docs/discovery.md; 1.2e-9)
FOLD_FIG6 = 0.4720910
#: beyond a jump's own bracket: the continuation's value and the oracle's root (xtol 1e-10,
#: rtol 1e-11) against the kernels' shooting (rtol 1e-10) and a fold value given to 1e-7
MARGIN = 1e-7

LINE = """
[study]
name = "sweep-stage"
[grid]
omega = {start = 0.44, stop = 2.0, num = 157}
sigma = 0.5
zeta = 0.01
[search]
periods = [1, 2]
attractors = "never"
[products]
outputs = ["orbits", "force_harmonics", "sweeps"]
""" + RIG_TABLE

#: a few omega values across the 1T flip near 1.9776 (the other paths' study)
FLIP = """
[study]
name = "sweep-flip"
[grid]
omega = [1.96, 1.97, 1.98, 1.99]
sigma = 0.5
zeta = 0.01
[search]
periods = [1, 2]
attractors = "never"
[products]
outputs = ["orbits", "sweeps"]
"""


def _jumps(sweeps, direction):
    d = {"up": 0, "down": 1}[direction]
    return [j for j in range(sweeps.sizes["jump"]) if int(sweeps["jump_direction"][j]) == d]


def _mtime(path):
    return max(p.stat().st_mtime_ns for p in path.rglob("*"))


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
    mtime = _mtime(store / "products" / "sweeps")
    assert main(["run", str(study), "--store", str(store)]) == 0
    out = capsys.readouterr().out
    assert "nothing to compute" in out and "sweeps:" not in out, out
    assert _mtime(store / "products" / "sweeps") == mtime

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
