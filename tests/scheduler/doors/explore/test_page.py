"""hertzmap explore on a store of several zeta values: the page's zeta selector lists the
store's values and redraws the map of the one chosen (scheduler.doors.explore.page; no browser: the
Bokeh document's callbacks run in the test)."""
from __future__ import annotations

from bokeh.document import Document

from hertzmap.scheduler.cluster.clusters import ClusterSpec
from hertzmap.scheduler.doors.explore.page import Page
from hertzmap.scheduler.doors.explore.state import ExploreState
from tests.helpers import blank_results, set_orbit, write_results


def test_the_zeta_selector_redraws_the_map_of_the_chosen_zeta(tmp_path):
    ds = blank_results("[grid]\nomega = [1.9, 2.0, 2.1]\nsigma = [0.2, 0.4]\n"
                       "zeta = [0.005, 0.01, 0.02]\n", "z")
    for i in range(3):
        for j in range(2):
            # a stable 1T orbit in contact at zeta 0.005 and 0.01, one that loses it at 0.02
            for k in range(3):
                set_orbit(ds, i, j, 0, period=1, stable=True, loses=k == 2,
                          min_q=-2.0 if k == 2 else -0.1, k=k)
    store = write_results(ds, tmp_path / "z.zarr")
    page = Page(Document(), ExploreState(store, ClusterSpec()))
    assert page.zeta_select.options == ["0.005", "0.01", "0.02"]
    assert not page.zeta_select.disabled and page.zeta == 0.005
    first = list(page.map_src.data["code"])
    page.zeta_select.value = "0.02"
    assert page.zeta == 0.02 and "zeta = 0.02" in page.map.title.text
    assert list(page.map_src.data["code"]) != first
