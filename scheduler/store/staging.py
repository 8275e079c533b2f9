"""Staging: the one way a result reaches the store before the client commits it. A worker (or
the client) stages a result as one file ``<folder>/<name>.npz`` of the store, written whole or
not at all (built next to its place, fsynced, renamed into it): a grid block, an atlas round's
tile, a stepped sweep, a swept run, a traced curve. The client, which holds the store's lock,
commits what is staged (packs the grid's blocks into their shards, writes an atlas round,
writes a product) and then removes the files. A run killed at any point keeps what was staged
and resumes the rest; committing again from the same files writes the same values.

Each stage's folder and file names are declared here, once."""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from hertzmap.scheduler.store.layout import STAGE_PAUSE_ENV, block_name, hold_for_test
from hertzmap.scheduler.store.lock import check_writer
from hertzmap.study.schema import PRODUCT_GROUP

#: the grid's staged blocks (scheduler.store.block_writes), at the store's root
GRID_STAGE = "grid_stage"
#: the atlas's staged rounds (one subfolder per round), at the store's root
ATLAS_STAGE = "atlas_stage"
#: the stepped sweeps' staged records, at the store's root
SWEEP_STAGE = "sweeps_stage"
#: the staged swept-sine runs: a subfolder of the stepped sweeps' folder (removed with it;
#: staged_files reads only a folder's own files)
SWEPT_STAGE = f"{SWEEP_STAGE}/swept"
#: the traced curves' committed one-curve parts: CURVE_PARTS under the store's products group
CURVE_PARTS = "traced_curves_parts"
CURVE_STAGE = f"{PRODUCT_GROUP}/{CURVE_PARTS}"


# -- the mechanism ------------------------------------------------------------------------------
def stage_file(store: str | Path, folder: str | Path, name: str,
               arrays: dict[str, np.ndarray] | None) -> Path:
    """Stage arrays as one .npz file ``folder/name.npz`` of the store, written whole or not
    at all (built next to its place, then renamed into it): a grid block, an atlas round's
    tile, a sweep, a traced curve. The caller holds the store's lock, or is a worker of the
    client that holds it."""
    root = Path(store) / folder
    root.mkdir(parents=True, exist_ok=True)
    final = root / f"{name}.npz"
    # the builder's pid in the name: a task run again elsewhere (its worker lost, or slow)
    # never builds into the same file
    building = root / f".{name}.{os.getpid()}.writing.npz"
    with open(building, "wb") as f:
        np.savez(f, **(arrays or {}))
        f.flush()
        os.fsync(f.fileno())
    hold_for_test(STAGE_PAUSE_ENV)
    os.replace(building, final)
    return final


