"""study.products and study.plots: classes on hand-built stores, contouring against a known
curve, isola heuristic, stored product groups, PNG figures, the ``hertzmap plot`` command."""
from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from study import products as P
from study.dataset import template
from study.spec import parse_study

RIG = """
[rig]
E = 2.1e11
nu = 0.29
R = 0.0127
m = 7.1
N = 69.7
"""


def _blank(toml: str, name: str = "t") -> xr.Dataset:
    """An in-memory store dataset (template) with writable arrays, every block done."""
    study = parse_study(toml, default_name=name)
    ds = template(study, study.shape, history="test")
    for v in list(ds.data_vars):
        ds[v] = ds[v].copy(data=np.array(ds[v].values))
    ds["task_done"][...] = True
    return ds


def _set(ds, i, j, slot, *, period, stable, loses=False, mult=(0.5, 0.4), min_q=-0.1,
         max_q=0.1, ff=0.0, iv=0.0, k=0):
    idx = dict(omega=i, sigma=j, zeta=k, solution=slot)
    ds["status"][idx] = 0
    ds["period"][idx] = period
    ds["stable"][idx] = stable
    ds["q0"][idx] = 0.0
    ds["v0"][idx] = 0.0
    ds["multipliers"][idx] = np.asarray(mult, complex)
    if "min_q" in ds:
        ds["min_q"][idx] = min_q
        ds["max_q"][idx] = max_q
        ds["ptp"][idx] = max_q - min_q
        ds["loses_contact"][idx] = loses
        ds["flight_fraction"][idx] = ff
        ds["max_impact_velocity"][idx] = iv


HAND = """
[grid]
omega = [1.0, 1.5, 2.0]
sigma = [0.1, 0.5]
zeta = 0.01
"""


@pytest.fixture()
def hand():
    ds = _blank(HAND)
    # (0, 0): one stable 1T in contact
    _set(ds, 0, 0, 0, period=1, stable=True)
    # (1, 0): stable 1T in contact + stable 2T with contact loss + unstable 2T with contact loss
    _set(ds, 1, 0, 0, period=1, stable=True)
    _set(ds, 1, 0, 1, period=2, stable=True, loses=True, min_q=-2.0, max_q=3.0, ff=0.3, iv=1.7)
    _set(ds, 1, 0, 2, period=2, stable=False, loses=True, min_q=-1.8, max_q=2.0, ff=0.2, iv=0.9)
    # (2, 0): 1T past its flip (unstable), stable 2T in contact, unstable 2T in contact
    _set(ds, 2, 0, 0, period=1, stable=False, mult=(-1.05, -0.9))
    _set(ds, 2, 0, 1, period=2, stable=True, min_q=-0.8, max_q=0.9)
    _set(ds, 2, 0, 2, period=2, stable=False, min_q=-0.5, max_q=0.6)
    # (0, 1): stable 1T with contact loss, and the same orbit again from a 2T solve (squared
    # multipliers): a duplicate, not a second orbit
    T = 2 * np.pi / 1.0
    mu = np.sqrt(np.exp(-2 * 0.01 * T))          # |mu1 mu2| = exp(-2 zeta T)
    _set(ds, 0, 1, 0, period=1, stable=True, loses=True, mult=(-mu, -mu), min_q=-1.6,
         max_q=2.0, ff=0.1, iv=0.5)
    _set(ds, 0, 1, 1, period=1, stable=True, loses=True, mult=(mu**2, mu**2), min_q=-1.6,
         max_q=2.0, ff=0.1, iv=0.5)
    # (1, 1): not computed (its block is not flagged) although a slot holds data
    _set(ds, 1, 1, 0, period=1, stable=True)
    ds["task_done"][...] = True
    return ds


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


def _write_store(ds, path):
    import warnings
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Cc]onsolidated metadata.*")
        ds.to_zarr(str(path), mode="w", consolidated=True)
    return path


def _digest(path: Path) -> dict[str, str]:
    out = {}
    for p in sorted(path.rglob("*")):
        rel = p.relative_to(path).as_posix()
        if p.is_file() and not rel.startswith(P.PRODUCT_GROUP) and rel != "zarr.json":
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def test_products_round_trip_and_leave_the_main_group_alone(hand, tmp_path):
    store = _write_store(hand, tmp_path / "s.zarr")
    before = _digest(store)
    attrs_before = xr.open_zarr(store, chunks=None).attrs
    prods = P.compute_products(store)
    assert {"orbit_classes", "loss_of_contact_map", "bifurcation_curves", "mms_curves",
            "frequency_response"} <= set(prods)
    assert set(P.list_products(store)) == set(prods)
    for name, prod in prods.items():
        back = P.read_product(store, name)
        xr.testing.assert_identical(back.drop_attrs(), prod.drop_attrs())
        assert back.attrs["title"]
    with xr.open_zarr(store, group="products/loss_of_contact_map", chunks=None) as g:
        assert "stable_set" in g and g["stable_set"].attrs["flag_meanings"]
    assert _digest(store) == before
    main = xr.open_zarr(store, chunks=None)
    assert main.attrs == attrs_before
    assert "products" not in main.variables
    # rewriting replaces the group
    P.write_product(store, "mms_curves", prods["mms_curves"].isel(omega=slice(0, 5)))
    assert P.read_product(store, "mms_curves").sizes["omega"] == 5
    # refused while a run holds the lock
    (tmp_path / "s.zarr.lock").write_text("{}")
    with pytest.raises(RuntimeError, match="locked"):
        P.write_product(store, "x", prods["mms_curves"])


