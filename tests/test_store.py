"""The store: template schema and attrs, region writes, completion flags, refusal of another
study, resume, status. Uses the placeholder solver (same contract as study.block) on an
in-process Dask cluster, so it runs without the real solver."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
import zarr

from conftest import PLACEHOLDER, placeholder_solve_block
from scheduler.cli import main
from scheduler.cluster import ClusterSpec
from scheduler.plan import choose_chunks, make_plan
from scheduler.run import RunOptions, run_study
from scheduler.store import Lock, Store, StoreError, lock_path, open_or_create, store_status
from study.dataset import (PRODUCT_VARIABLES, VARIABLES, bytes_per_point, stored_variables,
                           template)
from study.spec import parse_study

TEXT = """
[study]
name = "store-test"
[grid]
omega = {start = 0.5, stop = 2.5, num = 17}
sigma = [0.1, 0.3, 0.5, 0.7, 0.9]
zeta = [0.01, 0.1]
[products]
outputs = ["orbits", "measures", "force_harmonics"]
"""


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as c:
        yield c


def study(text=TEXT):
    return parse_study(text, default_name="x")


def run(path, client, text=TEXT, **kw):
    opts = RunOptions(store=path, solver=PLACEHOLDER, cluster=ClusterSpec(kind="address"),
                      error_sample=kw.pop("error_sample", 0), **kw)
    return run_study(study(text), opts, client=client)


def test_template_schema_and_attrs():
    s = study()
    ds = template(s, (17, 1, 1), history="h")
    names = stored_variables(s)
    assert set(names) == set(PRODUCT_VARIABLES["orbits"] + PRODUCT_VARIABLES["measures"]
                             + PRODUCT_VARIABLES["force_harmonics"])
    assert "residual" not in ds and "newton_iterations" not in ds
    assert set(ds.data_vars) == set(names) | {"task_done"}
    assert ds.sizes["omega"] == 17 and ds.sizes["solution"] == 4
    assert ds.multipliers.dims[-1] == "multiplier" and ds.sizes["multiplier"] == 2
    assert list(ds.harmonic.values) == [1, 2, 3, 4]
    assert ds.task_done.shape == (1, 5, 2)
    for name in list(ds.data_vars) + list(ds.coords):
        assert ds[name].attrs.get("long_name"), name
        assert "units" in ds[name].attrs, name
    assert list(ds.status.attrs["flag_values"]) == [-1, 0, 1, 2, 3, 4, 5, 6, 7, 8]
    assert ds.status.attrs["flag_meanings"].split() == [
        "empty", "converged", "not_converged", "diverged", "step_limit", "step_size", "singular",
        "time_limit", "unsettled", "unconfirmed"]
    assert ds.attrs["hertzmap_study_hash"] == s.hash
    assert ds.attrs["hertzmap_study_toml"] == TEXT
    assert json.loads(ds.attrs["hertzmap_study_json"]) == s.to_dict()
    versions = json.loads(ds.attrs["hertzmap_versions"])
    assert {"numpy", "numba", "scipy", "dask", "zarr", "xarray", "hertzmap"} <= set(versions)
    assert ds.attrs["history"] == "h"
    # empty values: NaN floats, False bools, period 0, status -1; no memory used
    assert np.isnan(ds.q0.values).all() and not ds.stable.values.any()
    assert (ds.status.values == -1).all() and (ds.period.values == 0).all()
    assert ds.q0.variable._data.base is not None or ds.q0.values.strides[0] == 0
    assert bytes_per_point(s) == 4 * (7 * 8 + 2 * 16 + 4 * 1 + 4 * 8)


def test_placeholder_honours_the_contract():
    s = study()
    out = placeholder_solve_block(s.axis("omega"), s.axis("sigma")[:2], s.axis("zeta")[:1],
                                  **s.solver_kwargs())
    for name, v in VARIABLES.items():
        if v.per_block:       # "bifurcations": the placeholder does not locate points
            continue
        a = out[name]
        extra = (v.extra_dim[1],) if v.extra_dim else ()
        assert a.shape == (17, 2, 1, 4) + extra and a.dtype == np.dtype(v.dtype), name


def test_run_writes_every_block_and_flags(tmp_path, client):
    path = tmp_path / "a.zarr"
    summary = run(path, client)
    assert summary["complete"] and summary["tasks_run"] == summary["tasks_total"]
    ds = xr.open_zarr(path)           # opens silently: consolidated metadata
    assert bool(ds.task_done.all())
    s = study()
    ref = placeholder_solve_block(s.axis("omega"), s.axis("sigma"), s.axis("zeta"), **s.solver_kwargs())
    for name in stored_variables(s):
        np.testing.assert_array_equal(ds[name].values, ref[name], err_msg=name)
        assert ds[name].dtype == np.dtype(VARIABLES[name].dtype)
        assert ds[name].attrs["long_name"] == VARIABLES[name].long_name
    np.testing.assert_array_equal(ds.omega.values, s.axis("omega"))
    assert ds.omega.attrs["long_name"] == "excitation frequency"
    # chunks are aligned with tasks: one chunk per task
    chunks = tuple(ds.attrs["hertzmap_chunk_shape"])
    assert ds.q0.encoding["chunks"] == chunks + (4,)
    assert ds.task_done.size == summary["tasks_total"]
    assert "created" in ds.attrs["history"] and "completed" in ds.attrs["history"]
    assert not lock_path(path).exists()
    # worked queries of docs/dataset.md
    both = ds[["q0", "v0"]].where(ds.stable & ds.loses_contact)
    assert int(both.q0.count()) == int((ds.stable & ds.loses_contact).sum())
    n_coexisting = (ds.status == 0).sum("solution")
    assert int(n_coexisting.max()) == 2
    assert int((ds.period == 2).sum()) > 0


def test_resume_computes_only_missing_tasks(tmp_path, client):
    path = tmp_path / "b.zarr"
    ref = tmp_path / "ref.zarr"
    run(ref, client)
    s = study()
    store, resumed = open_or_create(path, s, choose_chunks(s), overwrite=False, action="t")
    assert not resumed
    plan = make_plan(s, store.chunks)
    # do two tasks "by hand", leave one written-but-unflagged (client died in between)
    names = stored_variables(s)
    for t in plan.tasks[:3]:
        so, ss, sz = t.slices
        out = placeholder_solve_block(s.axis("omega")[so], s.axis("sigma")[ss], s.axis("zeta")[sz],
                                      **s.solver_kwargs())
        store.write_block(t.slices, out, names)
        if t is not plan.tasks[2]:
            store.mark_done(t.index)
    summary = run(path, client)
    assert summary["tasks_done_before"] == 2
    assert summary["tasks_run"] == len(plan.tasks) - 2
    a, b = xr.open_zarr(path).load(), xr.open_zarr(ref).load()
    a.attrs, b.attrs = {}, {}
    xr.testing.assert_identical(a, b)
    # and a third run does nothing
    again = run(path, client)
    assert again["tasks_run"] == 0 and again["complete"]


def test_another_study_is_refused_unless_overwrite(tmp_path, client, capsys):
    path = tmp_path / "c.zarr"
    run(path, client)
    other = TEXT.replace("zeta = [0.01, 0.1]", "zeta = [0.02]")
    before = sorted(p.name for p in path.rglob("*"))
    with pytest.raises(StoreError, match="another study"):
        run(path, client, text=other)
    assert sorted(p.name for p in path.rglob("*")) == before
    # through the CLI: exit code 2, nothing changed
    f = tmp_path / "other.toml"
    f.write_text(other)
    assert main(["run", str(f), "--store", str(path), "--workers", "1"]) == 2
    assert "another study" in capsys.readouterr().err
    assert xr.open_zarr(path).attrs["hertzmap_study_hash"] == study().hash
    summary = run(path, client, text=other, overwrite=True)
    assert summary["complete"]
    assert xr.open_zarr(path).attrs["hertzmap_study_hash"] == study(other).hash
    assert xr.open_zarr(path).sizes["zeta"] == 1


def test_non_store_paths_are_never_touched(tmp_path, client):
    d = tmp_path / "notastore"
    d.mkdir()
    (d / "precious.txt").write_text("keep me")
    with pytest.raises(StoreError, match="not a zarr store"):
        run(d, client, overwrite=True)
    assert (d / "precious.txt").read_text() == "keep me"
    # a foreign zarr store: refused without --overwrite
    z = tmp_path / "foreign.zarr"
    zarr.open_group(zarr.storage.LocalStore(z), mode="w", zarr_format=3)
    with pytest.raises(StoreError, match="not written by hertzmap"):
        run(z, client)


def test_lock_refuses_a_second_live_client_and_takes_over_a_dead_one(tmp_path, client):
    path = tmp_path / "d.zarr"
    run(path, client)
    lock = lock_path(path)
    import os
    import socket
    lock.write_text(json.dumps({"host": socket.gethostname(), "pid": os.getppid()}))
    with pytest.raises(StoreError, match="in use by another hertzmap client"):
        with Lock(path):
            pass
    lock.write_text(json.dumps({"host": socket.gethostname(), "pid": 2 ** 22 + 12345}))
    with Lock(path):
        assert json.loads(lock.read_text())["pid"] == os.getpid()
    assert not lock.exists()


def test_status_command(tmp_path, client, capsys):
    path = tmp_path / "e.zarr"
    run(path, client)
    info = store_status(path)
    assert info["tasks_done"] == info["tasks_total"] > 1
    assert info["hertzmap_study_name"] == "store-test"
    assert info["hertzmap_study_hash"] == study().hash
    assert info["versions"]["zarr"] == zarr.__version__
    assert main(["status", str(path)]) == 0
    out = capsys.readouterr().out
    assert "store-test" in out and f"{info['tasks_total']}/{info['tasks_total']} done" in out
    assert study().hash in out and "xarray" in out
    assert main(["status", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["tasks_done"] == info["tasks_total"]
    assert main(["status", str(tmp_path / "nope.zarr")]) == 2


def test_error_estimate_and_summary(tmp_path, client):
    summary = run(tmp_path / "f.zarr", client, error_sample=8)
    e = summary["error"]
    assert e["n"] == 8 and e["matched"] == 8 and e["max_deviation"] == 0.0
    assert e["rtol_ref"] == pytest.approx(1e-13)
    assert 0 <= summary["converged_fraction"] <= 1 and summary["orbits"] > 0
    assert math.isfinite(summary["overhead"])


def test_chunks_depend_on_the_study_only():
    s = study()
    assert choose_chunks(s) == choose_chunks(s)
    big = parse_study("[grid]\nomega = {start = 0.5, stop = 2.5, num = 201}\n"
                      "sigma = {start = 0.05, stop = 1.0, num = 77}\nzeta = 0.01\n", default_name="b")
    c = choose_chunks(big)
    assert c[0] == 201 and c[2] == 1
    plan = make_plan(big, c)
    covered = np.zeros(big.shape, int)
    for t in plan.tasks:
        covered[t.slices] += 1
    assert (covered == 1).all()       # tasks tile the grid exactly once


def test_study_layer_imports_neither_dask_nor_the_scheduler():
    import subprocess
    import sys
    from conftest import subprocess_env
    code = ("import sys, study.spec, study.dataset; "
            "bad = [m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed', 'scheduler')]; "
            "print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], env=subprocess_env(), capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr


from hypothesis import given, settings, strategies as hs


@settings(max_examples=40, deadline=None)
@given(n_o=hs.integers(1, 5000), n_s=hs.integers(1, 60), n_z=hs.integers(1, 5),
       task_seconds=hs.floats(0.01, 10))
def test_tasks_tile_any_grid_exactly_once(n_o, n_s, n_z, task_seconds):
    def axis(start, stop, num):
        return f"[{start}]" if num == 1 else f"{{start = {start}, stop = {stop}, num = {num}}}"
    s = parse_study(f"[grid]\nomega = {axis(0.1, 5.0, n_o)}\nsigma = {axis(0.0, 1.0, n_s)}\n"
                    f"zeta = {axis(0.0, 0.5, n_z)}\n", default_name="h")
    chunks = choose_chunks(s, task_seconds)
    assert all(1 <= c <= n for c, n in zip(chunks, s.shape))
    assert chunks[0] == n_o or chunks[0] <= 4096
    plan = make_plan(s, chunks)
    covered = np.zeros(s.shape, np.int8)
    for t in plan.tasks:
        covered[t.slices] += 1
    assert (covered == 1).all()


def test_resume_with_other_solver_code_warns(tmp_path, client, capsys):
    s = study()
    path = tmp_path / "g.zarr"
    store, _ = open_or_create(path, s, choose_chunks(s), overwrite=False, action="t")
    t = make_plan(s, store.chunks).tasks[0]
    so, ss, sz = t.slices
    store.write_block(t.slices, placeholder_solve_block(
        s.axis("omega")[so], s.axis("sigma")[ss], s.axis("zeta")[sz], **s.solver_kwargs()),
        stored_variables(s))
    store.mark_done(t.index)
    store._group.attrs["hertzmap_code_hash"] = "0" * 64
    run(path, client)
    assert "solver code (kernels/, study/) changed" in capsys.readouterr().err
    assert "solver code changed: 000000000000 ->" in xr.open_zarr(path).attrs["history"]


ALL_PRODUCTS_TEXT = TEXT.replace(
    'outputs = ["orbits", "measures", "force_harmonics"]',
    'outputs = ["orbits", "measures", "force_harmonics", "diagnostics", "bifurcations"]')


def _random_block(names, shape, max_solutions, rng, empty):
    """Arrays with the solve_block contract: random values with NaNs, or all fill (``empty``)."""
    out = {}
    for name in names:
        v = VARIABLES[name]
        lead = (1,) + tuple(shape)[1:] if v.per_block else tuple(shape) + (max_solutions,)
        full = lead + ((v.extra_dim[1],) if v.extra_dim else ())
        dtype = np.dtype(v.dtype)
        if empty:
            a = np.full(full, v.fill, dtype=dtype)
        elif dtype.kind == "f":
            a = rng.normal(size=full)
            a[rng.random(full) < 0.2] = np.nan
        elif dtype.kind == "c":
            a = rng.normal(size=full) + 1j * rng.normal(size=full)
            a[rng.random(full) < 0.2] = np.nan
        elif dtype.kind == "b":
            a = rng.random(full) < 0.5
        else:
            a = rng.integers(-1, 3, size=full)
        out[name] = a.astype(dtype)
    return out


def _chunk_bytes(path):
    return {str(p.relative_to(path)): p.read_bytes()
            for p in sorted(path.rglob("*")) if p.is_file() and "/c/" in str(p.relative_to(path))}


def test_block_write_is_byte_identical_to_an_xarray_region_write(tmp_path):
    # oracle: xarray's own region write of block_dataset, the path write_block replaced
    from study.dataset import block_dataset

    s = study(ALL_PRODUCTS_TEXT)
    names = stored_variables(s)
    assert any(VARIABLES[n].per_block for n in names)
    chunks = (5, 2, 1)
    plan = make_plan(s, chunks)
    direct = Store.create(tmp_path / "direct.zarr", s, chunks, "test")
    via_xr = Store.create(tmp_path / "xarray.zarr", s, chunks, "test")
    rng = np.random.default_rng(7)
    for i, task in enumerate(plan.tasks):
        shape = tuple(len(range(*sl.indices(n))) for sl, n in zip(task.slices, s.shape))
        arrays = _random_block(names, shape, s.max_solutions, rng, empty=(i % 3 == 0))
        direct.write_block(task.slices, arrays, names)
        region = {"omega": task.slices[0], "sigma": task.slices[1], "zeta": task.slices[2]}
        ds = block_dataset(arrays, names)
        if "omega_block" in ds.dims:
            ib = task.slices[0].start // chunks[0]
            region["omega_block"] = slice(ib, ib + 1)
        ds.to_zarr(zarr.storage.LocalStore(via_xr.path), region=region, consolidated=False,
                   zarr_format=3, write_empty_chunks=True)
    a, b = _chunk_bytes(direct.path), _chunk_bytes(via_xr.path)
    assert a.keys() == b.keys() and len(a) > 0
    assert [k for k in a if a[k] != b[k]] == []
    # every chunk of every written block exists, all-fill blocks included (verify relies on it)
    assert direct.verify(plan.tasks, names) == {}
    opened = []
    for path in (direct.path, via_xr.path):
        ds = xr.open_zarr(path, consolidated=False)[list(names)]
        ds.attrs = {}       # the stores' own attrs differ (history timestamps)
        opened.append(ds)
    xr.testing.assert_identical(*opened)


def test_error_estimate_finds_orbits_that_only_continuation_reaches(client):
    # The error estimate re-solves each sampled orbit alone at a tight tolerance. Orbits that
    # the block solver reaches only by continuation along omega are missed by a point's own
    # automatic seeds; seeded with the stored start point, every sample is found again.
    from scheduler.run import estimate_error
    from study.block import solve_block

    s = study('[study]\nname = "err"\n[grid]\nomega = {start = 0.5, stop = 2.5, num = 41}\n'
              'sigma = 0.5\nzeta = 0.01\n[solver]\nrtol = 1e-10\n')
    kw = s.solver_kwargs()
    omega = s.axis("omega")
    line = solve_block(omega, s.axis("sigma"), s.axis("zeta"), **kw)
    alone_only, found_alone = [], []
    for i, w in enumerate(omega):
        single = solve_block(np.array([w]), s.axis("sigma"), s.axis("zeta"), **kw)
        for slot in np.flatnonzero(line["status"][i, 0, 0] == 0):
            p, q0, v0 = (line[k][i, 0, 0, slot] for k in ("period", "q0", "v0"))
            ok = (single["status"][0, 0, 0] == 0) & (single["period"][0, 0, 0] == p)
            near = ok.any() and np.min(np.abs(single["q0"][0, 0, 0][ok] - q0)) < 1e-6
            (found_alone if near else alone_only).append(
                (float(w), 0.5, 0.01, int(p), float(q0), float(v0)))
    assert len(alone_only) >= 2, "the line should have orbits that only continuation reaches"
    samples = alone_only[:4] + found_alone[:4]
    e = estimate_error(client, s, samples)
    assert e["n"] == len(samples) and e["matched"] == len(samples)
    assert 0.0 < e["max_deviation"] < 1e-8


def test_attr_updates_keep_the_consolidated_metadata(tmp_path, monkeypatch):
    # A reader opening the store mid-run must never find zarr.json without its consolidated
    # metadata (xarray then falls back to listing the directory, with a warning). So the attrs
    # write itself must keep it: with consolidate_metadata disabled, nothing may be lost.
    import warnings

    s = study()
    store = Store.create(tmp_path / "a.zarr", s, choose_chunks(s), "test")
    monkeypatch.setattr(zarr, "consolidate_metadata", lambda *a, **k: None)
    store.add_history("step one")
    store.set_attrs(hertzmap_error_estimate='{"n": 0}')
    doc = json.loads((store.path / "zarr.json").read_text())
    assert doc.get("consolidated_metadata") is not None
    assert doc["attributes"]["history"].endswith("step one")
    assert doc["attributes"]["hertzmap_error_estimate"] == '{"n": 0}'
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = xr.open_zarr(store.path)
    assert ds.attrs["history"].count("\n") == 1 and set(stored_variables(s)) <= set(ds)


def test_a_store_appears_whole(tmp_path, monkeypatch):
    # built next to its place and renamed into it: while the template is written nothing is at
    # the path; a creation cut short earlier (its building folder) is cleared first
    s = study()
    path = tmp_path / "w.zarr"
    stale = tmp_path / ".w.zarr.creating"
    stale.mkdir()
    (stale / "junk").write_text("left by a creation cut short")
    seen = []
    real = xr.Dataset.to_zarr

    def spy(self, *args, **kwargs):
        seen.append(path.exists())
        return real(self, *args, **kwargs)

    monkeypatch.setattr(xr.Dataset, "to_zarr", spy)
    store = Store.create(path, s, choose_chunks(s), "test")
    assert seen == [False]
    assert path.is_dir() and not stale.exists()
    assert json.loads((path / "zarr.json").read_text()).get("consolidated_metadata") is not None
    assert store.study_hash == s.hash


def test_attr_update_restores_missing_consolidated_metadata(tmp_path):
    # a store whose zarr.json lost its consolidated metadata (written by older code) gets it back
    s = study()
    store = Store.create(tmp_path / "c.zarr", s, choose_chunks(s), "test")
    zarr.open_group(zarr.storage.LocalStore(store.path), mode="r+", zarr_format=3,
                    use_consolidated=False).attrs["probe"] = 1
    assert json.loads((store.path / "zarr.json").read_text()).get("consolidated_metadata") is None
    store.add_history("after")
    doc = json.loads((store.path / "zarr.json").read_text())
    assert doc.get("consolidated_metadata") is not None
    assert doc["attributes"]["probe"] == 1 and doc["attributes"]["history"].endswith("after")
