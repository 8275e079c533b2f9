"""study.solve.curves: seeds from located points (planes, order), one trace per curve
(coverage), the spec's "curves" output, and the traced-curves product (study.products)."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from kernels import continuation as cont
from study.products.traced_curves import (CODIM2_CODES, combine_traced_curves, isola_boundary,
                                          trace_from_part, traced_curves_dataset,
                                          traced_segments)
from study.schema import BIFURCATION_KINDS, BIFURCATION_SLOTS
from study.solve import curves as C
from study.spec import StudyError, parse_study

Z = 0.01


def located(omega, sigma, zeta, points):
    """A results Dataset holding only located points: points = [(j, k, kind, period, omega,
    q0, v0)] on line (sigma[j], zeta[k]), one omega block."""
    shape = (1, len(sigma), len(zeta), BIFURCATION_SLOTS)
    kind = np.zeros(shape, np.int8)
    per = np.zeros(shape, np.int8)
    w, q, v = (np.full(shape, np.nan) for _ in range(3))
    count = np.zeros(shape[:3], np.int16)
    for j, k, kd, p, wo, q0, v0 in points:
        s = int(count[0, j, k])
        kind[0, j, k, s], per[0, j, k, s] = BIFURCATION_KINDS[kd], p
        w[0, j, k, s], q[0, j, k, s], v[0, j, k, s] = wo, q0, v0
        count[0, j, k] += 1
    dims = ("omega_block", "sigma", "zeta", "bifurcation")
    return xr.Dataset({"bifurcation_kind": (dims, kind), "bifurcation_period": (dims, per),
                       "bifurcation_omega": (dims, w), "bifurcation_q0": (dims, q),
                       "bifurcation_v0": (dims, v),
                       "bifurcation_count": (dims[:3], count)},
                      coords={"omega": np.asarray(omega, float),
                              "sigma": np.asarray(sigma, float),
                              "zeta": np.asarray(zeta, float)})


def test_seeds_per_plane_and_order():
    omega, sigma = np.linspace(1.9, 2.1, 5), [0.4, 0.5]
    pts = [(0, 0, "flip", 1, 1.97, 0.1, 0.2), (0, 0, "grazing", 2, 1.93, 0.3, 0.4),
           (1, 0, "flip", 1, 1.96, 0.1, 0.2)]
    seeds = C.curve_seeds(located(omega, sigma, [Z], pts))
    # one zeta: only the (omega, sigma) plane; line by line, then by omega
    assert [s.plane for s in seeds] == [("omega", "sigma")] * 3
    assert [(s.kind, s.sigma, s.omega) for s in seeds] == [
        ("grazing", 0.4, 1.93), ("flip", 0.4, 1.97), ("flip", 0.5, 1.96)]
    assert [s.index for s in seeds] == [0, 1, 2] and all(s.fixed == Z for s in seeds)
    # sweeping zeta too: (omega, zeta) at each sigma and (sigma, zeta) at the nearest omega
    ds = located(omega, sigma, [0.01, 0.02], pts)
    seeds = C.curve_seeds(ds)
    planes = [s.plane for s in seeds]
    assert planes.count(("omega", "sigma")) == 3 and planes.count(("omega", "zeta")) == 3
    sz = [s for s in seeds if s.plane == ("sigma", "zeta")]
    assert len(sz) == 3 and sorted(s.fixed for s in sz) == [1.95] * 3   # the nearest grid omega
    assert sz[0].params()["omega"] == sz[0].fixed
    assert C.swept_planes({"omega": [1, 2], "sigma": [1], "zeta": [1]}) == []


@pytest.fixture(scope="module")
def flip_trace():
    """The 1T flip curve's right arm in (omega, sigma) at zeta 0.01 from a point at sigma 0.5,
    and the located flip of the same arm at sigma 0.6 (by continuation in omega)."""
    from study.solve.seeds import linear_response_seed

    def flip_at(sigma):
        b = cont.continue_orbit(Z, linear_response_seed(2.2, sigma, Z), omega=2.2, sigma=sigma,
                                period=1, direction=-1, p_min=1.9, p_max=2.3, dp_max=0.01)
        return max((p for p in b.special if p.kind == "flip"), key=lambda p: p.omega)
    a, b = flip_at(0.5), flip_at(0.6)
    seed = C.Seed(0, ("omega", "sigma"), Z, "flip", 1, a.omega, 0.5, Z, *a.x0)
    other = C.Seed(1, ("omega", "sigma"), Z, "flip", 1, b.omega, 0.6, Z, *b.x0)
    bounds = {"omega": (1.9, 2.1), "sigma": (0.4, 0.7)}
    return C.trace_seed(seed, bounds), seed, other, bounds


def test_trace_seed_returns_arrays(flip_trace):
    r, seed, _, bounds = flip_trace
    V = r["vertices"]
    assert r["status"] == ("boundary", "boundary") and r["maps"] > 0
    assert V["multipliers"].shape == (len(V["omega"]), 2)
    # a multiplier -1 at every vertex (the flip), the vertices inside the window
    assert np.max(np.min(np.abs(V["multipliers"] + 1.0), axis=1)) < 1e-8
    assert V["sigma"].min() >= 0.4 - 1e-12 and V["sigma"].max() <= 0.7 + 1e-12
    assert V["flag"][np.argmin(np.abs(V["sigma"] - 0.5))].astype(int) & cont.VERTEX_SEED


def test_a_seed_on_a_traced_curve_is_covered(flip_trace):
    r, seed, other, bounds = flip_trace
    assert C.covers(r, seed, bounds) and C.covers(r, other, bounds)
    # another kind, another period, another zeta, or another orbit at the same point: not
    for changed in (dict(kind="grazing"), dict(period=2), dict(fixed=0.02),
                    dict(q0=other.q0 + 1.0)):
        s = C.Seed(**{**other.as_dict(), **changed})
        assert not C.covers(r, s, bounds), changed
    far = C.Seed(**{**other.as_dict(), "omega": other.omega - 0.05})
    assert not C.covers(r, far, bounds)


def test_the_curves_output_in_the_study_file():
    base = """
