"""study.products: classes, the loss-of-contact map, curves, multiple-scales products,
responses, harmonics and histories, on hand-built results (every value set by the test) and on
a real line of orbits."""
from __future__ import annotations

from pathlib import Path
import hashlib

import numpy as np
import pytest
import xarray as xr

from hertzmap.study import products as P
from hertzmap.study.analytic import multiple_scales as ms
from hertzmap.study.analytic.paper import F0_PRINTED
from tests.helpers import RIG_TABLE, solved_results


def _undone(ds):
    """Unflag the block holding point (1, 1): here chunks are the whole grid, so rebuild with
    one-point chunks instead."""
    ds = ds.copy()
    ds.attrs["hertzmap_chunk_shape"] = [1, 1, 1]
    td = np.ones((3, 2, 1), bool)
    td[1, 1, 0] = False
    ds = ds.drop_vars("task_done").assign(
        task_done=(("omega_chunk", "sigma_chunk", "zeta_chunk"), td))
    return ds


def _digest(path: Path) -> dict[str, str]:
    out = {}
    for p in sorted(path.rglob("*")):
        rel = p.relative_to(path).as_posix()
        if p.is_file() and not rel.startswith(P.PRODUCT_GROUP) and rel != "zarr.json":
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def test_classes_and_map_on_hand_built_cases(hand):
    ds = P.open_store(_undone(hand))
    cls = P.orbit_classes(ds)
    assert cls.dims == ("omega", "sigma", "zeta", "solution")
    c = cls.isel(zeta=0).values
    assert list(c[0, 0]) == [1, 0, 0, 0]
    assert list(c[1, 0]) == [1, 3, 5, 0]
    assert list(c[2, 0]) == [7, 2, 4, 0]
    assert list(c[0, 1]) == [6, 0, 0, 0]            # the duplicate is dropped
    assert list(c[1, 1]) == [0, 0, 0, 0]            # not computed
    assert set(cls.attrs) >= {"long_name", "units", "flag_values", "flag_meanings"}

    lcm = P.loss_of_contact_map(ds)
    assert set(lcm.dims) == {"omega", "sigma", "zeta", "orbit_class"}
    for v in lcm.data_vars:
        assert "long_name" in lcm[v].attrs and "units" in lcm[v].attrs, v
    m = lcm.isel(zeta=0)
    assert m["stable_set"].values.tolist() == [[1, 2], [1 | 8, 0], [4, 0]]
    assert m["n_orbits"].values.tolist() == [[1, 1], [3, 0], [3, 0]]
    assert m["n_stable"].values.tolist() == [[1, 1], [2, 0], [1, 0]]
    assert m["computed"].values.tolist() == [[True, True], [True, False], [True, True]]
    assert bool(m["contact_loss_possible"][1, 0]) and not bool(m["contact_loss_certain"][1, 0])
    assert bool(m["contact_loss_certain"][0, 1])
    assert m["flight_fraction"].values[1, 0] == pytest.approx(0.3)
    assert m["max_impact_velocity"].values[1, 0] == pytest.approx(1.7)
    assert m["max_impact_velocity"].values[0, 0] == 0.0
    assert np.isnan(m["flight_fraction"].values[1, 1])
    # flip indicator (1 + mu1)(1 + mu2) of the 1T orbit; negative past the flip
    assert m["flip_indicator_1T"].values[0, 0] == pytest.approx(1.5 * 1.4)
    assert m["flip_indicator_1T"].values[2, 0] == pytest.approx(-0.05 * 0.1)
    assert m["contact_margin_1T"].values[0, 1] == pytest.approx(-0.1)
    assert m["contact_margin_2T"].values[1, 0] == pytest.approx(-0.5)
    assert m["class_count"].sel(orbit_class=3).values[1, 0] == 1


