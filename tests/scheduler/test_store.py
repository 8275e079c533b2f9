"""scheduler.store: region writes of blocks and their flags, resume, refusal of another study
and of paths that are not stores, the lock, consolidated metadata, products written into
their groups without touching the main group."""
from __future__ import annotations

import json
import socket

import numpy as np
import pytest
import xarray as xr
import zarr

from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.stages.plan import choose_chunks, make_plan
from hertzmap.scheduler.store import (Lock, Store, StoreError, list_products, lock_path, open_or_create,
                             read_product, write_product, write_products)
from hertzmap.study import products as P
from hertzmap.study.schema import (SLOT_CHUNK, VARIABLES, chunked_length, slot_counts,
                                   stored_variables)
from hertzmap.study.schema import PRODUCT_GROUP
from tests.helpers import (ALL_OUTPUTS_STUDY, STORE_TEST_STUDY, placeholder_run, placeholder_study,
                           write_results)
from tests.helpers import placeholder_solve_block


def _random_block(names, shape, rng, empty, slots=None):
    """Arrays with the solve_block contract: random values with NaNs, or all fill (``empty``);
    ``slots``: the lengths of the slot dims (default one chunk each)."""
    out = {}
    for name in names:
        v = VARIABLES[name]
        full = v.block_shape(tuple(shape), slots)
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


def test_run_writes_every_block_and_flags(tmp_path, client):
    path = tmp_path / "a.zarr"
    summary = placeholder_run(path, client)
    assert summary["complete"] and summary["tasks_run"] == summary["tasks_total"]
    ds = xr.open_zarr(path)           # opens silently: consolidated metadata
    assert bool(ds.task_done.all())
    s = placeholder_study()
    ref = placeholder_solve_block(s.axis("omega"), s.axis("sigma"), s.axis("zeta"), **s.solver_kwargs())
    # the slot dims cut to the most any point holds at the end of the run: 1T and 2T orbits,
    # no attractor (the placeholder's census finds none)
    assert (ds.sizes["solution"], ds.sizes["attractor"]) == (2, 1)
    for name in stored_variables(s):
        want = ref[name]
        dim = VARIABLES[name].slot_dim
        if dim is not None:
            n = ds.sizes[dim]
            assert (want[:, :, :, n:] == VARIABLES[name].fill).all() or np.isnan(
                want[:, :, :, n:]).all(), name
            want = want[:, :, :, :n]
        np.testing.assert_array_equal(ds[name].values, want, err_msg=name)
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
    placeholder_run(ref, client)
    s = placeholder_study()
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
    summary = placeholder_run(path, client)
    assert summary["tasks_done_before"] == 2
    assert summary["tasks_run"] == len(plan.tasks) - 2
    a, b = xr.open_zarr(path).load(), xr.open_zarr(ref).load()
    a.attrs, b.attrs = {}, {}
    xr.testing.assert_identical(a, b)
    # and a third run does nothing
    again = placeholder_run(path, client)
    assert again["tasks_run"] == 0 and again["complete"]


def test_another_study_is_refused_unless_overwrite(tmp_path, client, capsys):
    path = tmp_path / "c.zarr"
    placeholder_run(path, client)
    other = STORE_TEST_STUDY.replace("zeta = [0.01, 0.1]", "zeta = [0.02]")
    before = sorted(p.name for p in path.rglob("*"))
    with pytest.raises(StoreError, match="another study"):
        placeholder_run(path, client, text=other)
    assert sorted(p.name for p in path.rglob("*")) == before
    # through the CLI: exit code 2, nothing changed
    f = tmp_path / "other.toml"
    f.write_text(other)
    assert main(["run", str(f), "--store", str(path), "--workers", "1"]) == 2
    assert "another study" in capsys.readouterr().err
    assert xr.open_zarr(path).attrs["hertzmap_study_hash"] == placeholder_study().hash
    summary = placeholder_run(path, client, text=other, overwrite=True)
    assert summary["complete"]
    assert xr.open_zarr(path).attrs["hertzmap_study_hash"] == placeholder_study(other).hash
    assert xr.open_zarr(path).sizes["zeta"] == 1


