"""study.solve.curve_seeds: seeds from the grid's sign changes (kinds, planes, order), one trace per
curve (coverage, the completeness check), the spec's "curves" output, and the traced-curves product (study.products)."""
from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from benchmarks import oracle
from hertzmap.kernels import continuation as cont
from hertzmap.scheduler.stages.curve_tasks import product_summary
from hertzmap.study.products.traced_curves import (CODIM2_CODES, combine_traced_curves, isola_boundary,
                                          trace_from_part, traced_curves_dataset,
                                          traced_segments)
from hertzmap.study.schema import BIFURCATION_KINDS, CROSSING_SLOTS
from hertzmap.study.solve import curve_seeds as C
from hertzmap.study.spec import StudyError, parse_study

Z = 0.01


LEVEL = -1.5          # contact-loss level of the Hertz law n = 1.5 (min q = -n)


def orbit(period, mu, min_q=-0.1, max_q=0.1, x0=(0.0, 0.0)):
    """An orbit record as study.solve.curve_seeds reads the stored slots."""
    return dict(period=period, x0=x0, min_q=min_q, max_q=max_q, ptp=max_q - min_q,
                multipliers=np.asarray(mu, complex))


def test_flip_and_grazing_crossings_between_matched_orbits():
    # flip function (1 + mu1)(1 + mu2): 0.5 * 1.5 = 0.75 at P, -0.25 * 1.5 = -0.375 at Q:
    # the crossing at 0.75 / (0.75 + 0.375) = 2/3 of the edge, the nearer orbit Q's
    a, b = orbit(1, [-0.5, 0.5], x0=(1.0, 2.0)), orbit(1, [-1.25, 0.5], x0=(3.0, 4.0))
    (c,) = C.crossings([a], [b], LEVEL)
    assert c["kind"] == "flip" and c["period"] == 1 and c["theta"] == pytest.approx(2 / 3)
    assert c["orbit"]["x0"] == (3.0, 4.0)
    # grazing: min q + 1.5 = +0.1 at P, -0.3 at Q: a quarter of the edge, the nearer orbit P's
    a, b = orbit(2, [0.5, 0.2], -1.4, 0.5, (1.0, 2.0)), orbit(2, [0.5, 0.2], -1.8, 0.5)
    (c,) = C.crossings([a], [b], LEVEL)
    assert (c["kind"], c["period"]) == ("grazing", 2) and c["theta"] == pytest.approx(0.25)
    assert c["orbit"]["x0"] == (1.0, 2.0) and c["min_q"] == pytest.approx(-1.5)
    # no sign change, or two orbits too far apart to be one branch: no crossing
    assert C.crossings([orbit(1, [-0.5, 0.5])], [orbit(1, [-0.9, 0.5])], LEVEL) == []
    assert C.crossings([orbit(1, [-0.5, 0.5])], [orbit(1, [-1.25, 0.5], 5.0, 9.0)],
                       LEVEL, searched=(1, 2)) == []


def test_branch_ends_fold_pairs_and_census_orbits():
    # both halves of a fold at P (fold functions (1 - mu1)(1 - mu2) of opposite signs), no
    # continuation at Q: one fold seed at the edge's midpoint, the halves' mean start point
    stable = orbit(1, [0.9, 0.5], -0.3, 0.4, (1.0, 0.0))
    unstable = orbit(1, [1.1, 0.5], -0.35, 0.45, (1.2, 0.2))
    (c,) = C.crossings([stable, unstable], [], LEVEL, searched=(1, 2))
    assert (c["kind"], c["period"], c["theta"]) == ("fold", 1, 0.5)
    np.testing.assert_allclose(c["orbit"]["x0"], (1.1, 0.1))
    # a lone end of a searched period is not a fold (its other half was not found)
    assert C.crossings([stable], [], LEVEL, searched=(1, 2)) == []
    # a census orbit (period 3, not searched) ending with a multiplier near +1: a fold; near
    # -1: a flip; elsewhere: nothing
    for mu, kind in (([0.9, 0.1], "fold"), ([-0.85, 0.1], "flip"), ([0.3, 0.1], None)):
        got = C.crossings([], [orbit(3, mu)], LEVEL, searched=(1, 2))
        assert [d["kind"] for d in got] == ([kind] if kind else []), mu
    # a 2T orbit ending on the 1T orbit at its flip (same invariants): a branch point, no fold
    one, two = orbit(1, [-0.95, 0.3]), orbit(2, [0.9, 0.09])
    assert C.crossings([], [one, two], LEVEL, searched=(1,)) == []


