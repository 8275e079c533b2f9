"""study.products.stroboscopic.attractor_ids on hand-set attractors (every value set here): one id
for periodic attractors on one branch and for overlapping chaotic clouds, separate ids for a
fold between two orbits, a distant cloud, and kinds that differ."""
from __future__ import annotations

import numpy as np
import xarray as xr

from hertzmap.study.products.stroboscopic import attractor_ids

N = 5


def _dataset():
    om = np.array([1.0, 1.1, 1.2, 1.3, 1.4])
    shape4 = (N, 1, 1, 2)
    kind = np.zeros(shape4, np.int8)
    sol = np.full(shape4, -1, np.int8)
    per = np.zeros(shape4, np.int8)
    basin = np.full(shape4, np.nan)
    sq = np.full(shape4 + (8,), np.nan)
    sv = np.full(shape4 + (8,), np.nan)
    rng = np.random.default_rng(1)
    # slot 0: a stable 2T orbit at points 0-2 (invariants drift slowly), then at 3-4 another
    # 2T orbit far from it (a jump: a different branch)
    min_q = np.full((N, 1, 1, 1), np.nan)
    max_q = np.full((N, 1, 1, 1), np.nan)
    for i, lo in enumerate([-1.0, -1.01, -1.02, -3.0, -3.01]):
        kind[i, 0, 0, 0], sol[i, 0, 0, 0], per[i, 0, 0, 0], basin[i, 0, 0, 0] = 1, 0, 2, 0.5
        min_q[i, 0, 0, 0], max_q[i, 0, 0, 0] = lo, lo + 1.5
    # slot 1: chaotic clouds at points 0-2 overlapping, at point 3 a cloud far away, at 4 none
    for i, centre in enumerate([(0.0, 0.0), (0.02, 0.0), (0.04, 0.01), (20.0, 20.0)]):
        kind[i, 0, 0, 1], basin[i, 0, 0, 1] = 2, 0.5
        sq[i, 0, 0, 1] = centre[0] + rng.normal(0, 1, 8)
        sv[i, 0, 0, 1] = centre[1] + rng.normal(0, 1, 8)
    mult = np.full((N, 1, 1, 1, 2), 0.5 + 0j)
    d4 = ("omega", "sigma", "zeta", "attractor")
    s4 = ("omega", "sigma", "zeta", "solution")
    return xr.Dataset(
        {"attractor_kind": (d4, kind), "attractor_solution": (d4, sol),
         "attractor_period": (d4, per), "basin_fraction": (d4, basin),
         "strobe_q": (d4 + ("strobe",), sq), "strobe_v": (d4 + ("strobe",), sv),
         "period": (s4, np.full((N, 1, 1, 1), 2, np.int8)), "min_q": (s4, min_q),
         "max_q": (s4, max_q), "ptp": (s4, max_q - min_q),
         "multipliers": (s4 + ("multiplier",), mult),
         "computed": (("omega", "sigma", "zeta"), np.ones((N, 1, 1), bool))},
        coords={"omega": om, "sigma": [0.5], "zeta": [0.01]})


def test_ids_follow_branches_and_clouds():
    out = attractor_ids(_dataset())
    ids = out["attractor_id"].values[:, 0, 0, :]
    periodic, chaotic = ids[:, 0], ids[:, 1]
    assert periodic[0] == periodic[1] == periodic[2]
    assert periodic[3] == periodic[4] != periodic[0]
    assert chaotic[0] == chaotic[1] == chaotic[2]
    assert chaotic[3] not in (chaotic[0], -1) and chaotic[4] == -1
    assert len(set(ids.ravel()) - {-1}) == out.sizes["id"] == 4
    k = out["id_kind"].values
    assert k[periodic[0]] == 1 and k[chaotic[0]] == 2
    assert out["id_points"].values[periodic[0]] == 3 and out["id_period"].values[periodic[0]] == 2
    assert out["id_basin"].values[chaotic[0]] == 0.5
    for v in out.data_vars.values():
        assert v.attrs["long_name"] and "units" in v.attrs
