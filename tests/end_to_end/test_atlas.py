"""The atlas end to end: a small study in the subharmonic window whose grid search leaves orbits
at some points only; the atlas continues them across its tiles (several, and a halo between
them). The same store with one worker as with two, and after a client killed between two staged
tiles of a round then rerun; every orbit the atlas added is a fixed point of the oracle's own
period map (benchmarks/oracle.py)."""
from __future__ import annotations

import subprocess

import numpy as np
import pytest
import xarray as xr

from benchmarks import oracle
from hertzmap.scheduler.store import ATLAS_ATTR, ATLAS_STAGE, Store, read_attrs
from hertzmap.study.schema import ATTRACTOR_KINDS
from hertzmap.study.solve.atlas import census_points
from tests.helpers import SLOW_ATLAS_TILE, hertzmap_cmd, kill_run_when, subprocess_env
from tests.scheduler.test_run import assert_same_store

pytestmark = [pytest.mark.slow]

STUDY = """
[study]
name = "atlas"
[grid]
omega = {start = 1.95, stop = 2.15, num = 9}
sigma = {start = 0.6, stop = 0.9, num = 5}
zeta = 0.01
[search]
# the grid's search meets unstable 3T orbits at some points: the atlas continues them
continue_unstable = "all"
[products]
outputs = ["orbits", "measures"]
"""
ARGS = ["--task-seconds", "0.01", "--error-sample", "0"]


