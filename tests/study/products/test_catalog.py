"""study.products.catalog: the registry of products. Every entry computes a described Dataset
on a small real store; when the results support each product (the thresholds of
docs/products.md); the stroboscopic diagram's lines; the order of the entries; a store with
every product group (and a basin map) opens as one xarray DataTree."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import xarray as xr

from hertzmap.scheduler.store import read_product, write_product, write_products
from hertzmap.study import products as P
from hertzmap.study.products import catalog
from hertzmap.study.products.basin_map import BASIN_ATTRACTOR, basin_map_dataset, basin_map_name
from hertzmap.study.products.damping import thresholds_dataset
from hertzmap.study.products.mms import MMS_POINTS
from hertzmap.study.solve.basin_grid import basin_map
from tests.helpers import (EVERY_OUTPUT_STUDY, blank_results, fake_traced_curves, set_orbit,
                           solved_results, write_results)

#: every product of docs/products.md that hertzmap plot computes (traced_curves and thresholds:
#: the run's)
EVERY_PRODUCT = {"orbit_classes", "loss_of_contact_map", "bifurcation_curves",
                 "located_bifurcations", "mms_curves", "frequency_response", "mms_response",
                 "force_harmonics", "stroboscopic_diagram", "attractor_ids", "time_histories",
                 "isola_boundary", "impact_onset"}
#: computed only for studies that sweep zeta (the real store has one zeta value: the products are
#: checked on stores of two in tests/study/products/test_damping.py)
ZETA_SWEPT = {"impact_onset"}


@pytest.fixture(scope="module")
def real_store(tmp_path_factory):
    """The small real store of every output (tests.helpers.EVERY_OUTPUT_STUDY), on disk."""
    return solved_results(EVERY_OUTPUT_STUDY, tmp_path_factory.mktemp("real") / "r.zarr")


@pytest.fixture(scope="module")
def real(real_store):
    """The small real store of every output, opened, and made-up traced curves standing for
    the run's."""
    return P.open_store(real_store), fake_traced_curves()


def test_every_entry_computes_a_described_dataset_on_a_real_store(real):
    ds, traced = real
    prods = P.compute_products(ds, given={"traced_curves": traced})
    assert set(prods) == EVERY_PRODUCT - ZETA_SWEPT
    assert EVERY_PRODUCT == {p.name for p in P.PRODUCTS}
    for name, prod in prods.items():
        assert isinstance(prod, xr.Dataset), name
        assert prod.attrs.get("title"), name
        for v in list(prod.data_vars) + list(prod.coords):
            assert {"long_name", "units"} <= set(prod[v].attrs), (name, v)
    # read off the results by hand: the census's stroboscopic points of the first line
    diag = P.diagram_line(prods["stroboscopic_diagram"], 0)
    line = ds.isel(sigma=0, zeta=0)
    kept = np.isfinite(line["strobe_q"].values) & (line["attractor_kind"].values > 0)[..., None]
    assert diag.sizes["point"] == int(kept.sum()) > 0
    np.testing.assert_array_equal(np.sort(diag["strobe_q"].values),
                                  np.sort(line["strobe_q"].values[kept]))
    # the isola's lowest point of the given curves (sigma 0.17, made up in the helper)
    assert float(prods["isola_boundary"]["sigma_isola"].sel(zeta=0.01)) == 0.17
    # without traced curves at hand there is no isola boundary, and nothing given is returned
    assert "isola_boundary" not in P.compute_products(ds)
    assert "traced_curves" not in prods


def _grid(omega="[1.9, 2.0]", sigma="0.3", zeta="0.01", extra=""):
    return P.open_store(blank_results(f"[grid]\nomega = {omega}\nsigma = {sigma}\nzeta = {zeta}\n"
                                      + extra))


def _needs(ds, name, **context):
    return catalog.product(name).needs(ds, P.Context(**context))


def test_frequency_response_for_at_most_16_lines_and_mms_response_within_its_window():
    sixteen = _grid(sigma="{start = 0.1, stop = 0.8, num = 8}", zeta="[0.01, 0.02]")
    seventeen = _grid(sigma="{start = 0.1, stop = 0.9, num = 17}")
    for name in ("frequency_response", "mms_response"):
        assert _needs(sixteen, name) and not _needs(seventeen, name)
    far = _grid(omega="[1.0, 1.5]")         # outside abs(omega - 2) <= 0.25
    assert _needs(far, "frequency_response") and not _needs(far, "mms_response")


def test_time_histories_for_few_named_frequencies_or_when_asked():
    eight = _grid(omega="{start = 1, stop = 2, num = 8}")
    nine = _grid(omega="{start = 1, stop = 2, num = 9}")
    assert _needs(eight, "time_histories") and not _needs(nine, "time_histories")
    assert _needs(nine, "time_histories", wanted=("time_histories",))
    assert not _needs(eight, "time_histories", wanted=("loss_of_contact_map",))


