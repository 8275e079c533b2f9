"""study.explore_data: the numbers of the explore page, without a browser. Hand-built stores
for the map and the table, a real 2T orbit with contact loss (kernels.shoot) for the integration
and the harmonics, the paper's rig computed here from its formulas for the units, and the
refined window's study file parsed back."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hertzmap.study import explore_data as E
from hertzmap.study import products as P
from hertzmap.study.spec import parse_study
from tests.helpers import blank_results

REPO = Path(__file__).resolve().parents[2]

RIG = """
[rig]
E = 2.1e11
nu = 0.29
R = 0.0127
m = 7.1
N = 69.7
"""

MAP = """
[study]
name = "hand"
[grid]
omega = [1.0, 1.5, 2.0, 2.2]
sigma = [0.1, 0.3, 0.6]
zeta = [0.01, 0.02]
[products]
outputs = ["orbits", "measures", "force_harmonics"]
"""


def _put(ds, i, j, k, slot, *, period, stable, loses=False, mult=(0.5, 0.4), min_q=-0.1,
         max_q=0.1, ff=0.0, iv=0.0, q0=0.0, v0=0.0, fh=(0.1, 0.01, 0.0, 0.0)):
    idx = dict(omega=i, sigma=j, zeta=k, solution=slot)
    ds["status"][idx] = 0
    ds["period"][idx] = period
    ds["stable"][idx] = stable
    ds["q0"][idx] = q0
    ds["v0"][idx] = v0
    ds["multipliers"][idx] = np.asarray(mult, complex)
    ds["min_q"][idx] = min_q
    ds["max_q"][idx] = max_q
    ds["ptp"][idx] = max_q - min_q
    ds["loses_contact"][idx] = loses
    ds["flight_fraction"][idx] = ff
    ds["max_impact_velocity"][idx] = iv
    ds["force_harmonics"][idx] = np.asarray(fh)


@pytest.fixture()
def hand():
    ds = blank_results(MAP, "hand")
    for i in range(4):
        for j in range(3):
            for k in range(2):
                _put(ds, i, j, k, 0, period=1, stable=True)
    # (2.0, 0.6, zeta 0.01): a stable 2T orbit with contact loss beside the unstable 1T one
    _put(ds, 2, 2, 0, 0, period=1, stable=False, mult=(-1.3, -0.7))
    _put(ds, 2, 2, 0, 1, period=2, stable=True, loses=True, min_q=-1.9, max_q=2.1, ff=0.25,
         iv=0.8, mult=(0.3, 0.2))
    # (1.5, 0.3, zeta 0.01): the same 1T orbit twice (its invariants within the identity rule
    # of study.orbit_rules): one orbit
    _put(ds, 1, 1, 0, 1, period=1, stable=True, mult=(0.5, 0.4), min_q=-0.1 + 1e-9)
    return ds


def test_units_dimensionless_and_the_papers_rig_from_its_formulas(hand):
    u = E.units_of(P.open_store(hand))
    assert not u.physical
    assert all(s.factor == 1.0 for s in (u.freq, u.amp, u.disp, u.vel, u.time, u.force))
    ds = P.open_store(blank_results(MAP + RIG, "rig"))
    u = E.units_of(ds)
    # paper Eq. 2-5, 28: double sphere-plane contact k = E sqrt(R) / (3 sqrt(2) (1 - nu^2))
    k = 2.1e11 * math.sqrt(0.0127) / (3 * math.sqrt(2) * (1 - 0.29**2))
    z_s = (69.7 / k) ** (2 / 3)
    Omega = math.sqrt(1.5 * k * math.sqrt(z_s) / 7.1)
    assert u.physical
    assert u.freq.factor == pytest.approx(Omega / (2 * math.pi), rel=1e-12)
    assert u.freq.factor == pytest.approx(271.0, abs=0.1)          # the paper's f0
    assert u.amp.factor == 69.7 and u.force.factor == 69.7
    assert u.disp.factor == pytest.approx(z_s / 1.5 * 1e6, rel=1e-12)   # q -> um
    assert u.vel.factor == pytest.approx(z_s / 1.5 * Omega * 1e3, rel=1e-12)
    assert u.time.factor == pytest.approx(1e3 / Omega, rel=1e-12)
    assert "[Hz]" in u.freq.label and "[N]" in u.amp.label and "[um]" in u.disp.label
    assert u.freq.inverse(u.freq(1.9)) == pytest.approx(1.9)


def test_map_cells_tile_the_grid_and_carry_the_classes(hand):
    hand["task_done"][...] = True
    ds = P.open_store(hand)
    lcm = P.loss_of_contact_map(ds)
    u = E.units_of(ds)
    cols = E.map_columns(ds, lcm, 0.01, u)
    n_o, n_s = ds.sizes["omega"], ds.sizes["sigma"]
    assert all(len(c) == n_o * n_s for c in cols.values())
    left = np.asarray(cols["left"]).reshape(n_o, n_s)
    right = np.asarray(cols["right"]).reshape(n_o, n_s)
    bottom = np.asarray(cols["bottom"]).reshape(n_o, n_s)
    top = np.asarray(cols["top"]).reshape(n_o, n_s)
    # cells meet half-way between neighbours (non-uniform omega: 1.0, 1.5, 2.0, 2.2)
    np.testing.assert_allclose(right[:-1, 0], left[1:, 0])
    np.testing.assert_allclose(right[:, 0], [1.25, 1.75, 2.1, 2.3])
    np.testing.assert_allclose(left[:, 0], [0.75, 1.25, 1.75, 2.1])
    np.testing.assert_allclose(top[0, :-1], bottom[0, 1:])
    code = np.asarray(cols["code"]).reshape(n_o, n_s)
    assert code[2, 2] == 8           # only the stable 2T with contact loss is stable there
    assert (np.delete(code.ravel(), 2 * n_s + 2) == 1).all()
    summary = np.asarray(cols["summary"]).reshape(n_o, n_s)
    assert "2T stable, contact loss" in summary[2, 2] and "flight 25 %" in summary[2, 2]
    assert "1T unstable" in summary[2, 2]
    assert summary[1, 1].count("<br>") == 0          # the duplicated 1T orbit listed once
    labels = {c: lab for c, _, lab in E.map_legend(code)}
    assert set(labels) == {1, 8} and labels[8] == "2T, contact loss"
    # a block not done: its cells are "not computed yet" whatever the arrays hold
    part = hand.copy(deep=True)
    part["task_done"][...] = False
    d2 = P.open_store(part)
    c2 = E.map_columns(d2, P.loss_of_contact_map(d2), 0.02, u)
    assert set(c2["label"]) == {"not computed yet"} and (np.asarray(c2["code"]) == 0).all()


def test_nearest_point_snaps_inside_and_refuses_outside(hand):
    ds = P.open_store(hand)
    u = E.units_of(ds)
    assert E.nearest_point(ds, 1.95, 0.5, u) == (2.0, 0.6)
    assert E.nearest_point(ds, 1.74, 0.16, u) == (1.5, 0.1)
    assert E.nearest_point(ds, 0.7, 0.3, u) is None          # left of the first cell
    assert E.nearest_point(ds, 1.5, 0.76, u) is None         # above the last cell


def test_point_orbits_drop_duplicates_and_keep_the_stored_numbers(hand):
    ds = P.open_store(hand)
    orb = E.point_orbits(ds, 2.01, 0.58, 0.011)
    assert orb.attrs["omega"] == 2.0 and orb.attrs["sigma"] == 0.6 and orb.attrs["zeta"] == 0.01
    assert list(orb["slot"].values) == [0, 1]
    assert list(orb["orbit_class"].values) == [7, 3]          # 1T unstable in contact, III
    assert orb["min_q"].values[1] == -1.9 and orb["flight_fraction"].values[1] == 0.25
    np.testing.assert_allclose(orb["multipliers"].values[0], [-1.3, -0.7])
    dup = E.point_orbits(ds, 1.5, 0.3, 0.01)
    assert dup.sizes["orbit"] == 1


def test_point_orbits_carry_the_census_basin_of_the_orbits_that_are_its_attractors():
    """The orbit table's basin share: a periodic attractor's basin_fraction on the orbit its
    attractor_solution names (wherever the slot order put it); NaN for an orbit no attractor
    names, and for every orbit where the census did not store attractors."""
    toml = "[grid]\nomega = 2.0\nsigma = 0.6\nzeta = 0.01\n[products]\n" \
           "outputs = [\"orbits\", \"measures\", \"force_harmonics\", \"attractors\"]\n"
    ds = blank_results(toml, "basins")
    _put(ds, 0, 0, 0, 0, period=1, stable=False, mult=(-1.3, -0.7))
    _put(ds, 0, 0, 0, 1, period=2, stable=True, loses=True, min_q=-1.9, max_q=2.1, mult=(0.3, 0.2))
    _put(ds, 0, 0, 0, 2, period=3, stable=True, min_q=-2.5, max_q=3.0, mult=(0.1, 0.2))
    for a, (link, share) in enumerate([(2, 0.75), (1, 0.25)]):
        at = dict(omega=0, sigma=0, zeta=0, attractor=a)
        ds["attractor_kind"][at] = 1
        ds["attractor_period"][at] = (3, 2)[a]
        ds["attractor_solution"][at] = link
        ds["basin_fraction"][at] = share
    ds["attractor_count"][dict(omega=0, sigma=0, zeta=0)] = 2
    orb = E.point_orbits(P.open_store(ds), 2.0, 0.6, 0.01)
    assert list(orb["period"].values) == [1, 2, 3]
    np.testing.assert_array_equal(orb["basin_fraction"].values, [np.nan, 0.25, 0.75])
    none = E.point_orbits(P.open_store(blank_results(MAP, "m")), 2.0, 0.6, 0.01)
    assert np.isnan(none["basin_fraction"].values).all()


def test_orbit_history_and_harmonics_of_a_real_2T_orbit_with_contact_loss():
    """A 2T orbit with contact loss found by shooting (exact events) put in a store: the page's
    integration from its start point closes, has its min q, and its FFT harmonics are the
    shooting's force harmonics."""
    from hertzmap.kernels import shoot

    orbit = shoot(1.9, 0.5, 0.01, period=2, guess=(-0.09, 1.5), exponent=1.5, rtol=1e-11)
    assert orbit.converged and orbit.loses_contact and orbit.stable
    toml = "[grid]\nomega = 1.9\nsigma = 0.5\nzeta = 0.01\n[products]\n" \
           "outputs = [\"orbits\", \"measures\", \"force_harmonics\"]\n"
    ds = blank_results(toml, "real")
    _put(ds, 0, 0, 0, 0, period=2, stable=True, loses=True, min_q=orbit.min_q,
         max_q=orbit.max_q, ff=orbit.flight_fraction, iv=orbit.max_impact_velocity,
         mult=orbit.multipliers, q0=orbit.x0[0], v0=orbit.x0[1], fh=orbit.force_harmonics)
    ds.attrs["rtol"] = 1e-11
    orb = E.point_orbits(P.open_store(ds), 1.9, 0.5, 0.01)
    h = E.orbit_history(orb, 0, samples_per_period=4096)
    assert h["status"] == 0 and h["tau"][-1] == pytest.approx(2 * 2 * np.pi / 1.9)
    assert abs(h["q"][-1] - h["q"][0]) < 1e-8 and abs(h["v"][-1] - h["v"][0]) < 1e-8
    # sampled minimum vs the exact event-located one (flight: q'' ~ 1, step 1.6e-3)
    assert h["q"].min() == pytest.approx(orbit.min_q, abs=1e-6)
    assert h["q"].min() >= orbit.min_q - 1e-10
    assert (h["force"][h["q"] < -1.5] == 0).all() and (h["q"] < -1.5).any()
    ratio, amp = E.force_spectrum(h, 2, kmax=8)
    np.testing.assert_allclose(ratio, np.arange(1, 9) / 2)
    np.testing.assert_allclose(amp[:4], orbit.force_harmonics, rtol=1e-6, atol=1e-9)
    # the Poincare section of a 2T orbit from its start point: two points, x0 at even periods
    pts = E.stroboscopic_points(1.9, 0.5, 0.01, orbit.x0, transient=10, periods=20, rtol=1e-11)
    np.testing.assert_allclose(pts[1::2], np.broadcast_to(orbit.x0, (10, 2)), atol=1e-7)
    assert np.abs(pts[0] - orbit.x0).max() > 0.1