def test_non_store_paths_are_never_touched(tmp_path, client):
    d = tmp_path / "notastore"
    d.mkdir()
    (d / "precious.txt").write_text("keep me")
    with pytest.raises(StoreError, match="not a zarr store"):
        placeholder_run(d, client, overwrite=True)
    assert (d / "precious.txt").read_text() == "keep me"
    # a foreign zarr store: refused without --overwrite
    z = tmp_path / "foreign.zarr"
    zarr.open_group(zarr.storage.LocalStore(z), mode="w", zarr_format=3)
    with pytest.raises(StoreError, match="not written by hertzmap"):
        placeholder_run(z, client)


def test_lock_refuses_a_second_live_client_and_takes_over_a_dead_one(tmp_path, client):
    path = tmp_path / "d.zarr"
    placeholder_run(path, client)
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


def _chunk_files(path):
    return sorted((str(f.relative_to(path)), f.stat().st_mtime_ns, f.read_bytes())
                  for f in path.rglob("*") if f.is_file() and "/c/" in str(f))


def test_a_worker_stages_only_for_the_client_that_holds_the_store(tmp_path):
    """stage_task_block (what run_task calls) stages its block while the client that sent the
    task holds the lock; for a client that has ended, or when another client holds the store
    now (a worker of a dead client finishing late), it refuses and stages nothing. The client
    packs the staged block into its shard: what the solver gave."""
    from hertzmap.scheduler.store import GRID_STAGE, pack_shard, stage_task_block
    from hertzmap.scheduler.store.layout import shard_of

    s = placeholder_study()
    path = tmp_path / "w.zarr"
    store, _ = open_or_create(path, s, choose_chunks(s), overwrite=False, action="t")
    plan = make_plan(s, store.chunks)
    t0, t1 = plan.tasks[:2]
    names = stored_variables(s)

    def block(t):
        so, ss, sz = t.slices
        return placeholder_solve_block(s.axis("omega")[so], s.axis("sigma")[ss],
                                       s.axis("zeta")[sz], **s.solver_kwargs())

    with Lock(path) as first:
        stage_task_block(str(path), first.owner, t0.index, block(t0))
    staged = sorted(p.name for p in (path / GRID_STAGE).iterdir())
    assert staged == ["-".join(map(str, t0.index)) + ".npz"]
    before = _chunk_files(path)
    with pytest.raises(StoreError, match="not locked by the client that sent this task"):
        stage_task_block(str(path), first.owner, t1.index, block(t1))
    with Lock(path) as second:
        assert second.owner["pid"] == first.owner["pid"]        # same process, a later lock
        with pytest.raises(StoreError, match="held by another client"):
            stage_task_block(str(path), first.owner, t1.index, block(t1))
    assert sorted(p.name for p in (path / GRID_STAGE).iterdir()) == staged
    assert _chunk_files(path) == before                          # nothing written by them
    # the client packs the shard once all its blocks are staged (here: all by hand)
    with Lock(path) as lock:
        for t in plan.tasks[1:]:
            stage_task_block(str(path), lock.owner, t.index, block(t))
        shards = {shard_of(t.index, store.shard_blocks) for t in plan.tasks}
        for shard in sorted(shards):
            assert pack_shard(store, shard, plan.counts, names)
    assert not any((path / GRID_STAGE).iterdir())
    ds = xr.open_zarr(path).isel(omega=t0.slices[0], sigma=t0.slices[1], zeta=t0.slices[2])
    np.testing.assert_array_equal(ds.q0.values, block(t0)["q0"])


def test_a_worker_that_does_not_see_the_store_says_it_needs_a_shared_file_system(tmp_path):
    from hertzmap.scheduler.store import check_writer

    owner = {"host": socket.gethostname(), "pid": 1, "token": "0" * 32}
    with pytest.raises(StoreError, match="must be on a file system that the workers share"):
        check_writer(tmp_path / "elsewhere.zarr", owner)
    assert not (tmp_path / "elsewhere.zarr").exists()


