"""study.plots: every figure a study's products support is drawn (valid PNGs of a sane size), the
paper's analytic figures, and which figures a scene gets."""
from __future__ import annotations

import matplotlib
import pytest

from hertzmap.study import plots
from hertzmap.study import products as P
from tests.helpers import blank_results, set_orbit


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


def test_histories_are_drawn_only_where_asked_or_few_frequencies():
    few = P.open_store(blank_results("[grid]\nomega = [1.0, 2.0]\nsigma = 0.3\nzeta = 0.01\n"))
    many = P.open_store(blank_results("[grid]\nomega = {start = 1, stop = 2, num = 9}\n"
                                      "sigma = 0.3\nzeta = 0.01\n"))
    assert plots.wants_time_histories(few) and not plots.wants_time_histories(many)
    assert plots.wants_time_histories(many, ["histories"])
    with pytest.raises(ValueError, match="unknown figure"):
        plots.wants_time_histories(many, ["maps"])