def test_mms_products():
    c = P.mms_curves(np.linspace(1.9, 2.1, 201), [0.005])
    assert c["sigma2"].dims == ("omega", "zeta")
    assert float(c["sigma2"].min()) == pytest.approx(0.1799039, abs=2e-4)
    assert float(c["sigma_star_min"][0]) == pytest.approx(0.1799039, abs=1e-6)
    assert float(c["sigma_star"][0]) == pytest.approx(0.179992, abs=1e-6)
    r = P.mms_response(np.linspace(1.8, 2.1, 61), 0.5, 0.01)
    assert {"A_upper", "A_lower", "min_q_upper", "min_q_lower", "region"} <= set(r.data_vars)
    assert np.nanmax(r["A_upper"].values) > 1.0


def test_plots_write_pngs(hand, tmp_path):
    import matplotlib

    from study import plots
    assert matplotlib.get_backend().lower() == "agg"
    # a small map: a smooth flip indicator through the 1T slot
    toml = "[grid]\nomega = {start = 1.9, stop = 2.1, num = 9}\nsigma = {start = 0.1, stop = 0.5, num = 6}\nzeta = 0.01\n"
    ds = _blank(toml, "m")
    for i, w in enumerate(ds["omega"].values):
        for j, s in enumerate(ds["sigma"].values):
            mu = -0.8 - (s - 0.2 - 10 * (w - 2) ** 2)      # below -1 above the parabola
            _set(ds, i, j, 0, period=1, stable=mu > -1, mult=(mu, 0.9 / mu))
            if mu < -1:
                _set(ds, i, j, 1, period=2, stable=True, loses=s > 0.4, min_q=-1.4 - s / 2,
                     max_q=1.0, ff=0.1, iv=0.3)
    store = _write_store(ds, tmp_path / "m.zarr")
    out = tmp_path / "png"
    paths = plots.plot_store(store, out)
    names = {p.name for p in paths}
    assert {"m_map.png", "m_measures.png", "m_bifurcation.png"} <= names
    paths += plots.plot_paper(["fig02", "fig03", "fig04", "fig05"], out)
    for p in paths:
        assert p.is_file() and 1000 < p.stat().st_size < 300_000
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    lcm = P.read_product(store, "loss_of_contact_map")
    assert int(lcm["exists_2T"].sum()) > 0


def test_real_orbits_line_histories_harmonics_and_rig(tmp_path):
    """A tiny real store from the block solver: response, force harmonics and F_exp time
    histories in physical units."""
    from study.block import solve_block
    from study.dataset import block_dataset, stored_variables

    toml = ("[grid]\nomega = [1.88, 1.97]\nsigma = 0.5\nzeta = 0.01\n[products]\n"
            "outputs = [\"orbits\", \"measures\", \"force_harmonics\"]\n" + RIG)
    study = parse_study(toml, default_name="real")
    ds = _blank(toml, "real")
    arrays = solve_block(study.axis("omega"), study.axis("sigma"), study.axis("zeta"),
                         **study.solver_kwargs())
    blk = block_dataset(arrays, stored_variables(study))
    for v in blk.data_vars:
        ds[v] = ds[v].copy(data=blk[v].values)
    store = _write_store(ds, tmp_path / "real.zarr")
    d = P.open_store(store)
    rig = P.rig_of(d)
    assert rig is not None and rig.f0 == pytest.approx(271.0, abs=0.1)
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
    # periodic: the force repeats after the orbit's period
    for k in range(th.sizes["case"]):
        p = int(th["period"].values[k])
        assert f[k, 0] == pytest.approx(f[k, 64 * p], abs=1e-6)
    assert th["force_N"].attrs["units"] == "N"


def test_cli_plot(hand, tmp_path):
    from scheduler.cli import main

    store = _write_store(hand, tmp_path / "c.zarr")
    out = tmp_path / "figs"
    assert main(["plot", str(store), "--out", str(out), "--which", "map"]) == 0
    assert (out / "t_map.png").is_file()
    assert main(["plot", "--paper", "fig04", "--out", str(out)]) == 0
    assert (out / "paper_fig04.png").is_file()
    assert main(["plot", "--out", str(out)]) == 2
    assert main(["plot", str(tmp_path / "nope.zarr")]) == 2
    assert main(["plot", "--paper", "fig99"]) == 2


def test_products_and_plots_import_neither_dask_nor_the_scheduler():
    code = ("import sys, study.products, study.plots; "
            "bad = [m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed', 'scheduler')]; "
            "print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                       cwd=Path(__file__).resolve().parent.parent)
    assert r.returncode == 0, r.stdout + r.stderr


def test_scene_files_are_valid_studies():
    from study.spec import load_study

    root = Path(__file__).resolve().parent.parent / "studies"
    scenes = sorted(root.glob("fig*.toml"))
    assert len(scenes) >= 10
    for f in scenes:
        s = load_study(f)
        assert s.name == f.stem
        assert s.size <= 20_000, f        # a few minutes at most on 2 cores
