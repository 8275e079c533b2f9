"""study.plots: every figure a study's products support is drawn (valid PNGs of a sane size), from
the products alone (nothing computed while drawing), the paper's analytic figures, and which
figures a scene gets."""
from __future__ import annotations

import dataclasses

import matplotlib
import numpy as np
import pytest

from hertzmap.study import plots
from hertzmap.study import products as P
from tests.helpers import (EVERY_OUTPUT_STUDY, blank_results, fake_traced_curves, set_orbit,
                           solved_results)


def test_plots_write_pngs(tmp_path):
    assert matplotlib.get_backend().lower() == "agg"
    # a small map: a smooth flip indicator through the 1T slot
    toml = "[grid]\nomega = {start = 1.9, stop = 2.1, num = 9}\nsigma = {start = 0.1, stop = 0.5, num = 6}\nzeta = 0.01\n"
    ds = blank_results(toml, "m")
    for i, w in enumerate(ds["omega"].values):
        for j, s in enumerate(ds["sigma"].values):
            mu = -0.8 - (s - 0.2 - 10 * (w - 2) ** 2)      # below -1 above the parabola
            set_orbit(ds, i, j, 0, period=1, stable=mu > -1, mult=(mu, 0.9 / mu))
            if mu < -1:
                set_orbit(ds, i, j, 1, period=2, stable=True, loses=s > 0.4, min_q=-1.4 - s / 2,
                     max_q=1.0, ff=0.1, iv=0.3)
    out = tmp_path / "png"
    results = P.open_store(ds)
    prods = P.compute_products(results)
    paths = plots.plot_results(results, prods, out)
    names = {p.name for p in paths}
    assert {"m_map.png", "m_measures.png", "m_bifurcation.png"} <= names
    paths += plots.plot_paper(["fig02", "fig03", "fig04", "fig05"], out)
    for p in paths:
        assert p.is_file() and 1000 < p.stat().st_size < 300_000
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert int(prods["loss_of_contact_map"]["exists_2T"].sum()) > 0


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    """The products of a small real store of every output (tests.helpers), made-up traced
    curves standing for the run's, and the stepped sweeps of its two lines (the run's sweeps
    stage computes the same)."""
    store = solved_results(EVERY_OUTPUT_STUDY, tmp_path_factory.mktemp("real") / "r.zarr")
    ds = P.open_store(store)
    traced = fake_traced_curves()
    return ds, {"traced_curves": traced, "sweeps": P.stepped_sweeps(ds),
                **P.compute_products(ds, given={"traced_curves": traced})}


def test_every_figure_of_the_registry_is_drawn_from_its_product_alone(real, tmp_path,
                                                                      monkeypatch):
    ds, prods = real
    names = {p.name for p in P.PRODUCTS} | set(P.RUN_PRODUCTS)
    for figure in plots.FIGURES:
        assert callable(figure.draw) and figure.help, figure
        assert set(figure.products) <= names, figure      # it draws from declared products
    assert len(plots.WHICH) == len(set(plots.WHICH))
    # nothing is computed while drawing: every product function of study.products fails
    def computed(*args, **kwargs):
        raise AssertionError("a product computed while drawing")
    for name in ("compute_products", "orbit_classes", "loss_of_contact_map", "bifurcation_curves",
                 "located_curves", "mms_curves", "mms_response", "mms_curves_over",
                 "mms_response_over", "frequency_response", "force_harmonics", "time_histories",
                 "stroboscopic_diagram", "stroboscopic_diagrams", "isola_boundary",
                 "stepped_sweeps", "sweeps_dataset"):
        monkeypatch.setattr(P, name, computed)
    monkeypatch.setattr(P, "PRODUCTS", tuple(dataclasses.replace(p, compute=computed)
                                             for p in P.PRODUCTS))
    paths = plots.plot_results(ds, prods, tmp_path, which=list(plots.WHICH))
    assert sorted(p.name for p in paths) == sorted(
        ["real_map.png", "real_measures.png", "real_lyapunov.png", "real_bifurcation.png",
         "real_response_sigma0.3.png", "real_response_sigma0.5.png",
         "real_harmonics_sigma0.3.png", "real_harmonics_sigma0.5.png",
         "real_strobe_sigma0.3.png", "real_strobe_sigma0.5.png", "real_histories.png",
         "real_sweeps_sigma0.3.png", "real_sweeps_sigma0.5.png"])
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # a scene of named frequencies (2 omega): by default its histories, not its responses;
    # and no figure of a product not given, whatever the results hold
    auto = plots.plot_results(ds, {n: v for n, v in prods.items() if n != "stroboscopic_diagram"},
                              tmp_path / "auto")
    assert "strobe_q" in ds
    assert sorted(p.name for p in auto) == sorted(
        ["real_map.png", "real_measures.png", "real_lyapunov.png", "real_bifurcation.png",
         "real_histories.png", "real_sweeps_sigma0.3.png", "real_sweeps_sigma0.5.png"])
    with pytest.raises(ValueError, match="unknown figure"):
        plots.plot_results(ds, prods, tmp_path, which=["maps"])


