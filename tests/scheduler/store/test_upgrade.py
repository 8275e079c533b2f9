"""``hertzmap upgrade``: a real store of format 2 (tests/data/store_format2.zip, written by
hertzmap before the sharded store, from tests/data/store_format2.toml) is refused by a run
with its format and the command that rewrites it, and rewritten in place by that command:
every value, attr and product group as the old store held them (read before the upgrade, by
xarray, the oracle), every array sharded, nothing recomputed, and a run of its study then finds
nothing to do."""
from __future__ import annotations

import warnings
import zipfile
from pathlib import Path

import pytest
import xarray as xr
import zarr

from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.store import list_products
from hertzmap.study.schema import STORE_FORMAT

DATA = Path(__file__).resolve().parents[2] / "data"
#: attrs the upgrade changes on purpose
CHANGED = ("hertzmap_store_format", "hertzmap_shard_blocks", "history")


def _load(path, group=None) -> xr.Dataset:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return xr.open_zarr(path, group=group, chunks=None).load()


def _files(path: Path) -> list[tuple[str, int]]:
    return sorted((str(p), p.stat().st_mtime_ns) for p in path.rglob("*") if p.is_file())


@pytest.fixture
def old_store(tmp_path) -> Path:
    with zipfile.ZipFile(DATA / "store_format2.zip") as z:
        z.extractall(tmp_path)
    return tmp_path / "format2.zarr"


def test_a_format_2_store_is_refused_with_the_command_that_rewrites_it(old_store, tmp_path,
                                                                       capsys):
    before = _files(old_store)
    args = ["run", str(DATA / "store_format2.toml"), "--store", str(old_store), "--workers", "1"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "store format 2" in err and "hertzmap upgrade STORE" in err and "Traceback" not in err
    assert _files(old_store) == before


def test_upgrade_rewrites_a_format_2_store_in_place_value_for_value(old_store, capsys):
    main_before = _load(old_store)
    products = list_products(old_store)
    products_before = {n: _load(old_store, f"products/{n}") for n in products}
    n_before = len([p for p in old_store.rglob("*") if p.is_file()])

    assert main(["upgrade", str(old_store)]) == 0
    assert "store format 2 -> " in capsys.readouterr().out
    after = _load(old_store)
    assert after.attrs["hertzmap_store_format"] == STORE_FORMAT
    assert "hertzmap upgrade: format 2" in after.attrs["history"]
    for ds in (main_before, after):
        for a in CHANGED:
            ds.attrs.pop(a, None)
    xr.testing.assert_identical(after, main_before)
    assert list_products(old_store) == products
    for n, ds in products_before.items():
        xr.testing.assert_identical(_load(old_store, f"products/{n}"), ds)
    # every array of the main group sharded (the fixture's 3 blocks make a shard each: no
    # fewer files here; benchmarks/store_layout.py counts them at scale)
    group = zarr.open_group(str(old_store), mode="r")
    assert all(group[n].shards is not None for n in main_before.data_vars)
    assert len([p for p in old_store.rglob("*") if p.is_file()]) <= n_before
    assert not any(p.name.startswith(".") for p in old_store.parent.iterdir())
    # a sound store of this format: status --check finds nothing damaged, a run of its study
    # has nothing to compute, a second upgrade nothing to do
    assert main(["status", str(old_store), "--check"]) == 0
    capsys.readouterr()
    before = _files(old_store)
    assert main(["upgrade", str(old_store)]) == 0
    assert "nothing to do" in capsys.readouterr().out
    assert _files(old_store) == before
    args = ["run", str(DATA / "store_format2.toml"), "--store", str(old_store), "--workers", "1"]
    assert main(args) == 0
    rerun = _load(old_store)
    for a in CHANGED:
        rerun.attrs.pop(a, None)
    xr.testing.assert_identical(rerun, main_before)
