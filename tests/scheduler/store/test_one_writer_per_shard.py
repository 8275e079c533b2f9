"""One writer per shard, under stress: four workers staging blocks at once, one of them killed
with SIGKILL while it is writing a staged file, then the client (and its cluster) killed with
SIGKILL while it packs a shard (between two of its variables), then a rerun: the store ends
identical, value for value, to an undisturbed run's (the oracle: the same study run with one
worker, nothing killed), and the log of every region write into the main group
($HERTZMAP_SHARD_LOG: writer pid, shards, start and end) shows no shard written by two
processes at overlapping times. The placeholder solver (tests.helpers) keeps it fast; its
extra orbits make some blocks hold more slots than the store's first chunk of them (the slot
dims grow while shards are packed)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.store import GRID_STAGE, SHARD_LOG_ENV, Store
from tests.helpers import PLACEHOLDER, hertzmap_cmd, subprocess_env, wait_until

STUDY = """
[study]
name = "shards"
[grid]
omega = {start = 0.5, stop = 2.5, num = 6}
sigma = {start = 0.1, stop = 1.1, num = 16}
zeta = [0.01, 0.05]
[products]
outputs = ["orbits", "measures"]
"""
#: one task per (sigma, zeta) line: 32 blocks, 8 shards of 4 blocks (layout.MIN_SHARDS)
N_TASKS = 32


def overlapping_writers(lines: list[dict]) -> list[tuple]:
    """The pairs of region writes by different processes into one shard at overlapping times."""
    by_shard: dict[tuple, list] = {}
    for w in lines:
        for shard in w["shards"]:
            by_shard.setdefault(tuple(shard), []).append(w)
    bad = []
    for shard, writes in by_shard.items():
        writes.sort(key=lambda w: w["start"])
        for a, b in zip(writes, writes[1:]):
            if b["start"] < a["end"] and a["pid"] != b["pid"]:
                bad.append((shard, a, b))
    return bad


def test_the_overlap_check_finds_two_writers_of_one_shard():
    """The check below is not vacuous: two processes in one shard at once are found, one after
    the other or in other shards are not."""
    w = [{"pid": 1, "shards": [[0, 0, 0]], "start": 0.0, "end": 1.0},
         {"pid": 2, "shards": [[0, 1, 0], [0, 0, 0]], "start": 0.5, "end": 1.5},
         {"pid": 2, "shards": [[1, 0, 0]], "start": 0.1, "end": 0.2},
         {"pid": 3, "shards": [[1, 0, 0]], "start": 0.2, "end": 0.3}]
    assert [(s, a["pid"], b["pid"]) for s, a, b in overlapping_writers(w)] == [((0, 0, 0), 1, 2)]


def _data(path: Path) -> xr.Dataset:
    ds = xr.open_zarr(path, chunks=None).load()
    ds.attrs = {}
    return ds


def _log(path: Path) -> list[dict]:
    return [json.loads(x) for x in path.read_text().splitlines()] if path.exists() else []


@pytest.mark.slow
def test_workers_and_client_killed_mid_write_then_rerun_identical_one_writer_per_shard(tmp_path):
    study = tmp_path / "shards.toml"
    study.write_text(STUDY)
    args = ["run", str(study), "--solver", PLACEHOLDER, "--task-seconds", "0.001",
            "--error-sample", "0"]
    extra = {"HERTZMAP_PLACEHOLDER_EXTRA": "3"}
    ref = tmp_path / "ref.zarr"
    os.environ.update(extra)
    try:
        assert main(args + ["--store", str(ref)]) == 0          # in-process: one writer
    finally:
        for k in extra:
            del os.environ[k]
    assert Store(ref).done_mask().sum() == N_TASKS
    assert Store(ref).slot_extents()["solution"] == 5

    store, log = tmp_path / "killed.zarr", tmp_path / "shards.log"
    env = subprocess_env(**extra, HERTZMAP_PLACEHOLDER_DELAY="0.02",
                         HERTZMAP_STAGE_PAUSE="0.3", HERTZMAP_PACK_PAUSE="1",
                         **{SHARD_LOG_ENV: str(log)})
    p = subprocess.Popen(hertzmap_cmd(*args, "--store", str(store), "--workers", "4"), env=env,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    try:
        # a worker killed while it writes a staged block (its pid is in the file's name)
        stage = store / GRID_STAGE

        def building():
            if stage.is_dir():
                return [q for q in stage.iterdir() if q.name.endswith(".writing.npz")]
            return []

        wait_until(lambda: building() or p.poll() is not None, 120, "a block being staged")
        victim = building()[0]
        os.kill(int(victim.name.split(".")[2]), signal.SIGKILL)
        # then the client (and its cluster) killed while it commits a shard: its variables
        # written, its flags not set yet (HERTZMAP_PACK_PAUSE holds it there)
        wait_until(lambda: len(_log(log)) >= 2 or p.poll() is not None, 180,
                   "a second shard written")
        os.killpg(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    assert p.returncode == -signal.SIGKILL, "the run ended before the kill"
    flags = Store(store).done_mask()
    assert 0 < flags.sum() < N_TASKS, f"the kill missed the packing ({flags.sum()} done)"
    # the last shard written: in the store, its blocks not flagged (the kill was mid-commit)
    last = _log(log)[-1]["shards"]
    blocks = Store(store).shard_blocks
    assert all(not flags[tuple(i)] for i in np.ndindex(*flags.shape)
               if [a // b for a, b in zip(i, blocks)] in last)
    # the rerun: two workers, no pauses, still logged
    r = subprocess.run(hertzmap_cmd(*args, "--store", str(store), "--workers", "2"),
                       env=subprocess_env(**extra, **{SHARD_LOG_ENV: str(log)}),
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    xr.testing.assert_identical(_data(store), _data(ref))
    assert not (store / GRID_STAGE).exists()
    writes = _log(log)
    assert len({w["pid"] for w in writes}) == 2          # the killed client and the rerun's
    assert overlapping_writers(writes) == []