def test_workers_that_cannot_write_the_store_stop_the_run_before_any_task(tmp_path, client):
    """With --scheduler or --cluster the connected workers are asked first: here the lock
    they find is not the run's (what a worker sees when the path it has is another file
    system's), so the run stops with the reason, no task submitted, nothing flagged, and a
    rerun resumes."""
    import io

    from hertzmap.scheduler.cluster.clusters import ClusterSpec
    from hertzmap.scheduler.run import RunOptions, StudyRun
    from tests.helpers import PLACEHOLDER

    s = placeholder_study()
    path = tmp_path / "n.zarr"
    store, _ = open_or_create(path, s, choose_chunks(s), overwrite=False, action="t")
    opts = RunOptions(store=path, solver=PLACEHOLDER, cluster=ClusterSpec(kind="address"),
                      error_sample=0)
    out, err = io.StringIO(), io.StringIO()
    before = _chunk_files(path)
    with Lock(path):
        elsewhere = {"host": "another-node", "pid": 1, "token": "0" * 32}
        summary = StudyRun(s, opts, store, out, err, owner=elsewhere).run(False, client)
    assert not summary["complete"] and summary["failed"][0][0] == "shared file system"
    assert "cannot write the store" in err.getvalue() and "held by another client" in err.getvalue()
    assert "running" not in out.getvalue()
    assert _chunk_files(path) == before            # no block written, no flag set
    assert placeholder_run(path, client)["complete"]


def test_resume_with_other_solver_code_warns(tmp_path, client, capsys):
    s = placeholder_study()
    path = tmp_path / "g.zarr"
    store, _ = open_or_create(path, s, choose_chunks(s), overwrite=False, action="t")
    t = make_plan(s, store.chunks).tasks[0]
    so, ss, sz = t.slices
    store.write_block(t.slices, placeholder_solve_block(
        s.axis("omega")[so], s.axis("sigma")[ss], s.axis("zeta")[sz], **s.solver_kwargs()),
        stored_variables(s))
    store.mark_done(t.index)
    store._group.attrs["hertzmap_code_hash"] = "0" * 64
    placeholder_run(path, client)
    assert "solver code (kernels/, study/) changed" in capsys.readouterr().err
    assert "solver code changed: 000000000000 ->" in xr.open_zarr(path).attrs["history"]


def test_block_write_is_byte_identical_to_an_xarray_region_write(tmp_path):
    # oracle: xarray's own region write of block_dataset, the path write_block replaced
    from hertzmap.study.schema import block_dataset

    s = placeholder_study(ALL_OUTPUTS_STUDY)
    names = stored_variables(s)
    assert any(VARIABLES[n].per_block for n in names)
    # 2 x 2 x 2 blocks of the 17 x 5 x 2 grid: edge blocks shorter along omega and sigma,
    # three of them empty
    chunks = (9, 3, 1)
    plan = make_plan(s, chunks)
    assert len(plan.tasks) == 8
    direct = Store.create(tmp_path / "direct.zarr", s, chunks, "test")
    via_xr = Store.create(tmp_path / "xarray.zarr", s, chunks, "test")
    rng = np.random.default_rng(7)
    for i, task in enumerate(plan.tasks):
        shape = tuple(len(range(*sl.indices(n))) for sl, n in zip(task.slices, s.shape))
        arrays = _random_block(names, shape, rng, empty=(i % 3 == 0))
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


def _filled(names, shape, counts, rng):
    """A block whose point p holds counts[p] orbits (status 0, slots filled from 0) and one
    attractor, the rest of its slots empty; the slot dims in whole chunks."""
    slots = slot_counts(chunked_length(max(counts)), SLOT_CHUNK)
    a = _random_block(names, shape, rng, empty=False, slots=slots)
    n = np.asarray(counts).reshape(shape)
    used = np.arange(slots["solution"]) < n[..., None]
    for name in names:
        v = VARIABLES[name]
        if v.slot_dim == "solution":
            keep = used.reshape(used.shape + (1,) * (a[name].ndim - 4))
            a[name] = np.where(keep, a[name], np.array(v.fill, a[name].dtype))
    a["status"][used] = 0
    if "attractor_kind" in a:
        a["attractor_kind"][...] = 0
        a["attractor_kind"][..., 0] = 1
    return a


