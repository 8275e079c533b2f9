"""scheduler.stages.threshold_tasks: the thresholds output as a stage of a real run (2 zeta values, a
grid that holds the isola's lowest point): products/thresholds is written once, holds sigma* and
sigma** at each zeta with the isola's join, is what study.products.damping.thresholds computes
in one process from the same store, and a rerun leaves it alone. The numbers themselves are
checked against the scipy oracle in tests/study/solve/test_thresholds.py."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.store import list_products, read_product
from hertzmap.study import products as P
from tests.helpers import assert_rerun_leaves_product, small_study_toml

STUDY = small_study_toml("thresholds-stage", omega={"start": 1.3, "stop": 2.1, "num": 9},
                         sigma=[0.1, 0.2, 0.3, 0.4], zeta=[0.008, 0.01],
                         outputs=["orbits", "thresholds"])


@pytest.mark.slow
def test_the_thresholds_stage_writes_its_product_once(tmp_path, capsys):
    study, store = tmp_path / "th.toml", tmp_path / "th.zarr"
    study.write_text(STUDY)
    assert main(["run", str(study), "--store", str(store)]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if ln.startswith("thresholds:"))
    assert "products/thresholds" in line, out
    assert "thresholds 2 tasks" in next(ln for ln in out.splitlines()
                                        if ln.startswith("stages:")), out
    # the output implies the curves the isola's sigma** starts from
    assert {"traced_curves", "thresholds"} <= set(list_products(store))
    th = read_product(store, "thresholds")
    np.testing.assert_array_equal(th["zeta"].values, [0.008, 0.01])
    assert np.all(np.isfinite(th["sigma_star"].values))
    assert np.all(np.isfinite(th["sigma_double_star"].values)), th.attrs
    assert np.all(th["sigma_double_star"].values < th["sigma_star"].values)
    assert np.all(np.isfinite(th["sigma_join"].values))
    # the stage's product is the one computed in this process from the run's store
    here = P.thresholds(P.open_store(store), read_product(store, "traced_curves"))
    xr.testing.assert_allclose(th.reset_coords(drop=True), here.reset_coords(drop=True),
                               rtol=1e-12)
    # a rerun: nothing pending, the product untouched
    assert_rerun_leaves_product(main, study, store, "thresholds", capsys, "thresholds:")