def read_stage_file(store: str | Path, folder: str | Path, name: str) -> dict[str, np.ndarray]:
    """A staged file's arrays ({} when it holds none)."""
    with np.load(Path(store) / folder / f"{name}.npz", allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def staged_names(store: str | Path, folder: str) -> list[str]:
    """The names of the files staged whole so far in ``folder`` (not one being written, not
    its subfolders), sorted."""
    root = Path(store) / folder
    if not root.is_dir():
        return []
    return sorted(p.stem for p in root.iterdir()
                  if p.suffix == ".npz" and not p.name.startswith(".") and p.is_file())


def staged_files(store: str | Path, folder: str) -> dict[str, dict[str, np.ndarray]]:
    """The files staged whole so far in ``folder`` of the store, by name, read."""
    return {name: read_stage_file(store, folder, name) for name in staged_names(store, folder)}


def unstage(store: str | Path, folder: str, name: str) -> None:
    """Remove one staged file (once what it held is committed)."""
    (Path(store) / folder / f"{name}.npz").unlink(missing_ok=True)


def remove_stage(store: str | Path, folder: str) -> None:
    """Remove a folder of staged files (once what they held is committed)."""
    shutil.rmtree(Path(store) / folder, ignore_errors=True)


# -- the atlas's rounds (scheduler.stages.atlas_tasks) -------------------------------------------------
def _round_folder(round_: int) -> str:
    return f"{ATLAS_STAGE}/round_{int(round_):04d}"


def write_atlas_tile(store: str | Path, round_: int, index: tuple[int, int, int],
                     arrays: dict[str, np.ndarray] | None) -> Path:
    """Stage one tile's result of an atlas round (its arrays, or None when the round added
    nothing there): a killed round keeps the tiles staged so far, and the main group is
    written only when the round commits."""
    return stage_file(store, _round_folder(round_), block_name(index), arrays)


def stage_atlas_tile(store: str | Path, owner: dict[str, Any], round_: int,
                     index: tuple[int, int, int], arrays: dict[str, np.ndarray] | None) -> Path:
    """write_atlas_tile by the worker that computed the tile, only while ``owner`` (the
    client's Lock.owner) holds the store (check_writer)."""
    check_writer(store, owner)
    return write_atlas_tile(store, round_, index, arrays)


def staged_atlas_tiles(store: str | Path, round_: int) -> set[tuple[int, int, int]]:
    """The tiles of ``round_`` staged so far."""
    return {tuple(int(i) for i in name.split("-"))
            for name in staged_names(store, _round_folder(round_))}


def read_atlas_tile(store: str | Path, round_: int, index: tuple[int, int, int]
                    ) -> dict[str, np.ndarray]:
    """A staged tile's arrays ({} when the round added nothing there)."""
    return read_stage_file(store, _round_folder(round_), block_name(index))


def remove_atlas_stage(store: str | Path) -> None:
    """Remove every staged round (after its commit)."""
    remove_stage(store, ATLAS_STAGE)


# -- the stepped sweeps and swept runs (scheduler.stages.sweep_tasks) ------------------------------------
def sweep_name(line: int, direction: str) -> str:
    """The staged file's name of a sweep: ``<line>-<direction>``."""
    return f"{int(line):06d}-{direction}"


def stage_sweep(store: str | Path, line: int, direction: str,
                arrays: dict[str, np.ndarray]) -> Path:
    """Stage one finished sweep's arrays (the client, holding the store's lock, commits it)."""
    return stage_file(store, SWEEP_STAGE, sweep_name(line, direction), arrays)


def staged_sweeps(store: str | Path) -> dict[tuple[int, str], dict[str, np.ndarray]]:
    """The sweeps staged so far, by (line, direction)."""
    return {(int(name.partition("-")[0]), name.partition("-")[2]): arrays
            for name, arrays in staged_files(store, SWEEP_STAGE).items()}


def swept_name(line: int, direction: str, rate_index: int) -> str:
    """The staged file's name of a swept run: ``<line>-<direction>-<rate index>``."""
    return f"{int(line):06d}-{direction}-{int(rate_index):03d}"


def stage_swept(store: str | Path, line: int, direction: str, rate_index: int,
                arrays: dict[str, np.ndarray]) -> Path:
    """Stage one finished swept run's arrays (the client, holding the store's lock, commits
    them with the sweeps)."""
    return stage_file(store, SWEPT_STAGE, swept_name(line, direction, rate_index), arrays)


def staged_swept(store: str | Path) -> dict[tuple[int, str, int], dict[str, np.ndarray]]:
    """The swept runs staged so far, by (line, direction, rate index)."""
    out = {}
    for name, arrays in staged_files(store, SWEPT_STAGE).items():
        line, direction, k = name.split("-")
        out[(int(line), direction, int(k))] = arrays
    return out


# -- the traced curves (scheduler.stages.curve_tasks) ----------------------------------------------------
def _json_safe(value):
    """A part's attrs as JSON: numpy arrays and scalars as lists and numbers."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def write_curve_part(store: str | Path, index: int, part: xr.Dataset) -> Path:
    """Stage the traced curve of seed ``index`` (a one-curve products dataset): its arrays, and
    their dims and attrs as JSON (no pickles) in the array ``meta``. A zarr group per part took
    0.2-0.3 s (45 small arrays), a tenth of the default scene's curve stage over its 14 parts;
    this takes milliseconds. The caller holds the store's lock (hertzmap run)."""
    meta = {"attrs": {k: (json.dumps(v) if isinstance(v, (dict, list, tuple)) else _json_safe(v))
                      for k, v in part.attrs.items()},
            "variables": {name: {"dims": list(v.dims), "attrs": _json_safe(dict(v.attrs)),
                                 "coord": name in part.coords}
                          for name, v in part.variables.items()}}
    arrays = {f"v_{i}": np.asarray(v.values) for i, v in enumerate(part.variables.values())}
    return stage_file(store, CURVE_STAGE, f"{int(index):06d}",
                      {"meta": np.array(json.dumps(meta)), **arrays})


def read_curve_parts(store: str | Path) -> dict[int, xr.Dataset]:
    """The staged one-curve parts, by seed index (in memory)."""
    out: dict[int, xr.Dataset] = {}
    for name, z in staged_files(store, CURVE_STAGE).items():
        meta = json.loads(str(z["meta"]))
        data, coords = {}, {}
        for i, (vname, v) in enumerate(meta["variables"].items()):
            var = xr.Variable(tuple(v["dims"]), z[f"v_{i}"], v["attrs"])
            (coords if v["coord"] else data)[vname] = var
        out[int(name)] = xr.Dataset(data, coords=coords, attrs=meta["attrs"])
    return out