def test_map_keeps_the_1t_2t_kinds_beside_a_stable_longer_orbit(hand):
    """A stable 3T orbit alone is map_class 16; beside a stable 1T orbit the map keeps the 1T
    kind (the paper's loss-of-contact map) and stable_longer marks the point."""
    from hertzmap.study.products.maps import MAP_CLASS_LONGER
    from tests.helpers import set_orbit

    ds = hand.copy(deep=True)
    set_orbit(ds, 0, 0, 3, period=3, stable=True, loses=True, min_q=-9.0, max_q=3.0)
    for slot in range(ds.sizes["solution"]):          # (2, 0): a stable 3T orbit only
        ds["status"][dict(omega=2, sigma=0, zeta=0, solution=slot)] = 1
    set_orbit(ds, 2, 0, 0, period=3, stable=True, loses=True, min_q=-9.0, max_q=3.0)
    m = P.loss_of_contact_map(P.open_store(ds)).isel(zeta=0)
    assert int(m["map_class"][0, 0]) == int(m["stable_set"][0, 0]) == 1
    assert int(m["stable_longer"][0, 0]) == 1
    assert int(m["map_class"][2, 0]) == MAP_CLASS_LONGER and int(m["stable_set"][2, 0]) == 0
    assert int(m["stable_longer"][2, 0]) == 1
    assert int(m["stable_longer"][1, 0]) == 0 and int(m["map_class"][1, 0]) == 1 | 8


def test_contour_lines_find_a_known_curve():
    om = np.linspace(1.8, 2.2, 81)
    sg = np.linspace(0.0, 1.0, 51)
    W, S = np.meshgrid(om, sg, indexing="ij")
    z = S - (0.2 + 5 * (W - 2) ** 2)                   # zero on sigma = 0.2 + 5 (omega - 2)^2
    lines = P.contour_lines(om, sg, z, 0.0)
    assert len(lines) == 1
    w, s = lines[0][:, 0], lines[0][:, 1]
    assert np.max(np.abs(s - (0.2 + 5 * (w - 2) ** 2))) < 2e-3
    assert w.min() < 1.83 and w.max() > 2.17
    # NaN points are masked: no line through them
    z2 = z.copy()
    z2[:, 30:] = np.nan
    for line in P.contour_lines(om, sg, z2, 0.0):
        assert line[:, 1].max() <= sg[29] + 1e-12


def test_bifurcation_curves_and_flip_minimum_from_an_analytic_indicator():
    om = np.linspace(1.9, 2.1, 41)
    sg = np.linspace(0.05, 0.6, 45)
    W, S = np.meshgrid(om, sg, indexing="ij")
    lcm = xr.Dataset({"flip_indicator_1T": (("omega", "sigma", "zeta"),
                                            ((0.3 + 8 * (W - 2.01) ** 2) - S)[..., None])},
                     coords={"omega": om, "sigma": sg, "zeta": [0.01]})
    curves = P.bifurcation_curves(lcm)
    assert set(curves.data_vars) == {"omega", "sigma", "zeta", "curve", "segment"}
    segs = P.curve_segments(curves, "flip_1T", 0.01)
    assert len(segs) == 1
    w, s = P.flip_minimum(lcm, 0.01)
    assert w == pytest.approx(2.01, abs=1e-6) and s == pytest.approx(0.3, abs=1e-6)
    # a line study has no curves, but a well-formed empty product
    empty = P.bifurcation_curves(lcm.isel(sigma=[0]))
    assert empty.sizes["vertex"] == 0


def test_isola_heuristic():
    # omega along axis 0, three sigma lines
    ex = np.zeros((10, 3), bool)
    flip = np.zeros((10, 3), bool)
    loses = np.zeros((10, 3), bool)
    ex[2:5, 0] = True; loses[3, 0] = True                 # isola: no flip on its run
    ex[6:9, 0] = True; flip[8, 0] = True; loses[6, 0] = True   # flip-born run
    ex[2:9, 1] = True; flip[8, 1] = True; loses[2:9, 1] = True  # one run, touches the flip
    ex[1:3, 2] = True                                       # no contact loss: not an isola
    iso = P.isola_mask(ex, flip, loses)
    assert iso[:, 0].tolist() == [False] * 2 + [True] * 3 + [False] * 5
    assert not iso[:, 1].any() and not iso[:, 2].any()


