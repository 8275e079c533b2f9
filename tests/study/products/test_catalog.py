"""study.products.catalog: the registry of products. Every entry computes a described Dataset
on a small real store; when the results support each product (the thresholds of
docs/products.md); the stroboscopic diagram's lines; the order of the entries."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from hertzmap.study import products as P
from hertzmap.study.products import catalog
from tests.helpers import (EVERY_OUTPUT_STUDY, blank_results, fake_traced_curves, set_orbit,
                           solved_results)

#: every product of docs/products.md that hertzmap plot computes (traced_curves: the run's)
EVERY_PRODUCT = {"orbit_classes", "loss_of_contact_map", "bifurcation_curves",
                 "located_bifurcations", "mms_curves", "frequency_response", "mms_response",
                 "force_harmonics", "stroboscopic_diagram", "attractor_ids", "time_histories",
                 "isola_boundary", "thresholds", "impact_onset"}
#: computed only for studies that sweep zeta (the real store has one zeta value: the products are
#: checked on stores of two in tests/study/products/test_damping.py)
ZETA_SWEPT = {"thresholds", "impact_onset"}


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    """The small real store of every output (tests.helpers.EVERY_OUTPUT_STUDY), opened, and
    made-up traced curves standing for the run's."""
    store = solved_results(EVERY_OUTPUT_STUDY, tmp_path_factory.mktemp("real") / "r.zarr")
    return P.open_store(store), fake_traced_curves()


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