def test_response_slice_is_the_lines_distinct_orbits(hand):
    ds = P.open_store(hand)
    u = E.units_of(ds)
    sl = E.response_slice(ds, 0.55, 0.01, u)
    assert tuple(sl["line"]) == (0.6, 0.01)
    # 4 omega with one 1T orbit each, plus the 2T orbit at omega = 2.0
    assert len(sl["x"]) == 5
    two = sl["orbit_class"] == 3
    assert sl["omega"][two].tolist() == [2.0] and sl["ptp"][two].tolist() == [4.0]
    assert sl["stable"][two].all() and not sl["stable"][sl["orbit_class"] == 7].any()
    colors = E.class_colors()
    assert sl["color"][two][0] == colors[3][0]


def test_refine_study_is_the_recorded_study_on_the_window():
    toml = MAP.replace('name = "hand"', 'name = "hand"\ndescription = "x"') + RIG
    ds = P.open_store(blank_results(toml, "hand"))
    ds.attrs["hertzmap_study_toml"] = toml
    base = parse_study(toml)
    text, study = E.refine_study(ds, (1.4, 1.8), (0.55, 0.2), 6, 5, 0.019)
    again = parse_study(text)
    assert again.hash == study.hash
    np.testing.assert_allclose(study.omega, np.linspace(1.4, 1.8, 6))
    np.testing.assert_allclose(study.sigma, np.linspace(0.2, 0.55, 5))
    assert study.zeta == (0.02,)                          # the grid's zeta nearest 0.019
    d0, d1 = base.to_dict(), study.to_dict()
    for key in ("model", "solver", "search", "products", "rig"):
        assert d1[key] == d0[key], key
    assert study.name.startswith("hand.refine-") and len(study.name) == len("hand.refine-") + 8
    # the same window, the same study (a second refine resumes its store); another, another
    assert E.refine_study(ds, (1.4, 1.8), (0.2, 0.55), 6, 5, 0.02)[1].hash == study.hash
    assert E.refine_study(ds, (1.4, 1.8), (0.2, 0.55), 7, 5, 0.02)[1].name != study.name
    assert E.refine_store_name("runs/hand.zarr".split("/")[-1], study.name) == \
        f"hand.refine-{study.name[-8:]}.zarr"
    # a window beyond the grid is clipped to it
    _, clipped = E.refine_study(ds, (0.1, 1.2), (0.0, 9.0), 3, 3, 0.01)
    assert clipped.omega[0] == 1.0 and clipped.omega[-1] == 1.2
    assert clipped.sigma[0] == 0.1 and clipped.sigma[-1] == 0.6
    with pytest.raises(ValueError, match="more than the 100"):
        E.refine_study(ds, (1.4, 1.8), (0.2, 0.55), 11, 10, 0.01, max_points=100)
    with pytest.raises(ValueError, match="omega .* empty"):
        E.refine_study(ds, (2.5, 3.0), (0.2, 0.55), 6, 6, 0.01)
    with pytest.raises(ValueError, match="integer >= 2"):
        E.refine_study(ds, (1.4, 1.8), (0.2, 0.55), 1, 6, 0.01)
    del ds.attrs["hertzmap_study_toml"]
    with pytest.raises(ValueError, match="no recorded study"):
        E.refine_study(ds, (1.4, 1.8), (0.2, 0.55), 6, 6, 0.01)