def _two_zeta_map():
    """A small map of two zeta values, a smooth flip indicator through the 1T slot at each."""
    toml = ("[grid]\nomega = {start = 1.9, stop = 2.1, num = 5}\n"
            "sigma = {start = 0.1, stop = 0.5, num = 4}\nzeta = [0.005, 0.01]\n")
    ds = blank_results(toml, "z")
    for k in range(2):
        for i, w in enumerate(ds["omega"].values):
            for j, s in enumerate(ds["sigma"].values):
                mu = -0.8 - (s - 0.2 * (k + 1) - 10 * (w - 2) ** 2)
                set_orbit(ds, i, j, 0, period=1, stable=mu > -1, mult=(mu, 0.9 / mu), k=k)
    return P.open_store(ds)


def test_a_store_of_several_zeta_gets_one_figure_per_zeta_or_the_chosen_one(tmp_path):
    ds = _two_zeta_map()
    prods = {n: v for n, v in P.compute_products(ds, wanted=plots.products_for(["map"])).items()
             if n != "thresholds"}
    names = {p.name for p in plots.plot_results(ds, prods, tmp_path / "all", which=["map"])}
    assert names == {"z_map_zeta0.005.png", "z_map_zeta0.01.png"}
    one = plots.plot_results(ds, prods, tmp_path / "one", which=["map"], zeta=0.0098)
    assert [p.name for p in one] == ["z_map_zeta0.01.png"]
    with pytest.raises(ValueError, match="--zeta 0.2 is outside the store's zeta values"):
        plots.plot_results(ds, prods, tmp_path / "bad", which=["map"], zeta=0.2)


def test_the_thresholds_figure_from_its_product(tmp_path):
    ds = _two_zeta_map()
    th = P.thresholds(ds)
    paths = plots.plot_results(ds, {"thresholds": th}, tmp_path)
    assert [p.name for p in paths] == ["z_thresholds.png"]
    assert 1000 < paths[0].stat().st_size < 300_000


def test_the_maps_of_several_zeta_side_by_side_and_the_impact_onset_chart(tmp_path):
    ds = _two_zeta_map()
    prods = {n: v for n, v in P.compute_products(ds, wanted=plots.products_for(["map"])).items()
             if n != "thresholds"}
    paths = plots.plot_results(ds, prods, tmp_path, which=["zeta_maps", "impact_onset"])
    assert sorted(p.name for p in paths) == ["z_impact_onset.png", "z_zeta_maps.png"]
    for p in paths:
        assert 1000 < p.stat().st_size < 300_000


