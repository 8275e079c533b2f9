"""scheduler.doors.library, what ``import hertzmap`` offers: a study from a path, a scene, TOML text
or a dict; a run on the user's own Dask client that stores what ``hertzmap run`` stores, is
interrupted (SIGINT, a notebook's interrupt) and resumed from Python to the same store; bad
input refused by exceptions naming the field, the store left untouched; the store as one
DataTree."""
from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest
import xarray as xr

import hertzmap
from hertzmap.scheduler.doors.cli import main
from tests.helpers import (blank_results, done_count, small_study_toml, subprocess_env, wait_until,
                           write_results)

STUDY = small_study_toml("library", omega={"start": 0.6, "stop": 2.4, "num": 19},
                         sigma=[0.1, 0.4, 0.7, 1.0], zeta=[0.01, 0.05],
                         outputs=["orbits", "measures"])


def _files(store) -> dict[str, int]:
    return {str(p.relative_to(store)): p.stat().st_mtime_ns for p in store.rglob("*")
            if p.is_file()}


def test_a_study_from_each_form():
    by_text = hertzmap.load_study(STUDY)
    doc = {"study": {"name": "library"},
           "grid": {"omega": {"start": 0.6, "stop": 2.4, "num": 19},
                    "sigma": [0.1, 0.4, 0.7, 1.0], "zeta": [0.01, 0.05]},
           "search": {"periods": [1, 2], "attractors": "never"},
           "products": {"outputs": ["orbits", "measures"]}}
    assert hertzmap.load_study(doc).hash == by_text.hash
    assert hertzmap.load_study(by_text) is by_text
    default = hertzmap.load_study("default")
    assert default.name == "default" and hertzmap.scene_paths()["default"].is_file()
    with pytest.raises(hertzmap.StudyError) as exc:
        hertzmap.load_study({"grid": {"omega": [1.9], "sigma": [0.5], "zeta": -0.5}})
    assert exc.value.field == "grid.zeta" and "got -0.5" in str(exc.value)
    with pytest.raises(hertzmap.StudyError) as exc:
        hertzmap.load_study(42)
    assert exc.value.field == "study"
    # import hertzmap is light: nothing of numba or Dask until a function is used
    r = subprocess.run([sys.executable, "-c", "import sys, hertzmap; print(sorted(m for m in "
                        "('numba', 'distributed', 'zarr') if m in sys.modules))"],
                       capture_output=True, text=True, env=subprocess_env(), timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stdout + r.stderr


@pytest.mark.slow
def test_a_run_on_my_client_is_the_cli_run_and_resumes_after_an_interrupt(tmp_path):
    from distributed import Client, LocalCluster

    path = tmp_path / "library.toml"
    path.write_text(STUDY)
    reference, store = tmp_path / "cli.zarr", tmp_path / "lib.zarr"
    assert main(["run", str(path), "--store", str(reference), "--workers", "2"]) == 0
    # interrupted as a notebook's interrupt button does: SIGINT to the Python process
    code = f"import hertzmap; hertzmap.run({str(path)!r}, {str(store)!r}, workers=2)"
    p = subprocess.Popen([sys.executable, "-c", code], env=subprocess_env(),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_until(lambda: done_count(store) >= 2 or p.poll() is not None, 120, "2 tasks")
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    done = done_count(store)
    total = done_count(reference)
    assert 2 <= done < total, f"the interrupt landed after the end ({done}/{total})"
    assert "to resume, run again" in err and "KeyboardInterrupt" in err
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as client:
        tree = hertzmap.run(path, store, client=client, quiet=True)
        assert client.status == "running"           # the user's client is left open
    assert isinstance(tree, xr.DataTree)
    assert "resumed" in tree.attrs["history"]
    # a block the interrupted run had staged (more slots than the store had) is not left over
    assert not [p.name for p in store.iterdir() if p.name.endswith("_stage")]
    a, b = xr.open_zarr(store).load(), xr.open_zarr(reference).load()
    assert a.attrs["hertzmap_study_hash"] == b.attrs["hertzmap_study_hash"]
    a.attrs, b.attrs = {}, {}
    xr.testing.assert_identical(a, b)
    xr.testing.assert_identical(tree["period"].load(), xr.open_zarr(reference)["period"].load())

    # bad input: an exception naming what is wrong, the store untouched
    before = _files(store)
    with pytest.raises(hertzmap.RefusedError, match="workers"):
        hertzmap.run(path, store, workers=0)
    with pytest.raises(hertzmap.RefusedError, match="another study|belongs"):
        hertzmap.run(STUDY.replace("0.05]", "0.06]"), store, workers=1)
    with pytest.raises(hertzmap.StudyError, match="grid.sigma"):
        hertzmap.run(STUDY.replace("0.7, 1.0]", "0.7, -1.0]"), store)
    assert _files(store) == before
    # done already: a rerun computes nothing and returns the tree
    t0 = time.perf_counter()
    again = hertzmap.run(path, store, quiet=True)
    assert time.perf_counter() - t0 < 30 and set(again.children) == set(tree.children)


def test_a_product_of_an_earlier_layout_is_refused_by_name(tmp_path):
    """A store whose product group an earlier version wrote on its own omega grid under the
    name ``omega`` (mms_curves before it had mms_omega): open says which group and how to
    rewrite it, instead of xarray's alignment error."""
    import numpy as np

    from hertzmap.scheduler.store import write_product

    store = write_results(blank_results("[grid]\nomega = [1.9, 2.0]\nsigma = 0.3\nzeta = 0.01\n"),
                          tmp_path / "old.zarr")
    assert set(hertzmap.open(store).children) == set()
    old = xr.Dataset({"sigma1": ("omega", np.zeros(5))}, coords={"omega": np.linspace(1.75, 2.25, 5)})
    write_product(store, "mms_curves", old)
    with pytest.raises(hertzmap.RefusedError, match="products/mms_curves.*hertzmap plot"):
        hertzmap.open(store)
