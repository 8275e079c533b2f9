"""``hertzmap basins`` end to end on a tiny real store (3 omega values around the bistable point
omega 1.7, sigma 1.0, zeta 0.05 of tests/study/solve/test_basin_grid.py): the map computed in
tasks on an embedded local cluster (both methods: label reuse in tiles, the default, and one
whole transient per state) is the map computed in one process, stored as its product group with
attrs on every variable and the boundary's measures, and drawn; bad input is refused, naming
the option and what is allowed, with the store untouched."""
from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hertzmap.scheduler.doors.cli import main
from hertzmap.study.products.basin_map import basin_map_name
from hertzmap.scheduler.stages.basin_tasks import check_request, store_orbits
from hertzmap.study.solve.basin_grid import basin_map
from hertzmap.study.solve.dense_basins import cell_basin_map
from tests.helpers import solved_results

STUDY = """
[grid]
omega = [1.6, 1.7, 1.8]
sigma = [0.8, 1.0]
zeta = [0.05]
[search]
attractors = "never"
"""


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    return solved_results(STUDY, tmp_path_factory.mktemp("basins") / "bistable.zarr",
                          "bistable")


def _main(argv) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main([str(a) for a in argv])
        except SystemExit as exc:           # argparse usage errors
            rc = exc.code
    return rc, out.getvalue(), err.getvalue()


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(root.rglob("*"))}


def test_the_command_stores_and_draws_the_map(store, tmp_path):
    # 1.72 is not a grid value: the nearest, 1.7, is taken
    rc, out, err = _main(["basins", store, "--omega", 1.72, "--sigma", 1.0, "--grid", "12x10",
                          "--workers", 1, "--out", tmp_path, "--q-range=-4,2",
                          "--method", "transients"])
    assert rc == 0, err
    name = basin_map_name(1.7, 1.0, 0.05)
    png = tmp_path / f"bistable_{name}.png"
    assert png.is_file() and png.stat().st_size > 10_000
    ds = xr.open_zarr(store, group=f"products/{name}").load()
    for v in list(ds.data_vars) + list(ds.coords):
        assert ds[v].attrs.get("long_name") and "units" in ds[v].attrs, v
    assert ds["basin_entropy"].attrs["units"] == "nats"
    # the same map in one process (the store's solver options: Hertz, n = 1.5, rtol 1e-10)
    ref = basin_map(1.7, 1.0, 0.05, (-4.0, 2.0), (-5.0, 5.0), (12, 10))
    assert ds["basin_label"].shape == (10, 12)
    assert (ds["basin_label"].values == ref.labels).all()
    assert list(ds["attractor_period"].values) == [a["period"] for a in ref.attractors] == [1, 2]
    assert float(ds["basin_entropy"]) == pytest.approx(ref.entropy.basin_entropy, abs=0)
    assert np.allclose(ds["q"].values, ref.q) and np.allclose(ds["v"].values, ref.v)
    assert "S_b = " in out and name in out
    # the store with its basin map opens as one DataTree; the map's own attractors are its
    # dim basin_attractor (not the main group's attractor slots)
    tree = xr.open_datatree(store, engine="zarr")
    assert f"/products/{name}" in tree.groups
    group = tree[f"products/{name}"].to_dataset(inherit=False)
    assert group.sizes["basin_attractor"] == len(ref.attractors) == 2
    assert "attractor" not in group.dims


def test_the_reuse_method_is_the_one_process_map(store, tmp_path):
    """The default method on 2 workers (its tiles in any order) gives the map that
    study.solve.dense_basins computes in this process from the store's orbits, with the
    measures stored and printed."""
    rc, out, err = _main(["basins", store, "--omega", 1.7, "--sigma", 1.0, "--grid", "40x30",
                          "--workers", 2, "--out", tmp_path])
    assert rc == 0, err
    name = basin_map_name(1.7, 1.0, 0.05)
    ds = xr.open_zarr(store, group=f"products/{name}").load()
    req = check_request(store, 1.7, 1.0, None, "40x30", None, None)
    assert store_orbits(req), "the store holds the point's stable orbits"
    ref = cell_basin_map(1.7, 1.0, 0.05, req.q_range, req.v_range, (40, 30),
                         options=req.options, orbits=store_orbits(req),
                         transient_periods=req.transient_periods,
                         record_periods=req.record_periods)
    assert (ds["basin_label"].values == ref.labels).all()
    assert (ds["basin_method"].values == ref.method).all()
    assert ds.attrs["method"] == "reuse"
    assert ds.attrs["cells_seed"] + ds.attrs["cells_reused"] + ds.attrs["cells_census"] == 1200
    for v in ("basin_entropy_error", "uncertainty_exponent", "uncertainty_exponent_error",
              "boundary_dimension", "wada", "wada_share", "uncertain_share"):
        assert ds[v].attrs.get("long_name"), v
    assert np.isfinite(float(ds["uncertainty_exponent"]))
    assert "uncertainty exponent alpha" in out and "by label reuse" in out
    assert (tmp_path / f"bistable_{name}.png").is_file()


@pytest.mark.parametrize("args, needle", [
    (["--grid", "12by12"], "--grid: expected NQxNV"),
    (["--method", "guess"], "invalid choice: 'guess'"),
    (["--grid", "1x12"], "--grid: each side must be 2..2000"),
    (["--q-range=4,-6"], "--q-range: expected finite LO < HI"),
    (["--v-range", "a,b"], "--v-range: expected LO,HI"),
    (["--omega", 2.5], "--omega 2.5 is outside the store's omega axis [1.6, 1.8]"),
    (["--sigma", 0.1], "--sigma 0.1 is outside the store's sigma axis [0.8, 1]"),
])
def test_bad_input_is_refused_and_the_store_untouched(store, tmp_path, args, needle):
    before = _snapshot(store)
    argv = ["basins", store, "--omega", 1.7, "--sigma", 1.0, "--grid", "12x12", "--out",
            tmp_path]
    rc, _, err = _main(argv + args)
    assert rc == 2 and needle in err, err
    assert "Traceback" not in err
    assert _snapshot(store) == before and not list(tmp_path.iterdir())


def test_a_path_that_is_not_a_store_is_refused(tmp_path):
    rc, _, err = _main(["basins", tmp_path, "--omega", 1.7, "--sigma", 1.0])
    assert rc == 2 and "not a zarr store" in err