[study]
name = "c"
[grid]
omega = {start = 1.9, stop = 2.1, num = 5}
sigma = SIGMA
zeta = 0.01
[products]
outputs = ["orbits", "curves"]
"""
    s = parse_study(base.replace("SIGMA", "[0.4, 0.5]"))
    assert "curves" in s.products and "bifurcations" in s.products     # curves need seeds
    assert s.solver_kwargs()["locate"] is True
    with pytest.raises(StudyError) as e:
        parse_study(base.replace("SIGMA", "0.5"))
    assert e.value.field == "products.outputs" and "two swept" in str(e.value)


def test_product_round_trip_and_isola_boundary(flip_trace):
    r, *_ = flip_trace
    failed = {"seed": {**r["seed"], "index": 5, "kind": "fold", "period": 2},
              "status": ("start_fail", "start_fail"), "vertices": {}, "codim2": [], "maps": 3}
    one = traced_curves_dataset([r])
    two = traced_curves_dataset([failed])
    both = combine_traced_curves([one, two])
    assert both.sizes["curve"] == 2 and both.sizes["vertex"] == len(r["vertices"]["omega"])
    assert both["curve_vertices"].values.tolist() == [len(r["vertices"]["omega"]), 0]
    assert both["curve_status_end"].attrs["flag_meanings"].split()[5] == "start_fail"
    for name, var in both.variables.items():
        if name != "multiplier":
            assert {"long_name", "units", "description"} <= set(var.attrs), name
    xr.testing.assert_identical(both, combine_traced_curves([one, two]))
    segs = traced_segments(both, kind="flip", period=1, zeta=Z)
    assert len(segs) == 1 and segs[0].shape[1] == 2
    back = trace_from_part(traced_curves_dataset([r], {"hertzmap_curve_seed": "{}"})
                           .assign_attrs(hertzmap_curve_seed=__import__("json").dumps(r["seed"]),
                                         hertzmap_curve_status='["boundary", "boundary"]'))
    np.testing.assert_array_equal(back["vertices"]["omega"], r["vertices"]["omega"])
    # no 2T fold curve ending on the 1T orbit: no isola
    iso = isola_boundary(both)
    assert np.isnan(iso["sigma_isola"].values).all() and iso["curve"].values.tolist() == [-1]
    assert CODIM2_CODES["fold_flip"] == 2


def test_a_seed_that_does_not_converge_is_a_failed_trace():
    seed = C.Seed(0, ("omega", "sigma"), Z, "fold", 2, 1.0, 0.5, Z, 50.0, 50.0)
    r = C.trace_seed(seed, {"omega": (0.5, 2.5), "sigma": (0.05, 1.0)},
                     options={"max_points": 5})
    assert r["status"] == ("start_fail", "start_fail")
    assert all(len(v) == 0 for v in r["vertices"].values())
    part = traced_curves_dataset([r])
    assert part.sizes["vertex"] == 0 and part["curve_vertices"].values.tolist() == [0]