def _run(d, store, *extra, study="atlas.toml"):
    r = subprocess.run(hertzmap_cmd("run", str(d / study), "--store", str(store), *ARGS, *extra),
                       env=subprocess_env(), capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "Traceback" not in r.stdout + r.stderr
    return r.stdout


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    d = tmp_path_factory.mktemp("atlas")
    (d / "atlas.toml").write_text(STUDY)
    ref = d / "ref.zarr"
    out = _run(d, ref, "--workers", "2")
    return d, ref, out


def test_the_atlas_adds_orbits_that_the_oracle_confirms(reference):
    d, ref, out = reference
    assert "atlas:" in out and "round(s) to the fixed point" in out, out
    ds = xr.open_zarr(ref).load()
    assert len(Store(ref).done_mask().ravel()) > 1                       # several tiles
    state = read_attrs(ref)[ATLAS_ATTR]
    assert state["phase"] == "done" and state["rounds"][-1]["added"] == 0
    added = np.argwhere((ds.atlas_round.values > 0) & (ds.status.values == 0))
    assert len(added) > 0
    assert not (ref / ATLAS_STAGE).exists()
    for i, j, k, s in added[:: max(1, len(added) // 6)]:
        x = np.array([float(ds.q0.values[i, j, k, s]), float(ds.v0.values[i, j, k, s])])
        w, sg = float(ds.omega[i]), float(ds.sigma[j])
        m = int(ds.period.values[i, j, k, s])
        phi = oracle.period_map(x, w, sg, 0.01, m)
        assert np.max(np.abs(phi - x)) < 1e-7 * (1 + np.hypot(*x)), (w, sg, m)
    # the counts follow: every orbit found is stored; the slot dim is as long as the point
    # that holds most
    stored = (ds.status.values == 0).sum(axis=-1)
    np.testing.assert_array_equal(ds.orbits_found.values, stored)
    assert ds.sizes["solution"] == (ds.status.values != -1).sum(axis=-1).max()


def test_one_worker_gives_the_same_store(reference, tmp_path):
    d, ref, _ = reference
    one = tmp_path / "one.zarr"
    _run(d, one, "--workers", "1")
    assert_same_store(ref, one)
    assert read_attrs(one)[ATLAS_ATTR] == read_attrs(ref)[ATLAS_ATTR]


def test_client_killed_between_staged_tiles_then_rerun_identical(reference, tmp_path):
    d, ref, _ = reference
    store = tmp_path / "killed.zarr"
    cmd = hertzmap_cmd("run", str(d / "atlas.toml"), "--store", str(store), *ARGS,
                       "--workers", "2", "--atlas-tile", SLOW_ATLAS_TILE)
    stage = store / ATLAS_STAGE / "round_0001"
    kill_run_when(cmd, subprocess_env(HERTZMAP_ATLAS_DELAY="1.0"),
                  lambda p: stage.is_dir() and any(not q.name.startswith(".")
                                                   for q in stage.iterdir()),
                  "a staged tile of the first atlas round")
    staged = [q for q in stage.iterdir() if not q.name.startswith(".")]
    assert 1 <= len(staged) < len(Store(store).done_mask().ravel()), "the kill missed the round"
    assert read_attrs(store).get(ATLAS_ATTR, {}).get("phase") != "done"
    _run(d, store, "--workers", "2")
    assert_same_store(ref, store)


# -- census rounds -----------------------------------------------------------------------------
# Two sigma lines of the vibro-impact scene (its whole omega axis: a line's search depends on
# the line only, so these are the scene's lines): the grid finds a stable 3T orbit on one line
# where the other line's census, in its first pass, called the transients chaotic; the atlas
# brings the orbit over, and a census round runs those points' census again.
CENSUS_STUDY = """
[study]
name = "census_rounds"
[grid]
omega = {start = 0.3, stop = 2.6, num = 93}
sigma = {start = 1.55, stop = 1.6, num = 2}
zeta = 0.01
[search]
periods = [1, 2]
attractors = "where-none-stable"
initial_states = 16
transient_periods = 500
record_periods = 128
[products]
outputs = ["orbits", "measures", "attractors"]
"""


@pytest.fixture(scope="module")
def census_reference(tmp_path_factory):
    d = tmp_path_factory.mktemp("census_rounds")
    (d / "census_rounds.toml").write_text(CENSUS_STUDY)
    ref = d / "ref.zarr"
    out = _run(d, ref, "--workers", "2", study="census_rounds.toml")
    return d, ref, out


def test_census_rounds_run_where_the_atlas_brought_a_stable_orbit(census_reference):
    d, ref, out = census_reference
    assert "the census run again at" in out, out
    state = read_attrs(ref)[ATLAS_ATTR]
    kinds = [r["kind"] for r in state["rounds"]]
    assert "census" in kinds and state["phase"] == "done", state
    ds = xr.open_zarr(ref).load()
    # no point is left where the census called transients chaotic after one pass beside a
    # stable orbit (the rule the census rounds run on: study.solve.atlas.census_points) ...
    arrays = {n: ds[n].values for n in ("attractor_kind", "attractor_periods_run", "stable",
                                        "status")}
    assert not census_points(arrays, 500, 128).any()
    # ... and the stable orbits the atlas brought to chaotic points are the oracle's
    chaotic = (ds.attractor_kind.values == ATTRACTOR_KINDS["non_periodic"]).any(axis=-1)
    brought = (ds.status.values == 0) & ds.stable.values & (ds.atlas_round.values > 0)
    where = np.argwhere(chaotic[..., None] & brought)
    assert len(where) > 0
    for i, j, k, s in where:
        x = np.array([float(ds.q0.values[i, j, k, s]), float(ds.v0.values[i, j, k, s])])
        m = int(ds.period.values[i, j, k, s])
        phi = oracle.period_map(x, float(ds.omega[i]), float(ds.sigma[j]), 0.01, m)
        assert np.max(np.abs(phi - x)) < 1e-7 * (1 + np.hypot(*x))
        # their census ran the longer passes beside the orbit
        assert np.nanmax(ds.attractor_periods_run.values[i, j, k]) > 500 + 128


def test_census_round_killed_then_rerun_on_one_worker_gives_the_same_store(census_reference,
                                                                          tmp_path):
    """One worker instead of two, and the client killed in the census round: the rerun ends
    with the reference's store."""
    d, ref, _ = census_reference
    store = tmp_path / "killed.zarr"
    cmd = hertzmap_cmd("run", str(d / "census_rounds.toml"), "--store", str(store), *ARGS,
                       "--workers", "1", "--atlas-tile", SLOW_ATLAS_TILE)

    def in_census_round(_):
        state = (read_attrs(store) or {}).get(ATLAS_ATTR) or {}     # None: no store yet
        return state.get("kind") == "census" and state.get("phase") == "computing"

    kill_run_when(cmd, subprocess_env(HERTZMAP_ATLAS_DELAY="1.0"), in_census_round,
                  "the census round")
    state = read_attrs(store)[ATLAS_ATTR]
    assert state["kind"] == "census" and state["phase"] != "done", "the kill missed the round"
    _run(d, store, "--workers", "1", study="census_rounds.toml")
    assert_same_store(ref, store)
    assert read_attrs(store)[ATLAS_ATTR] == read_attrs(ref)[ATLAS_ATTR]