def test_a_block_holding_more_slots_grows_the_store_and_reads_back_whole(tmp_path):
    """Store.write_block (the client's) grows the slot dims by whole chunks when a block holds
    more than they have room for; every variable and the coordinate grow together, the
    consolidated metadata says so (xarray opens one Dataset), the other blocks read as before;
    settle_slots cuts the dims to the most any point holds."""
    s = placeholder_study(ALL_OUTPUTS_STUDY)
    names = stored_variables(s)
    chunks = (9, 5, 2)
    plan = make_plan(s, chunks)
    store = Store.create(tmp_path / "a.zarr", s, chunks, "test")
    rng = np.random.default_rng(3)
    shapes = [tuple(len(range(*sl.indices(n))) for sl, n in zip(t.slices, s.shape))
              for t in plan.tasks]
    small = _filled(names, shapes[0], [2] * int(np.prod(shapes[0])), rng)
    counts = [3] * int(np.prod(shapes[1]))
    counts[4] = 11                                  # one point holds 11 orbits
    big = _filled(names, shapes[1], counts, rng)
    store.write_block(plan.tasks[0].slices, small, names)
    assert store.slot_extents() == {"solution": 4, "attractor": 4}
    store.write_block(plan.tasks[1].slices, big, names)
    assert store.slot_extents() == {"solution": 12, "attractor": 4}
    assert store.slots_used() == {"solution": 11, "attractor": 1}
    ds = xr.open_zarr(store.path).load()           # consolidated: one consistent Dataset
    assert ds.sizes["solution"] == 12 and ds.solution.values.tolist() == list(range(12))
    got = ds["q0"].values[plan.tasks[1].slices]
    np.testing.assert_array_equal(got, big["q0"])
    np.testing.assert_array_equal(ds["q0"].values[plan.tasks[0].slices][..., :4], small["q0"])
    assert np.isnan(ds["q0"].values[plan.tasks[0].slices][..., 4:]).all()
    assert store.settle_slots() == {"solution": 11, "attractor": 1}
    ds = xr.open_zarr(store.path).load()
    assert ds.sizes["solution"] == 11 and ds.sizes["attractor"] == 1
    np.testing.assert_array_equal(ds["q0"].values[plan.tasks[1].slices], big["q0"][..., :11])


def test_the_client_packs_a_block_the_store_has_no_room_for(tmp_path):
    """A worker never resizes the store: it stages its block, whatever it holds; packing a
    block holding more slots than the store has grows the dims first (the client's alone). A
    later region write of fewer slots removes the block's second chunk of slots."""
    from hertzmap.scheduler.store import GRID_STAGE, pack_shard, stage_task_block

    s = placeholder_study()
    names = stored_variables(s)
    chunks = (17, 5, 2)
    plan = make_plan(s, chunks)
    task = plan.tasks[0]
    assert len(plan.tasks) == 1
    rng = np.random.default_rng(4)
    with Lock(tmp_path / "a.zarr") as lock:
        store = Store.create(tmp_path / "a.zarr", s, chunks, "test")
        block = _filled(names, s.shape, [5] * s.size, rng)
        stage_task_block(store.path, lock.owner, task.index, block)
        staged = list((store.path / GRID_STAGE).glob("*.npz"))
        assert len(staged) == 1 and store.slot_extents()["solution"] == 4
        assert pack_shard(store, (0, 0, 0), plan.counts, names) == [task.index]
        assert not any((store.path / GRID_STAGE).glob("*.npz"))
        assert store.slot_extents()["solution"] == 8 and store.done_mask().all()
        fits = _filled(names, s.shape, [2] * s.size, rng)
        store.write_block(task.slices, fits, names)
    ds = xr.open_zarr(store.path).load()
    np.testing.assert_array_equal(ds["q0"].values[..., :4], fits["q0"])
    # the block's second chunk of slots, stored by the first write, is gone with the second
    assert np.isnan(ds["q0"].values[..., 4:]).all()
    assert not (store.path / "q0" / "c" / "0" / "0" / "0" / "1").exists()


