"""The "bifurcations" output end to end: fold/flip/grazing points located along each omega line,
stored per omega block, assembled into curves, with a client killed mid-study and rerun. A
small study through the flips of the 1T orbit near omega = 2 at zeta = 0.01."""
from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
import xarray as xr

from benchmarks import oracle
from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.store import Store, lock_path, store_status
from hertzmap.study import products as P
from hertzmap.study.schema import OUTPUT_VARIABLES, stored_variables
from hertzmap.study.spec import parse_study
from tests.helpers import hertzmap_cmd, kill_client_mid_study, subprocess_env
from tests.scheduler.test_run import assert_same_store


BIFURCATION_STUDY = """
[study]
name = "bifstore"
[grid]
omega = {start = 1.9, stop = 2.1, num = 9}
sigma = [0.4, 0.5, 0.6, 0.7]
zeta = 0.01
[products]
outputs = ["orbits", "measures", "bifurcations"]
"""


pytestmark = [pytest.mark.slow]

SIGMAS = [0.4, 0.5, 0.6, 0.7]
TEXT_WITHOUT = BIFURCATION_STUDY.replace(', "bifurcations"', "")
TASK_SECONDS = "0.01"          # one sigma line per task: 4 tasks


@pytest.fixture(scope="module")
def paths(tmp_path_factory):
    d = tmp_path_factory.mktemp("bif")
    (d / "bifstore.toml").write_text(BIFURCATION_STUDY)
    ref = d / "ref.zarr"
    rc = main(["run", str(d / "bifstore.toml"), "--store", str(ref), "--workers", "2",
               "--task-seconds", TASK_SECONDS, "--error-sample", "0"])
    assert rc == 0
    return d, ref


#: brackets in omega holding one flip of the 1T orbit each, for every sigma of the study: all
#: are above sigma* ~ 0.36 (paper Eq. 26), so the 1T orbit is past its flip (a multiplier below
#: -1) on an interval around omega = 2 (1.988..2.008 at sigma 0.4, 1.960..2.029 at 0.7)
FLIP_BRACKETS = ((1.95, 1.999), (2.001, 2.05))
#: the study solves at rtol 1e-10: its located flips are within 1e-8 of the converged ones
#: (docs/discovery.md, spread over rtol 1e-8..1e-12; found 6e-11 from the oracle's); the
#: oracle's own flips at rtol 1e-11 (~0.7 s each) move by < 1e-10 from rtol 1e-12
FLIP_TOL = 1e-8
ORACLE_RTOL = 1e-11


def test_stored_flips_match_the_oracle(paths):
    """Every stored 1T flip against the oracle's own flip (benchmarks.oracle.flip_omega: brentq
    on 1 + tr M + det M of its scipy fixed point and its monodromy from the variational
    equations) in the stated brackets."""
    _, ref = paths
    ds = xr.open_zarr(ref).load()
    assert ds.sizes["omega_block"] == 1 and ds.sizes["bifurcation"] == 16
    assert ds.bifurcation_kind.attrs["flag_meanings"] == "empty fold flip grazing"
    worst = 0.0
    for j, s in enumerate(SIGMAS):
        kind = ds.bifurcation_kind.values[0, j, 0]
        per = ds.bifurcation_period.values[0, j, 0]
        w = ds.bifurcation_omega.values[0, j, 0]
        n = int(ds.bifurcation_count.values[0, j, 0])
        assert n == int((kind > 0).sum()) and np.isnan(w[kind == 0]).all()
        flips = np.sort(w[(kind == 2) & (per == 1)])
        assert flips.size == 2, (s, w, kind)       # the two flips of the 1T orbit
        for wf, bracket in zip(flips, FLIP_BRACKETS):
            guess = (ds.bifurcation_q0.values[0, j, 0][w == wf][0],
                     ds.bifurcation_v0.values[0, j, 0][w == wf][0])
            w_oracle, _ = oracle.flip_omega(bracket, s, 0.01, guess, rtol=ORACLE_RTOL)
            worst = max(worst, abs(wf - w_oracle))
        # grazing of the 2T branch (onset of contact loss) below the lower flip
        assert ((kind == 3) & (per == 2)).sum() == 1
        assert np.all(np.diff(w[kind > 0]) >= 0)               # ordered by omega
    assert worst < FLIP_TOL, worst


def test_curves_assembled_and_checked(paths):
    _, ref = paths
    ds = P.open_store(ref)
    c = P.located_curves(ds)
    flips = c.where((c.kind == 2) & (c.period == 1), drop=True)
    segs = np.unique(flips.segment.values)
    assert segs.size == 2                       # the left and right arms of the flip curve
    for sgm in segs:
        arm = flips.where(flips.segment == sgm, drop=True)
        np.testing.assert_array_equal(arm.sigma.values, SIGMAS)
    left = flips.where(flips.omega < 2, drop=True)
    assert np.all(np.diff(left.omega.values) < 0)     # the flip region widens with sigma
    prods = P.compute_products(ds)
    assert "located_bifurcations" in prods
    # status --check covers the new variables: a lost chunk is reported damaged
    d, _ = paths
    broken = d / "broken.zarr"
    shutil.copytree(ref, broken)
    (broken / "bifurcation_omega" / "c" / "0" / "2" / "0" / "0").unlink()
    damaged = store_status(broken, check=True)["damaged"]
    assert list(damaged) == ["0-2-0"] and "bifurcation_omega" in damaged["0-2-0"][0]


def test_without_the_product_nothing_changes(tmp_path):
    s = parse_study(TEXT_WITHOUT)
    # the product is in the study's canonical form (and so its hash, which names its store)
    # only when asked for
    assert "bifurcations" not in s.to_dict()["products"]["outputs"]
    assert parse_study(BIFURCATION_STUDY).hash != s.hash
    assert "locate" not in s.solver_kwargs()
    assert not set(stored_variables(s)) & set(OUTPUT_VARIABLES["bifurcations"])
    assert parse_study(BIFURCATION_STUDY).solver_kwargs()["locate"] is True
    from hertzmap.study.solve.block import solve_block
    om, sg, zt = s.axis("omega"), s.axis("sigma")[:1], s.axis("zeta")
    a = solve_block(om, sg, zt, **s.solver_kwargs())
    b = solve_block(om, sg, zt, locate=True, **s.solver_kwargs())
    assert not any(k.startswith("bifurcation") for k in a)
    for k, v in a.items():                        # the grid results do not depend on locate
        np.testing.assert_array_equal(v, b[k], err_msg=k)


def test_client_killed_then_rerun_identical(paths, tmp_path):
    d, ref = paths
    store = tmp_path / "killed.zarr"
    cmd = hertzmap_cmd("run", str(d / "bifstore.toml"), "--store", str(store), "--workers", "2",
                       "--task-seconds", TASK_SECONDS, "--error-sample", "0")
    env = subprocess_env()
    done = kill_client_mid_study(cmd, env, store, 1)
    assert lock_path(store).exists()
    from hertzmap.scheduler.store.block_writes import staged_blocks

    done += len(staged_blocks(store))    # staged before the kill: packed on resume, not rerun
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    if done < 4:
        assert f"{done}/4 tasks already done" in r.stdout
    assert Store(store).done_mask().all()
    assert_same_store(store, ref)             # including the bifurcation_* variables