def test_refine_of_a_line_study_refines_along_its_line():
    toml = "[grid]\nomega = { start = 0.5, stop = 2.5, num = 21 }\nsigma = 0.5\nzeta = 0.01\n"
    ds = P.open_store(blank_results(toml, "line"))
    ds.attrs["hertzmap_study_toml"] = toml
    _, study = E.refine_study(ds, (1.8, 2.1), (0.49, 0.51), 61, 1, 0.01)
    assert study.sigma == (0.5,) and study.shape == (61, 1, 1)
    np.testing.assert_allclose(study.omega, np.linspace(1.8, 2.1, 61))
    assert "sigma 0.5," in study.description


def test_task_progress(hand):
    hand["task_done"][...] = False
    assert E.task_progress(hand) == (0, hand["task_done"].size)
    hand["task_done"][0, 0, 0] = True
    assert E.task_progress(hand) == (1, hand["task_done"].size)


#: A line of 5 omega values through the 1T flip near 1.97758 (sigma 0.5, zeta 0.01, the paper's
#: rig), listed downwards, with the sweeps output (its defaults: jump_tol 1e-6, 4000 + 200
#: periods per step)
SWEEP_LINE = """
[study]
name = "swept"
[grid]
omega = [2.0, 1.99, 1.98, 1.97, 1.96]
sigma = [0.45, 0.5]
zeta = 0.01
[search]
periods = [1, 2]
[products]
outputs = ["orbits", "measures", "force_harmonics", "sweeps"]
""" + RIG