def test_products_of_stored_outputs_and_of_the_runs_curves():
    plain = _grid(extra='[search]\nattractors = "never"\n')      # no census: no strobe_q
    outputs = _grid(extra='[search]\nattractors = "always"\n[products]\noutputs = ["orbits", '
                    '"force_harmonics", "bifurcations", "attractors"]\n')
    for name in ("force_harmonics", "located_bifurcations", "stroboscopic_diagram"):
        assert _needs(outputs, name) and not _needs(plain, name), name
    assert not _needs(plain, "isola_boundary")
    assert _needs(plain, "isola_boundary", products={"traced_curves": fake_traced_curves()})


def test_stroboscopic_diagram_of_four_sigma_lines_at_two_zeta():
    """6 sigma x 3 zeta: the lines are sigma 0.1, 0.3, 0.4, 0.6 (the first, the last and two
    evenly between) at zeta 0.01 and 0.03 (the first and the last, never only the first ones);
    one hand-set 2T attractor and one stored orbit."""
    ds = blank_results("[grid]\nomega = [1.9, 2.0]\nsigma = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]\n"
                       "zeta = [0.01, 0.02, 0.03]\n[search]\nattractors = \"always\"\n"
                       "[products]\noutputs = [\"orbits\", \"measures\", \"attractors\"]\n")
    at = dict(omega=1, sigma=2, zeta=2, attractor=0)                  # sigma 0.3, zeta 0.03
    ds["attractor_kind"][at] = 1
    ds["attractor_period"][at] = 2
    ds["strobe_q"][at] = np.nan
    ds["strobe_v"][at] = np.nan
    ds["strobe_q"][dict(at, strobe=[0, 1])] = [-0.5, 0.25]
    ds["strobe_v"][dict(at, strobe=[0, 1])] = [0.125, -0.75]
    set_orbit(ds, 0, 2, 0, period=1, stable=True, k=2)
    diagrams = catalog.product("stroboscopic_diagram").compute(P.open_store(ds))
    np.testing.assert_allclose(diagrams["line_sigma"], [0.1, 0.1, 0.3, 0.3, 0.4, 0.4, 0.6, 0.6])
    np.testing.assert_allclose(diagrams["line_zeta"], [0.01, 0.03] * 4)
    assert diagrams.sizes["point"] == 2 and diagrams.sizes["orbit"] == 1
    one = P.diagram_line(diagrams, 3)
    assert (one.attrs["sigma"], one.attrs["zeta"]) == (0.3, 0.03)
    np.testing.assert_array_equal(one["strobe_q"], [-0.5, 0.25])
    np.testing.assert_array_equal(one["strobe_v"], [0.125, -0.75])
    np.testing.assert_array_equal(one["strobe_omega"], [2.0, 2.0])
    np.testing.assert_array_equal(one["strobe_period"], [2, 2])
    np.testing.assert_array_equal(one["orbit_omega"], [1.9])
    others = [P.diagram_line(diagrams, i) for i in range(8) if i != 3]
    assert all(d.sizes["point"] == 0 and d.sizes["orbit"] == 0 for d in others)


def test_entries_come_after_what_they_take():
    seen = set(catalog.RUN_PRODUCTS)
    for p in P.PRODUCTS:
        assert set(p.inputs) <= seen, (p.name, p.inputs)
        assert p.name not in seen and p.description
        seen.add(p.name)
    with pytest.raises(KeyError):
        catalog.product("strobe")


# -- the store as one DataTree: a product group's dims align with the main group's -------------

def _tree_and_groups(store) -> tuple[xr.DataTree, dict[str, xr.Dataset]]:
    """The store opened as one DataTree (refused unless every group aligns with its parents),
    and each group as stored (a tree's group does not repeat the coordinates it inherits)."""
    return (xr.open_datatree(store, engine="zarr"),
            {path: ds.load() for path, ds in xr.open_groups(store, engine="zarr").items()})


def _assert_aligned(groups: dict[str, xr.Dataset]) -> None:
    """Every dim of every group that is named as a dim of the main group holds the main group's
    values, in its order (what DataTree checks, said per dim)."""
    root = groups["/"]
    for path, own in groups.items():
        for d in set(own.dims) & set(root.dims):
            assert own.sizes[d] == root.sizes[d], (path, d)
            if d in own.indexes:
                np.testing.assert_array_equal(own[d].values, root[d].values, err_msg=f"{path} {d}")


def _plot_products(store, given_names=P.RUN_PRODUCTS) -> dict[str, xr.Dataset]:
    """What hertzmap plot writes (scheduler.doors.cli cmd_plot): the products computed from the
    store and the run's groups it holds, each written as products/<name>."""
    given = {name: read_product(store, name) for name in given_names}
    prods = P.compute_products(P.open_store(store), given=given)
    write_products(store, prods)
    return prods