def _off_the_canvas(fig) -> float:
    """How far (inches) what a figure draws reaches beyond its canvas: matplotlib's tight
    bounding box of every drawn artist (axes, tick labels in view, titles, legends, texts)
    against the figure's own box; 0 when everything is on it."""
    tight = fig.get_tightbbox(fig.canvas.get_renderer())
    w, h = fig.get_size_inches()
    return max(0.0, -tight.x0, -tight.y0, tight.x1 - w, tight.y1 - h)


def test_no_figure_cuts_off_a_legend_or_a_label(real, tmp_path, monkeypatch):
    """Every figure of a store, and a map whose legend lists every kind of response and every
    curve (as the vibro-impact scene's), drawn as `save` draws it: everything drawn lies on
    the canvas; the crowded legend takes two columns beside the axes."""
    from hertzmap.study.plots import style

    checked, cut = [], {}
    saving = style.save

    def save(fig, path):
        style.fit(fig)
        over = _off_the_canvas(fig)
        if over > 0.01:
            cut[str(path)] = over
        checked.append(fig)
        return saving(fig, path)

    for module in ("plane_figures", "line_figures", "damping_figures", "basin_figures",
                   "paper_figures"):
        monkeypatch.setattr(f"hertzmap.study.plots.{module}.save", save)
    ds, prods = real
    plots.plot_results(ds, prods, tmp_path, which=list(plots.WHICH))
    # every kind of response at once, and every curve: the longest legend a map can have
    toml = ("[grid]\nomega = {start = 1.9, stop = 2.1, num = 12}\n"
            "sigma = {start = 0.1, stop = 0.5, num = 10}\nzeta = 0.01\n")
    big = blank_results(toml, "crowded")
    for i in range(12):
        for j in range(10):
            set_orbit(big, i, j, 0, period=1, stable=True)
    big = P.open_store(big)
    crowded = P.compute_products(big)
    lcm = crowded["loss_of_contact_map"]
    codes = [c for c in style.SET_COLORS if c > 0]
    field = lcm["map_class"].values
    field.flat[:] = [codes[i % len(codes)] for i in range(field.size)]
    lcm["stable_longer"].values[...] = 1
    path = plots.plot_loss_of_contact_map(lcm, crowded["bifurcation_curves"],
                                          tmp_path / "crowded.png", mms=crowded["mms_curves"],
                                          traced=fake_traced_curves())
    assert len(checked) >= 10 and not cut, cut
    legend = checked[-1].legends[0]
    assert len(legend.get_texts()) > style.LEGEND_ROWS and legend._ncols == 2
    assert path.is_file()