def test_a_refine_keeps_the_sweep_settings():
    toml = SWEEP_LINE.replace("[products]", "[products]").replace(
        '"sweeps"]\n', '"sweeps"]\n[sweep]\naxis = "omega"\njump_tol = 1e-5\n')
    ds = P.open_store(blank_results(toml, "swept"))
    ds.attrs["hertzmap_study_toml"] = toml
    _, study = E.refine_study(ds, (1.96, 2.0), (0.45, 0.5), 3, 2, 0.01)
    assert study.sweep_dict == parse_study(toml).sweep_dict
    assert study.sweep_dict["jump_tol"] == 1e-5


def test_explore_data_imports_neither_a_server_nor_dask_nor_the_scheduler():
    code = ("import sys, study.explore_data, study.explore_sweeps; "
            "bad = [m for m in sys.modules if m.split('.')[0] in "
            "('bokeh', 'tornado', 'dask', 'distributed', 'scheduler')]; "
            "print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                       cwd=REPO)
    assert r.returncode == 0, r.stdout + r.stderr


def test_a_basin_map_keeps_its_tiles_colours():
    """The final labels (by basin size) renumbered as the tiles numbered them where they
    overlap most; a label the tiles never drew gets a number of its own."""
    provisional = np.array([[2, 2, 0], [0, -1, -1]], np.int16)
    final = np.array([[0, 0, 1], [1, 1, 2]])
    out = E.keep_colours(final, provisional)
    assert out.tolist() == [[2, 2, 0], [0, 0, 1]]


def test_basin_shares_pair_the_map_with_the_census():
    import xarray as xr
    ds = xr.Dataset({"attractor_kind": ("basin_attractor", np.array([1, 1, 3], np.int8)),
                     "attractor_period": ("basin_attractor", np.array([2, 1, 0], np.int8)),
                     "basin_fraction": ("basin_attractor", np.array([0.6, 0.3, 0.1]))})
    census = [{"kind": "periodic", "period": 1, "basin": 0.25},
              {"kind": "periodic", "period": 2, "basin": 0.75},
              {"kind": "periodic", "period": 3, "basin": 0.0}]
    rows = E.basin_shares(ds, census)
    assert [(r["kind"], r["period"]) for r in rows] == [
        ("periodic", 2), ("periodic", 1), ("unsettled", 0), ("periodic", 3)]
    assert [r["map"] for r in rows[:3]] == [0.6, 0.3, 0.1] and np.isnan(rows[3]["map"])
    assert [r["census"] for r in rows[:2]] == [0.75, 0.25] and np.isnan(rows[2]["census"])
    assert rows[3]["census"] == 0.0
