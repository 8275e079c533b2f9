"""study.products.traced_curves: docs/dataset.md lists its variables, and its worked query
(sigma** for each zeta) reads sigma** off a product."""
from __future__ import annotations

import re

import numpy as np
import xarray as xr

from hertzmap.study.products.traced_curves import (TRACED_VARIABLES, combine_traced_curves,
                                          isola_boundary, traced_curves_dataset)
from tests.helpers import REPO, fake_trace
from tests.study.test_schema import _doc_table


def test_docs_list_every_traced_variable():
    rows = _doc_table("docs/dataset.md", "Traced-curve variables")
    documented = {n for row in rows for n in re.findall(r"`([^`]+)`", row[0])}
    assert documented == set(TRACED_VARIABLES)


def test_the_worked_query_sigma_star2_per_zeta():
    join = dict(kind="fold_flip", period=2, omega=2.0, sigma=0.36, zeta=0.01, q0=0.0, v0=0.0,
                multipliers=[-1, 0.5], value=0.0, left=1e-9, right=np.nan, accuracy=1e-8,
                vertex=4)
    parts = [traced_curves_dataset([t]) for t in (
        fake_trace(0, "fold", 2, 0.01, [0.3, 0.2, 0.17, 0.25, 0.36], [join]),
        fake_trace(1, "fold", 2, 0.02, [0.5, 0.4, 0.35, 0.45, 0.6],
                    [dict(join, zeta=0.02, sigma=0.7)]),
        fake_trace(2, "fold", 1, 0.01, [0.3, 0.1, 0.05, 0.2, 0.3]))]    # not the isola
    tc = combine_traced_curves(parts)
    text = (REPO / "docs" / "dataset.md").read_text()
    query = text[text.index("### Worked query: sigma**"):]
    code = query[query.index("```python") + 9:query.index("```", query.index("```python") + 9)]
    code = code.replace('xr.open_zarr("results/fig09.zarr", group="products/traced_curves")'
                        '.load()', "tc").replace("print(", "(")
    code = code[:code.index("# the same, read off by hertzmap plot")]
    env = {"np": np, "xr": xr, "tc": tc}
    exec(code.replace("import numpy as np\nimport xarray as xr\n", ""), env)
    s = env["sigma_2star"]
    assert s.sel(zeta=0.01) == 0.17 and s.sel(zeta=0.02) == 0.35
    iso = isola_boundary(tc)
    np.testing.assert_array_equal(iso.sigma_isola.values, [0.17, 0.35])
    np.testing.assert_array_equal(iso.sigma_join.values, [0.36, 0.7])