def test_mms_products():
    z = 0.005
    omega = np.linspace(1.9, 2.1, 201)
    c = P.mms_curves(omega, [z])
    # the multiple-scales grid is its own (not a study's omega axis): its dim is mms_omega
    assert c["sigma2"].dims == ("mms_omega", "zeta") == (P.MMS_OMEGA, "zeta")
    np.testing.assert_array_equal(c["mms_omega"].values, omega)
    # the product holds the multiple-scales module's curves (tested against the oracle's flips
    # of Eq. 11 in tests/study/analytic/test_multiple_scales.py)
    np.testing.assert_array_equal(c["sigma2"].values[:, 0], ms.sigma2(omega, z))
    assert float(c["sigma_star_min"][0]) == float(ms.sigma_star(z, "min"))
    # the curve's minimum is below every grid value, and near the lowest: the grid (step 1e-3)
    # has a point within 5e-4 of it, where sigma2 rises steeply (~500 (omega - omega_min)^2)
    assert 0 <= float(c["sigma2"].min()) - float(c["sigma_star_min"][0]) < 2e-4
    # Eq. 27: sigma* ~ 36 zeta, to O(zeta^2) relative (docs/analytic.md: 36 zeta (1 - 21 zeta^2))
    assert float(c["sigma_star_min"][0]) == pytest.approx(36 * z, rel=25 * z**2)
    # Eq. 26 as printed: 36 zeta / (1 + 16 zeta^2 / 9)
    assert float(c["sigma_star"][0]) == pytest.approx(36 * z / (1 + 16 * z**2 / 9), rel=1e-14)
    r = P.mms_response(np.linspace(1.8, 2.1, 61), 0.5, 0.01)
    assert {"A_upper", "A_lower", "min_q_upper", "min_q_lower", "region"} <= set(r.data_vars)
    assert np.nanmax(r["A_upper"].values) > 1.0
    assert r["A_upper"].dims == ("mms_omega",) and r.sizes["mms_omega"] == 61


def test_real_orbits_line_histories_harmonics_and_rig(tmp_path):
    """A tiny real store from the block solver: response, force harmonics and F_exp time
    histories in physical units."""
    toml = ("[grid]\nomega = [1.88, 1.97]\nsigma = 0.5\nzeta = 0.01\n[products]\n"
            "outputs = [\"orbits\", \"measures\", \"force_harmonics\"]\n" + RIG_TABLE)
    store = solved_results(toml, tmp_path / "real.zarr")
    d = P.open_store(store)
    rig = P.rig_of(d)
    # the [rig] table is the paper's rig (section 4.1): f0 as printed in Eq. 29c, 271 Hz
    assert rig is not None and round(rig.f0) == F0_PRINTED
    fr = P.frequency_response(d, rig=rig)
    assert "frequency_hz" in fr.coords and fr["frequency_hz"].attrs["units"] == "Hz"
    assert (fr["orbit_class"].values == 3).any()         # stable 2T with contact loss (Fig. 6)
    fh = P.force_harmonics(d, rig=rig)
    amp = fh["force_amplitude"]
    two = (fh["orbit_class"] == 3).values
    one = (fh["orbit_class"] == 1).values
    assert (amp.sel(ratio=0.5).values[two] > 0.1).all()  # the subharmonic of the 2T orbits
    assert (amp.sel(ratio=0.5).values[one] == 0).all()
    assert fh["force_amplitude_N"].attrs["units"] == "N"
    th = P.time_histories(d, [1.88], rig=rig, cycles=2, samples_per_cycle=64)
    assert th.sizes["time"] == 129 and th.sizes["case"] >= 1
    f = th["F_exp"].values
    assert np.all(f >= -1 - 1e-12)
    lost = th["period"].values == 2
    assert np.isclose(f[lost], -1.0).any()                # in flight F_exp = -1 (Eq. 30)
    # periodic: the force repeats after the orbit's period (within the two cycles drawn: a
    # census orbit of period 3 or more does not repeat within them)
    checked = 0
    for k in range(th.sizes["case"]):
        p = int(th["period"].values[k])
        if 64 * p < th.sizes["time"]:
            assert f[k, 0] == pytest.approx(f[k, 64 * p], abs=1e-6)
            checked += 1
    assert checked >= 2
    assert th["force_N"].attrs["units"] == "N"