def test_a_store_with_every_product_and_a_basin_map_opens_as_one_datatree(real_store,
                                                                          tmp_path):
    """The real store with the run's traced curves, every product hertzmap plot writes and a
    basin map written as hertzmap basins writes it (scheduler.stages.basin_tasks.run_basins): one
    DataTree. The multiple-scales products' own omega grid (801 values, the study has 2) is
    ``mms_omega``; the basin map's own attractors (1 here, the census's slots 4) are
    ``basin_attractor``: named ``omega`` and ``attractor`` they do not align."""
    store = shutil.copytree(real_store, tmp_path / "plotted.zarr")
    write_product(store, "traced_curves", fake_traced_curves())     # as hertzmap run does
    prods = _plot_products(store, ("traced_curves",))
    assert set(prods) == EVERY_PRODUCT - ZETA_SWEPT
    # hertzmap basins at (2.05, 0.5, 0.01), with the study's transients (a small grid)
    omega, sigma, zeta = 2.05, 0.5, 0.01
    bm = basin_map(omega, sigma, zeta, grid=(4, 3), transient_periods=200, record_periods=32)
    name = basin_map_name(omega, sigma, zeta)
    write_product(store, name, basin_map_dataset(bm, {"hertzmap_product_source":
                                                      "hertzmap basins"}))
    # the stepped sweeps of its two lines, as hertzmap run's sweeps stage writes them
    write_product(store, "sweeps", P.stepped_sweeps(P.open_store(store)))

    tree, groups = _tree_and_groups(store)
    assert set(tree.groups) == set(groups) == (
        {"/", "/products", "/products/traced_curves", "/products/sweeps", f"/products/{name}"}
        | {f"/products/{n}" for n in prods})
    _assert_aligned(groups)
    root = groups["/"]
    for group, dims in (("mms_curves", {"mms_omega", "zeta"}),
                        ("mms_response", {"sigma", "zeta", "mms_omega"})):
        own = groups[f"/products/{group}"]
        assert set(own.dims) == dims, group
        assert own.sizes["mms_omega"] == MMS_POINTS != root.sizes["omega"]
        assert own["mms_omega"].attrs["long_name"] and own["mms_omega"].attrs["units"] == "1"
    basins = groups[f"/products/{name}"]
    assert "attractor" not in basins.dims
    assert basins.sizes[BASIN_ATTRACTOR] == len(bm.attractors) != root.sizes["attractor"]
    assert basins.sizes["strobe"] == root.sizes["strobe"]
    assert list(basins["attractor_period"].values) == [a["period"] for a in bm.attractors]
    assert tree[f"products/{name}"]["basin_label"].shape == (3, 4)
    sweeps = groups["/products/sweeps"]
    assert sweeps.sizes["line"] == 2 and sweeps.sizes["step"] == root.sizes["omega"]
    assert "omega" not in sweeps.dims and sweeps.sizes["multiplier"] == root.sizes["multiplier"]


def test_products_of_axes_listed_out_of_order_align_with_the_main_group(tmp_path):
    """A study may list its axes in any order (omega downwards, zeta unsorted): the products,
    computed on sorted axes, are stored in the main group's order (the run's thresholds too),
    the isola boundary at every zeta of the study (the traced curves have one), and the store
    opens as one DataTree."""
    store = write_results(blank_results(
        "[grid]\nomega = [2.05, 1.9, 2.0]\nsigma = [0.5, 0.3]\nzeta = [0.02, 0.01, 0.03]\n",
        "unsorted"), tmp_path / "unsorted.zarr")
    ds = P.open_store(store)
    write_product(store, "traced_curves", fake_traced_curves(0.01))
    write_product(store, "thresholds", thresholds_dataset(ds, (None, "none"), (None, [], "none")))
    write_product(store, "sweeps", P.stepped_sweeps(ds))
    prods = _plot_products(store)
    assert {"loss_of_contact_map", "impact_onset", "mms_response", "isola_boundary"} <= set(prods)
    tree, groups = _tree_and_groups(store)
    assert set(tree.groups) == set(groups)
    _assert_aligned(groups)
    np.testing.assert_array_equal(groups["/products/loss_of_contact_map"]["omega"],
                                  [2.05, 1.9, 2.0])
    for group in ("thresholds", "isola_boundary", "impact_onset", "mms_curves"):
        np.testing.assert_array_equal(groups[f"/products/{group}"]["zeta"], [0.02, 0.01, 0.03])
    sweeps = groups["/products/sweeps"]          # its lines in the study's order, steps sorted
    np.testing.assert_array_equal(sweeps["line_sigma"], [0.5] * 3 + [0.3] * 3)
    np.testing.assert_array_equal(sweeps["line_zeta"], [0.02, 0.01, 0.03] * 2)
    np.testing.assert_array_equal(sweeps["value"], [1.9, 2.0, 2.05])
    iso = groups["/products/isola_boundary"]
    np.testing.assert_array_equal(iso["sigma_isola"], [np.nan, 0.17, np.nan])
    np.testing.assert_array_equal(iso["curve"], [-1, 0, -1])
