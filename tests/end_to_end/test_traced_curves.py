"""The "curves" output end to end: a small study near omega = 2 at zeta = 0.01 whose grid's
sign changes of the test functions seed the 1T flip curve, the isola's 2T fold curve (it ends where the isola joins the
flip-born branch) and the two arms of the 2T grazing curve; its client killed between two committed curves and
rerun, against an undisturbed run; curves (re)traced on a complete store; the figures."""
from __future__ import annotations

import os
import shutil
import signal
import subprocess

import numpy as np
import pytest
import xarray as xr

from benchmarks import oracle
from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.store import CURVE_PARTS, PRODUCT_GROUP, Store, read_product
from tests.helpers import SLOW_TRACER, hertzmap_cmd, subprocess_env, wait_until
from tests.scheduler.test_run import assert_same_store

pytestmark = [pytest.mark.slow]

STUDY = """
[study]
name = "traced"
[grid]
omega = {start = 1.85, stop = 2.1, num = 11}
sigma = [0.3, 0.4, 0.5]
zeta = 0.01
[products]
outputs = ["orbits", "measures", "curves"]
"""
ARGS = ["--workers", "2", "--task-seconds", "0.01", "--error-sample", "0"]


@pytest.fixture(scope="module")
def paths(tmp_path_factory):
    d = tmp_path_factory.mktemp("traced")
    (d / "traced.toml").write_text(STUDY)
    ref = d / "ref.zarr"
    r = subprocess.run(hertzmap_cmd("run", str(d / "traced.toml"), "--store", str(ref), *ARGS),
                       env=subprocess_env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stdout + r.stderr
    return d, ref, r.stdout


def traced(store) -> xr.Dataset:
    return read_product(store, "traced_curves")


def test_curves_of_the_study(paths):
    _, ref, out = paths
    assert "curves: 5 traced" in out, out
    t = traced(ref)
    ok = t.curve_vertices.values > 0                   # dim curve keeps failed starts too
    kinds = sorted(zip(t.curve_kind.values[ok].tolist(), t.curve_period.values[ok].tolist()))
    # the 2T fold (isola), the 1T flip, both arms of the 2T grazing curve (they meet at
    # sigma 0.273, below the window, on the 2T fold curve), and the fold of the stable 3T
    # orbits the census finds at sigma 0.45-0.5 (test_3t_fold_curve_against_the_oracle)
    assert kinds == [(1, 2), (1, 3), (2, 1), (3, 2), (3, 2)]
    assert (t.curve_vertices.values[ok] > 20).all()
    assert np.all(t.residual.values < 1e-9)
    # the isola's fold curve ends on the 1T orbit where it joins the flip-born branch
    fold = int(np.nonzero((t.curve_kind.values == 1) & ok)[0][0])
    assert t.curve_status_start.values[fold] == 2 or t.curve_status_end.values[fold] == 2
    join = t.codim2_kind.values == 2
    assert join.sum() == 1
    assert abs(float(t.codim2_sigma.values[join][0]) - 0.3596) < 1e-3
    # the completeness check: every seed is covered by a traced curve, or says why not; here
    # one fold seed of the coarse grid (two 2T branches paired across a sharp change, no fold
    # there) does not start, and the summary says so
    assert t.attrs["hertzmap_curve_seeds"] == t.sizes["seed"] > 3
    outcome = dict(zip(np.asarray(t.seed_outcome.attrs["flag_values"]).tolist(),
                       t.seed_outcome.attrs["flag_meanings"].split()))
    names = [outcome[int(c)] for c in t.seed_outcome.values]
    covered = t.seed_curve.values >= 0
    assert all(n in ("traced", "covered") for n in np.array(names)[covered])
    assert all(n not in ("traced", "covered") for n in np.array(names)[~covered])
    assert (t.seed_curve.values[covered] < t.sizes["curve"]).all()
    assert "seeds not covered by a traced curve:" in out
    # the vertices stay in the window, the flip curve's lowest point is a refined extremum
    assert t.omega.min() >= 1.85 - 1e-12 and t.sigma.max() <= 0.5 + 1e-12
    flip = t.where(t.curve_id == int(np.nonzero(t.curve_kind.values == 2)[0][0]), drop=True)
    k = int(np.argmin(flip.sigma.values))
    assert int(flip.flag.values[k]) & 2 and abs(float(flip.sigma[k]) - 0.35904) < 1e-4
    assert not (ref / PRODUCT_GROUP / CURVE_PARTS).exists()


def test_each_seed_cell_brackets_a_sign_change_of_the_oracle(paths):
    """Every flip and grazing seed lies in a grid cell where the scipy oracle's own test
    function (1 + tr M + det M of its monodromy from the variational equations; min q + n by
    event location) changes sign between the cell's two grid points, for the oracle's orbits
    of the seed's period started from the stored ones."""
    _, ref, _ = paths
    t = traced(ref)
    res = xr.open_zarr(str(ref), chunks=None)
    omega, sigma = np.sort(res.omega.values), np.sort(res.sigma.values)
    kinds = {2: "flip", 3: "grazing"}
    checked = 0
    for i in range(t.sizes["seed"]):
        kind = kinds.get(int(t.seed_kind[i]))
        if kind is None:
            continue
        m, w, s = int(t.seed_period[i]), float(t.seed_omega[i]), float(t.seed_sigma[i])
        if np.isclose(sigma, s, rtol=0, atol=1e-12).any():         # a cell along omega
            k = int(np.searchsorted(omega, w))
            ends = [(omega[k - 1], s), (omega[k], s)]
        else:                                                       # a cell across sigma
            k = int(np.searchsorted(sigma, s))
            ends = [(w, sigma[k - 1]), (w, sigma[k])]
        signs = []
        for we, se in ends:
            pt = res.sel(omega=we, sigma=se, zeta=0.01, method="nearest")
            ok = (pt.status.values == 0) & (pt.period.values == m)
            g = []
            for q0, v0 in zip(pt.q0.values[ok], pt.v0.values[ok]):
                if kind == "flip":
                    f, _ = oracle.flip_function_at(we, se, 0.01, (q0, v0), m)
                else:
                    x = oracle.checked_fixed_point((q0, v0), we, se, 0.01, m)
                    f = oracle.min_q(x, we, se, 0.01, m) + 1.5
                g.append(np.sign(f))
            signs.append(set(g))
        # the 1T orbit (one per point here) on either side of the curve's condition; of 2T
        # orbits (stable and unstable) at least one on each side
        if m == 1:
            assert signs[0] | signs[1] == {1.0, -1.0} and len(signs[0]) == len(signs[1]) == 1
        assert {1.0, -1.0} <= signs[0] | signs[1], (kind, m, w, s, signs)
        checked += 1
    assert checked >= 8


def test_3t_fold_curve_against_the_oracle(paths):
    """The fold curve of the census's 3T orbits (seeded where the line search followed a
    stable 3T orbit to its fold): vertices against the scipy oracle's fold of the period-3
    map on the vertex's omega line (sigma the extremum along the branch, rtol 1e-12)."""
    _, ref, _ = paths
    t = traced(ref)
    k = int(np.nonzero((t.curve_kind.values == 1) & (t.curve_period.values == 3)
                       & (t.curve_vertices.values > 0))[0][0])
    c = t.where(t.curve_id == k, drop=True)
    n = c.sizes["vertex"]
    assert n > 20
    for i in (n // 4, n // 2, 3 * n // 4):
        w, s = float(c.omega[i]), float(c.sigma[i])
        x = (float(c.q0[i]), float(c.v0[i]))
        s_oracle, _ = oracle.fold_on_line(x, fixed="omega", free="sigma", m=3,
                                          params=dict(omega=w, sigma=s, zeta=0.01),
                                          half_width=0.02)
        assert abs(s_oracle - s) < 1e-8, (w, s, s_oracle)


def test_client_killed_between_curves_then_rerun_identical(paths, tmp_path):
    d, ref, _ = paths
    store = tmp_path / "killed.zarr"
    cmd = hertzmap_cmd("run", str(d / "traced.toml"), "--store", str(store), *ARGS,
                       "--curve-tracer", SLOW_TRACER)
    env = subprocess_env(HERTZMAP_CURVE_DELAY="1.5")
    parts = store / PRODUCT_GROUP / CURVE_PARTS
    p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    try:
        wait_until(lambda: (parts.is_dir() and any(not q.name.startswith(".")
                                                  for q in parts.iterdir()))
                   or p.poll() is not None, 240, "a committed curve")
        os.killpg(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    committed = [q for q in parts.iterdir() if not q.name.startswith(".")]
    assert 1 <= len(committed) < traced(ref).sizes["curve"], "the kill landed after the curves"
    assert Store(store).done_mask().all()                 # the grid was complete
    # the same command again, its curves without the pause (the kill is behind us)
    r = subprocess.run(cmd, env=subprocess_env(HERTZMAP_CURVE_DELAY="0"), capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "all 3 tasks done" in r.stdout and "committed" in r.stdout
    assert f"{len(committed)} resumed" in r.stdout
    assert_same_store(store, ref)
    xr.testing.assert_identical(traced(store), traced(ref))      # the seed_* variables too
    assert traced(store).sizes["seed"] > 3


def test_curves_retraced_on_a_complete_store(paths, tmp_path):
    d, ref, _ = paths
    store = tmp_path / "copy.zarr"
    shutil.copytree(ref, store)
    shutil.rmtree(store / PRODUCT_GROUP / "traced_curves")
    rc = main(["run", str(d / "traced.toml"), "--store", str(store), *ARGS])
    assert rc == 0
    xr.testing.assert_identical(traced(store), traced(ref))


def test_figures_draw_the_traced_curves(paths, tmp_path, capsys):
    _, ref, _ = paths
    store = tmp_path / "plot.zarr"
    shutil.copytree(ref, store)
    assert main(["plot", str(store), "--out", str(tmp_path), "--which", "map",
                 "bifurcation"]) == 0
    out = capsys.readouterr().out
    assert "traced_curves" in out and "isola_boundary" in out
    assert (tmp_path / "traced_map.png").is_file()
    assert (tmp_path / "traced_bifurcation.png").is_file()
    iso = read_product(store, "isola_boundary")
    assert abs(float(iso.sigma_join.sel(zeta=0.01)) - 0.3596) < 1e-3
    assert np.isnan(float(iso.sigma_isola.sel(zeta=0.01)))     # sigma** is below the window
    # the product was read, not rewritten: identical to the run's
    xr.testing.assert_identical(traced(store), traced(ref))