def test_a_resize_cut_short_is_made_whole(tmp_path):
    """A kill between two arrays' resizes leaves the slot dim of different lengths: the next
    run's settle_slots(slot_extents()) makes every array and the coordinate as long as the
    longest (nothing stored is cut), and xarray opens the store again."""
    s = placeholder_study()
    store = Store.create(tmp_path / "a.zarr", s, choose_chunks(s), "test")
    arr = zarr.open_group(zarr.storage.LocalStore(store.path), mode="r+")["q0"]
    arr.resize(arr.shape[:3] + (8,))
    assert store.slot_extents()["solution"] == 8
    assert store.settle_slots(store.slot_extents())["solution"] == 8
    ds = xr.open_zarr(store.path)
    assert ds.sizes["solution"] == 8 and ds.period.shape[-1] == 8


def test_attr_updates_keep_the_consolidated_metadata(tmp_path, monkeypatch):
    # A reader opening the store mid-run must never find zarr.json without its consolidated
    # metadata (xarray then falls back to listing the directory, with a warning). So the attrs
    # write itself must keep it: with consolidate_metadata disabled, nothing may be lost.
    import warnings

    s = placeholder_study()
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
    s = placeholder_study()
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
    s = placeholder_study()
    store = Store.create(tmp_path / "c.zarr", s, choose_chunks(s), "test")
    zarr.open_group(zarr.storage.LocalStore(store.path), mode="r+", zarr_format=3,
                    use_consolidated=False).attrs["probe"] = 1
    assert json.loads((store.path / "zarr.json").read_text()).get("consolidated_metadata") is None
    store.add_history("after")
    doc = json.loads((store.path / "zarr.json").read_text())
    assert doc.get("consolidated_metadata") is not None
    assert doc["attributes"]["probe"] == 1 and doc["attributes"]["history"].endswith("after")


def _digest(path) -> dict[str, str]:
    """sha256 of every file of the store outside its products/ groups and root metadata."""
    import hashlib

    out = {}
    for p in sorted(path.rglob("*")):
        rel = p.relative_to(path).as_posix()
        if p.is_file() and not rel.startswith(PRODUCT_GROUP) and rel != "zarr.json":
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def test_products_round_trip_and_leave_the_main_group_alone(hand, tmp_path):
    store = write_results(hand, tmp_path / "s.zarr")
    before = _digest(store)
    attrs_before = xr.open_zarr(store, chunks=None).attrs
    prods = P.compute_products(store)
    assert {"orbit_classes", "loss_of_contact_map", "bifurcation_curves", "mms_curves",
            "frequency_response"} <= set(prods)
    write_products(store, prods)
    assert set(list_products(store)) == set(prods)
    for name, prod in prods.items():
        back = read_product(store, name)
        xr.testing.assert_identical(back.drop_attrs(), prod.drop_attrs())
        assert back.attrs["title"]
    with xr.open_zarr(store, group="products/loss_of_contact_map", chunks=None) as g:
        assert "stable_set" in g and g["stable_set"].attrs["flag_meanings"]
    assert _digest(store) == before
    main = xr.open_zarr(store, chunks=None)
    assert main.attrs == attrs_before
    assert "products" not in main.variables
    # rewriting replaces the group
    write_product(store, "mms_curves", prods["mms_curves"].isel(mms_omega=slice(0, 5)))
    assert read_product(store, "mms_curves").sizes["mms_omega"] == 5
    # refused while a live run holds the lock (this process's pid: alive)
    with Lock(store):
        with pytest.raises(StoreError, match="locked"):
            write_product(store, "x", prods["mms_curves"])
    assert "x" not in list_products(store)
    # a dead client's lock is taken over
    lock_path(store).write_text(json.dumps({"host": socket.gethostname(), "pid": 2 ** 22 + 7}))
    write_product(store, "x", prods["mms_curves"])
    assert not lock_path(store).exists()
