"""study.products.damping: the thresholds (dim zeta and the vertices continued in zeta; a run
product, written by the run's thresholds stage) on a study of two zeta values, with and without
the traced isola it starts sigma** from; the registry computes impact_onset only for studies that
sweep zeta. The numbers themselves are
checked against the scipy oracle in tests/study/solve/test_thresholds.py."""
from __future__ import annotations

import numpy as np
import pytest

from hertzmap.study import products as P
from hertzmap.study.products.traced_curves import combine_traced_curves, traced_curves_dataset
from hertzmap.study.solve.curve_seeds import Seed, trace_seed
from tests.helpers import blank_results
from tests.study.solve.test_thresholds import ISOLA_START

GRID = "[grid]\nomega = [1.9, 2.0]\nsigma = [0.2, 0.4]\nzeta = [0.008, 0.01]\n"


@pytest.fixture(scope="module")
def two_zeta():
    """A blank store of two zeta values and the isola's 2T fold curve traced at zeta 0.01 from
    a rough start near its lowest point (the curves output's trace, study.solve.curve_seeds)."""
    ds = P.open_store(blank_results(GRID))
    seed = Seed(0, ("omega", "sigma"), 0.01, "fold", 2, ISOLA_START[2], ISOLA_START[3], 0.01,
                ISOLA_START[0], ISOLA_START[1], hold="sigma")
    traced = combine_traced_curves([traced_curves_dataset([trace_seed(
        seed, {"omega": (1.0, 2.2), "sigma": (0.1, 0.5)})])])
    return ds, traced


def test_the_thresholds_at_each_zeta_and_continued_between(two_zeta):
    ds, traced = two_zeta
    th = P.thresholds(ds, traced)
    assert th.attrs["title"] and th.attrs["hertzmap_star_ends"] == "range range"
    assert th.attrs["hertzmap_double_star_ends"] == "range range"
    for v in list(th.data_vars) + list(th.coords):
        assert {"long_name", "units", "description"} <= set(th[v].attrs), v
    np.testing.assert_array_equal(th["zeta"].values, [0.008, 0.01])
    for name in ("star", "double_star"):
        z = th[f"{name}_zeta"].values
        assert z[0] == 0.008 and z[-1] == 0.01 and np.all(np.diff(z) > 0)
        # the values at the study's zeta are the continued curve's vertices there
        for k, zg in enumerate(th["zeta"].values):
            i = int(np.argmin(np.abs(z - zg)))
            assert th[f"sigma_{name}"].values[k] == th[f"{name}_sigma"].values[i]
        assert np.all(th[f"sigma_{name}_accuracy"].values <= 1e-8)
    # the paper's order (Fig. 9): the isola (sigma**) appears below the flip's sigma*, and it
    # joins the flip-born branch on the flip curve, above its lowest point, near omega = 2
    assert np.all(th["sigma_double_star"].values < th["sigma_star"].values)
    assert np.all(th["sigma_join"].values > th["sigma_star"].values)
    assert np.all(np.abs(th["omega_join"].values - 2.0) < 0.01)
    assert np.all(th["join_accuracy"].values <= 1e-6)
    # the join continued with sigma**: traced from each of its vertices, the study's zeta
    # values among them, its sigma growing with damping as sigma*'s does
    jz = th["join_zeta"].values
    assert jz.size == th.sizes["double_star_vertex"] and np.all(np.diff(jz) > 0)
    for k, zg in enumerate(th["zeta"].values):
        i = int(np.argmin(np.abs(jz - zg)))
        assert jz[i] == zg and th["sigma_join"].values[k] == th["join_sigma"].values[i]
    assert np.all(np.diff(th["join_sigma"].values) > 0)
    assert np.all(th["join_vertex_accuracy"].values <= 1e-6)
    # multiple scales (paper Eq. 26) beside it, within 1 % at these zeta
    np.testing.assert_allclose(th["sigma_star"].values, th["sigma_star_mms"].values, rtol=1e-2)


def test_without_traced_curves_sigma_star_only_and_why():
    ds = P.open_store(blank_results(GRID))
    th = P.thresholds(ds)
    assert np.all(np.isfinite(th["sigma_star"].values))
    assert np.all(np.isnan(th["sigma_double_star"].values))
    assert th.sizes["double_star_vertex"] == 0 and th.sizes["join_vertex"] == 0
    assert "curves output" in th.attrs["hertzmap_double_star_ends"]


def test_only_studies_that_sweep_zeta_get_it():
    one = P.open_store(blank_results(GRID.replace("[0.008, 0.01]", "0.01")))
    assert "impact_onset" not in P.compute_products(one)
    assert "thresholds" not in P.compute_products(one)   # a run product: never computed here


def test_impact_onset_is_the_lowest_sigma_where_a_stable_response_loses_contact():
    """Made-up map: at zeta index k a stable 1T orbit loses contact from sigma line 2 + k on
    (at omega index 0 never); the paper's rig gives N and Hz."""
    from hertzmap.study.analytic.rig import Rig
    from tests.helpers import set_orbit

    raw = blank_results("[grid]\nomega = [1.9, 2.0]\nsigma = {start = 0.1, stop = 0.6, num = 6}"
                        "\nzeta = [0.005, 0.01]\n")
    for k in range(2):
        for i in range(2):
            for j in range(6):
                set_orbit(raw, i, j, 0, period=1, stable=True, loses=i == 1 and j >= 2 + k,
                          min_q=-2.0 if (i == 1 and j >= 2 + k) else -0.1, k=k)
    ds = P.open_store(raw)
    lcm = P.loss_of_contact_map(ds)
    onset = P.impact_onset(lcm, Rig.paper())
    sig = ds["sigma"].values
    np.testing.assert_allclose(onset["sigma_impact_onset"].sel(omega=2.0).values, sig[[2, 3]])
    np.testing.assert_allclose(onset["sigma_below_onset"].sel(omega=2.0).values, sig[[1, 2]])
    assert np.all(np.isnan(onset["sigma_impact_onset"].sel(omega=1.9).values))
    np.testing.assert_allclose(onset["force_amplitude_N"].values,
                               onset["sigma_impact_onset"].values * Rig.paper().N)
    np.testing.assert_allclose(onset["frequency_hz"].values, ds["omega"].values
                               * Rig.paper().f0)
    assert "impact_onset" in P.compute_products(ds)