def test_the_sweeps_figure_draws_the_swept_sines_beside_the_stepped_sweeps(real, tmp_path,
                                                                           monkeypatch):
    """With swept-sine runs in the sweeps product ([sweep] rates), each rate's up and down
    paths are drawn in every panel (thin, their direction's colour, the fastest faintest) and
    named in the legend with its rate; without, the figure is as before."""
    from hertzmap.study.plots import line_figures
    from hertzmap.study.products.stepped_sweeps import sweep_line, sweeps_dataset
    from hertzmap.study.solve.sweep_runs import run_sweep, run_swept, sweep_specs, swept_specs
    from hertzmap.study.schema import study_from_attrs
    from hertzmap.study.spec import DEFAULT_SWEEP

    ds, prods = real
    study = dataclasses.replace(study_from_attrs(ds.attrs), sweep=tuple(sorted(
        {**DEFAULT_SWEEP, "rates": (1e-3, 1e-4)}.items())))
    records = {(s["line"], s["direction"]): run_sweep(s) for s in sweep_specs(study)}
    runs = {(s["line"], s["direction"], s["rate_index"]): run_swept(s)
            for s in swept_specs(study, records)}
    swept = sweeps_dataset(ds, records, study, runs)
    figures = []

    def save(fig, path):
        figures.append(fig)
        return path

    monkeypatch.setattr(line_figures, "save", save)
    line_figures.plot_sweeps(sweep_line(prods["sweeps"], 0), tmp_path / "plain.png")
    line_figures.plot_sweeps(sweep_line(swept, 0), tmp_path / "swept.png")
    plain, drawn = figures
    labels = [t.get_text() for t in drawn.legends[0].get_texts()]
    assert [t for t in labels if t.startswith("swept sine")] == [
        "swept sine, 0.001 per unit tau", "swept sine, 0.0001 per unit tau"]
    assert not any(t.get_text().startswith("swept") for t in plain.legends[0].get_texts())
    for ax_plain, ax in zip(plain.axes, drawn.axes):
        thin = [ln for ln in ax.get_lines() if ln.get_linewidth() == 0.7]
        assert len(ax.get_lines()) - len(ax_plain.get_lines()) == len(thin) == 4
        assert sorted(ln.get_alpha() for ln in thin) == [0.35, 0.35, 0.9, 0.9]
    # a fifth panel, log-log: each stepped jump's swept delays against the rates that left it
    assert len(plain.axes) == 4 and len(drawn.axes) == 5
    delays = drawn.axes[4]
    assert delays.get_xscale() == delays.get_yscale() == "log"
    stored = sweep_line(swept, 0)
    rates = stored["rate"].values
    expected = [(rates[ok], d[ok]) for d in stored["swept_jump_delay"].values
                for ok in [np.isfinite(d) & (d > 0)] if ok.any()]
    got = [(ln.get_xdata(), ln.get_ydata()) for ln in delays.get_lines()]
    assert len(got) == len(expected)
    for (gx, gy), (ex, ey) in zip(got, expected):
        np.testing.assert_array_equal(gx, ex)
        np.testing.assert_array_equal(gy, ey)
    if not expected:            # these lines' few steps hold no jump a fast run left
        assert "no swept run left its branch" in " ".join(t.get_text() for t in delays.texts)


def test_the_sweeps_delay_panel_draws_each_jumps_delays_against_the_rate():
    """The sweeps figure's fifth panel (line_figures._plot_swept_delays) on a hand-made
    product: one log-log line per stepped jump that some rate's run left, its points the rates
    with a finite positive delay, named by direction, kind and the stepped jump's value."""
    import matplotlib.pyplot as plt
    import xarray as xr

    from hertzmap.study.plots.line_figures import _plot_swept_delays

    nan = float("nan")
    line = xr.Dataset(
        {"swept_jump_delay": (("jump", "rate"), [[4.0e-3, 8.6e-4, 1.9e-4], [nan, 3.0e-2, 1.4e-2],
                                                 [nan, nan, nan]]),
         "jump_direction": ("jump", [1, 0, 0]), "jump_kind": ("jump", [1, 2, 1]),
         "jump_value": ("jump", [0.4720908, 1.977579, 0.7535257])},
        coords={"rate": [1e-5, 1e-6, 1e-7]})
    fig, ax = plt.subplots()
    _plot_swept_delays(ax, line, ("rate", "per unit tau"), 1.0, {1: "fold", 2: "flip"},
                       "delay of the jump in omega")
    lines = ax.get_lines()
    assert [ln.get_label() for ln in lines] == ["down, fold at 0.47209", "up, flip at 1.9776"]
    np.testing.assert_array_equal(lines[0].get_xdata(), [1e-5, 1e-6, 1e-7])
    np.testing.assert_array_equal(lines[0].get_ydata(), [4.0e-3, 8.6e-4, 1.9e-4])
    np.testing.assert_array_equal(lines[1].get_xdata(), [1e-6, 1e-7])
    np.testing.assert_array_equal(lines[1].get_ydata(), [3.0e-2, 1.4e-2])
    assert ax.get_xscale() == ax.get_yscale() == "log"
    assert ax.get_ylabel() == "delay of the jump in omega"
    plt.close(fig)
