"""The atlas end to end: a small study in the subharmonic window whose grid search leaves orbits
at some points only; the atlas continues them across its tiles (several, and a halo between
them). The same store with one worker as with two, and after a client killed between two staged
tiles of a round then rerun; every orbit the atlas added is a fixed point of the oracle's own
period map (benchmarks/oracle.py)."""
from __future__ import annotations

import os
import signal
import subprocess

import numpy as np
import pytest
import xarray as xr

from benchmarks import oracle
from hertzmap.scheduler.store import ATLAS_ATTR, ATLAS_STAGE, Store, read_attrs
from tests.helpers import SLOW_ATLAS_TILE, hertzmap_cmd, subprocess_env, wait_until
from tests.scheduler.test_run import assert_same_store

pytestmark = [pytest.mark.slow]

STUDY = """
[study]
name = "atlas"
[grid]
omega = {start = 1.95, stop = 2.15, num = 9}
sigma = {start = 0.6, stop = 0.9, num = 5}
zeta = 0.01
[products]
outputs = ["orbits", "measures"]
"""
ARGS = ["--task-seconds", "0.01", "--error-sample", "0"]


def _run(d, store, *extra, env=None):
    r = subprocess.run(hertzmap_cmd("run", str(d / "atlas.toml"), "--store", str(store), *ARGS,
                                    *extra), env=env or subprocess_env(), capture_output=True,
                       text=True, timeout=600)
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
    # the counts follow: every stored orbit is counted found, none dropped beyond the slots
    stored = (ds.status.values == 0).sum(axis=-1)
    assert (ds.orbits_found.values >= stored).all()
    np.testing.assert_array_equal(ds.orbits_dropped.values, ds.orbits_found.values - stored)


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
    p = subprocess.Popen(cmd, env=subprocess_env(HERTZMAP_ATLAS_DELAY="1.0"),
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    try:
        wait_until(lambda: stage.is_dir() and any(not q.name.startswith(".")
                                                  for q in stage.iterdir()), timeout=300,
                   what="a staged tile of the first atlas round")
        os.killpg(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    staged = [q for q in stage.iterdir() if not q.name.startswith(".")]
    assert 1 <= len(staged) < len(Store(store).done_mask().ravel()), "the kill missed the round"
    assert read_attrs(store).get(ATLAS_ATTR, {}).get("phase") != "done"
    _run(d, store, "--workers", "2")
    assert_same_store(ref, store)