def grid(omega, sigma, zeta, mu_of, min_q_of, crossings=None, chunk=None):
    """A results Dataset with one orbit per grid point: period 1, multipliers (mu_of(w, s), 0.5),
    min q min_q_of(w), max q 0.2; ``crossings``: {(j, k): [records]} of the lines' own
    crossing_* variables (every omega block of ``chunk``; the other lines not recorded)."""
    shape = (len(omega), len(sigma), len(zeta), 1)
    W, S = np.meshgrid(omega, sigma, indexing="ij")
    mu = np.zeros(shape + (2,), complex)
    mu[..., 0, 0] = mu_of(W, S)[:, :, None]
    mu[..., 0, 1] = 0.5
    lo = np.broadcast_to(min_q_of(W)[:, :, None, None], shape).copy()
    dims = ("omega", "sigma", "zeta", "solution")
    ds = xr.Dataset({"period": (dims, np.ones(shape, np.int8)),
                     "status": (dims, np.zeros(shape, np.int8)),
                     "q0": (dims, np.zeros(shape)), "v0": (dims, np.zeros(shape)),
                     "min_q": (dims, lo), "max_q": (dims, np.full(shape, 0.2)),
                     "ptp": (dims, 0.2 - lo),
                     "multipliers": (dims + ("multiplier",), mu)},
                    coords={"omega": np.asarray(omega, float), "sigma": np.asarray(sigma, float),
                            "zeta": np.asarray(zeta, float)})
    if crossings is not None:
        blocks = -(-len(omega) // (chunk[0] if chunk else len(omega)))
        lshape = (blocks, len(sigma), len(zeta), CROSSING_SLOTS)
        kind, per = np.zeros(lshape, np.int8), np.zeros(lshape, np.int8)
        count = np.full(lshape[:3], -1, np.int16)
        rest = {n: np.full(lshape, np.nan) for n in ("omega", "q0", "v0", "min_q", "max_q",
                                                      "spread")}
        for (j, k), recs in crossings.items():
            count[:, j, k] = 0
            for slot, d in enumerate(recs):
                kind[0, j, k, slot] = BIFURCATION_KINDS[d["kind"]]
                per[0, j, k, slot] = d["period"]
                for n in rest:
                    rest[n][0, j, k, slot] = d[n]
        ldims = ("omega_block", "sigma", "zeta", "crossing")
        ds["crossing_kind"] = (ldims, kind)
        ds["crossing_period"] = (ldims, per)
        ds["crossing_count"] = (ldims[:3], count)
        for n, v in rest.items():
            ds[f"crossing_{n}"] = (ldims, v)
    if chunk is not None:
        ds.attrs["hertzmap_chunk_shape"] = list(chunk)
    return ds


def test_seeds_per_plane_and_order():
    omega, sigma = [1.9, 1.95, 2.0, 2.05, 2.1], [0.4, 0.5]
    # the 1T flip (mu1 = -1) at omega 1.97 on sigma 0.4 and 1.93 on sigma 0.5 (flip function
    # -6 (omega - w0(sigma)): linear, so the interpolated crossings are exact); across the
    # lines at omega 1.95 half way (sigma 0.45); grazing (min q = -1.5) at omega 2.075 on both
    mu = lambda w, s: -1.0 - 4.0 * (w - np.where(s < 0.45, 1.97, 1.93))     # noqa: E731
    mq = lambda w: -1.5 - 2.0 * (w - 2.075)                                  # noqa: E731
    seeds = C.curve_seeds(grid(omega, sigma, [Z], mu, mq), LEVEL, (1, 2))
    # one zeta: the (omega, sigma) plane only; line by line: along it, then to the next line
    assert {s.plane for s in seeds} == {("omega", "sigma")} and all(s.fixed == Z for s in seeds)
    got = [(s.kind, round(s.omega, 12), round(s.sigma, 12), s.hold) for s in seeds]
    assert got == [("flip", 1.97, 0.4, "sigma"), ("grazing", 2.075, 0.4, "sigma"),
                   ("flip", 1.95, 0.45, "omega"),
                   ("flip", 1.93, 0.5, "sigma"), ("grazing", 2.075, 0.5, "sigma")]
    assert [s.index for s in seeds] == list(range(5))
    # the lines' own records replace the stored slots' crossings along omega inside a block
    rec = dict(kind="flip", period=1, omega=1.9711, q0=0.5, v0=0.6, min_q=-0.1, max_q=0.2,
               spread=0.0)
    ds = grid(omega, sigma, [Z], mu, mq, crossings={(0, 0): [rec]}, chunk=(5, 1, 1))
    got = [(s.kind, s.omega, s.sigma, s.q0) for s in C.curve_seeds(ds, LEVEL, (1, 2))]
    # (its line's grazing is not in the records: not a seed); line 0.5 was not recorded (a
    # block out of time): its crossings from the stored slots
    assert got == [("flip", 1.9711, 0.4, 0.5), ("flip", 1.95, 0.45, 0.0),
                   ("flip", 1.93, 0.5, 0.0), ("grazing", 2.075, 0.5, 0.0)]
    # omega blocks of 2 points: the edges between blocks are read from the stored slots
    ds = grid(omega, sigma, [Z], mu, mq, crossings={(0, 0): []}, chunk=(2, 1, 1))
    got = [(s.kind, round(s.omega, 12)) for s in C.curve_seeds(ds, LEVEL, (1, 2))
           if s.sigma == 0.4]
    assert got == [("flip", 1.97), ("grazing", 2.075)]    # edges 1.95 | 2.0 and 2.05 | 2.1
    # sweeping zeta too: the (omega, zeta) and (sigma, zeta) planes get their seeds
    seeds = C.curve_seeds(grid(omega, sigma, [0.01, 0.02], mu, mq), LEVEL, (1, 2))
    planes = [s.plane for s in seeds]
    assert planes.count(("omega", "sigma")) == 10 and planes.count(("omega", "zeta")) == 8
    assert planes.count(("sigma", "zeta")) == 2          # across the lines at omega 1.95
    assert C.swept_planes({"omega": [1, 2], "sigma": [1], "zeta": [1]}) == []


@pytest.fixture(scope="module")
def flip_trace():
    """The 1T flip curve's right arm in (omega, sigma) at zeta 0.01 from a point at sigma 0.5,
    and the located flip of the same arm at sigma 0.6 (by continuation in omega)."""
    from hertzmap.study.solve.seeds import linear_response_seed

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


STEPS = {"omega": 0.005, "sigma": 0.05}       # a grid of the fixture's window


def test_a_seed_on_a_traced_curve_is_covered(flip_trace):
    r, seed, other, bounds = flip_trace
    # the orbit's min q and max q at the located flip by the scipy oracle (min q exact, max q
    # sampled: to ~1e-5 of the orbit's size ~0.35, well inside the continuity rule's share)
    lo = oracle.min_q((other.q0, other.v0), other.omega, 0.6, Z)
    t = np.linspace(0.0, 2.0 * np.pi / other.omega, 2001)
    q, _, _ = oracle.trajectory((other.q0, other.v0), 0.0, t[-1], t, other.omega, 0.6, Z)
    other = C.Seed(**{**other.as_dict(), "min_q": lo, "max_q": float(np.max(q))})
    assert C.covers(r, seed, STEPS) and C.covers(r, other, STEPS)
    # another kind, another period, another zeta, or another orbit at the same point: not
    for changed in (dict(kind="grazing"), dict(period=2), dict(fixed=0.02),
                    dict(min_q=lo + 1.0)):
        s = C.Seed(**{**other.as_dict(), **changed})
        assert not C.covers(r, s, STEPS), changed
    far = C.Seed(**{**other.as_dict(), "omega": other.omega - 0.05})     # 10 omega steps
    assert not C.covers(r, far, STEPS)


def test_the_completeness_check_reports_every_uncovered_seed(flip_trace):
    r, seed, other, _ = flip_trace
    axes = {"omega": np.arange(1.9, 2.1 + 1e-9, STEPS["omega"]),
            "sigma": np.arange(0.4, 0.7 + 1e-9, STEPS["sigma"]), "zeta": np.array([Z])}
    off = dict(other.as_dict(), omega=other.omega - 0.05)      # no flip curve passes there
    seeds = [seed, C.Seed(**dict(other.as_dict(), index=1)),
             C.Seed(**dict(off, index=2)),                      # its trace will fail to start
             C.Seed(**dict(off, index=3, omega=off["omega"] + STEPS["omega"])),
             C.Seed(**dict(off, index=4, sigma=0.45, omega=other.omega - 0.1))]
    book = C.SeedBook(seeds, axes)
    assert not book.skip(0)
    assert book.commit(r) == -1                                  # the first curve: kept
    assert book.skip(1)                                          # on it
    assert not book.skip(2)
    failed = {"seed": seeds[2].as_dict(), "status": ("start_fail", "start_fail"),
              "vertices": {}, "codim2": [], "maps": 3}
    book.commit(failed)
    assert book.skip(3)                                          # next to a failed start
    assert not book.skip(4)
    # seed 4's trace converged onto the curve of seed 0, far from seed 4's own cell
    dup = dict(r, seed=seeds[4].as_dict())
    assert book.commit(dup) == 0
    out = book.outcomes()
    assert [(d["outcome"], d["curve"], d["ref"]) for d in out] == [
        ("traced", 0, -1), ("covered", 0, -1), ("start_fail", -1, 1), ("near_untraced", -1, 2),
        ("on_earlier_curve", -1, 0)]
    # stored in the product and counted in the run's summary
    product = combine_traced_curves([traced_curves_dataset([r]), traced_curves_dataset([failed])],
                                    {}, out)
    assert product.sizes["seed"] == 5 and product.sizes["curve"] == 2
    assert product["seed_curve"].values.tolist() == [0, 0, -1, -1, -1]
    assert product_summary(product)["uncovered"] == {"start_fail": 1, "near_untraced": 1,
                                                     "on_earlier_curve": 1}
    for name in ("seed_outcome", "seed_curve", "seed_ref", "seed_omega"):
        assert {"long_name", "units", "description"} <= set(product[name].attrs), name


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
    # the seeds are the grid's sign changes: the stored orbits' measures and the lines'
    # crossings, not the located points (their continuation costs 2-5x the grid)
    assert "curves" in s.outputs and "measures" in s.outputs
    assert "bifurcations" not in s.outputs
    kw = s.solver_kwargs()
    assert kw["crossings"] is True and not kw.get("locate", False)
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


def test_a_committed_part_reads_back_as_it_was_written(flip_trace, tmp_path):
    from hertzmap.scheduler.store import read_curve_parts, write_curve_part
    from hertzmap.study.products.traced_curves import part_attrs
    r, *_ = flip_trace
    part = traced_curves_dataset([r], part_attrs(r, 3))
    write_curve_part(tmp_path, 7, part)
    back = read_curve_parts(tmp_path)
    assert list(back) == [7]
    for name, var in part.variables.items():
        np.testing.assert_array_equal(back[7][name].values, var.values)
        assert back[7][name].dtype == var.dtype and back[7][name].dims == var.dims, name
    assert back[7].attrs == part.attrs
    assert trace_from_part(back[7])["duplicate_of"] == 3
    xr.testing.assert_identical(combine_traced_curves([back[7]]), combine_traced_curves([part]))
