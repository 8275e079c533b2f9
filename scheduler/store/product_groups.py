"""The store's products groups (study.schema.PRODUCT_GROUP/<name>): written whole, each under
the store's lock; read back; listed."""
from __future__ import annotations

import json
from pathlib import Path

import xarray as xr

from hertzmap.scheduler.errors import StoreError
from hertzmap.scheduler.store.layout import quiet
from hertzmap.scheduler.store.lock import Lock, lock_path
from hertzmap.scheduler.store.staging import CURVE_STAGE, remove_stage
from hertzmap.study.schema import PRODUCT_GROUP

def write_product(store: str | Path, name: str, product: xr.Dataset, *, lock: bool = True) -> str:
    """Write a product (study.products) into the store as the zarr group
    ``products/<name>`` (replacing it). Returns the group path.

    Only that group is written: the main group's arrays and attrs are untouched (zarr's
    consolidated metadata at the root is refreshed to list the group). Takes the store's lock
    for the write, so it is refused while a ``hertzmap run`` holds it (``lock=False``: the
    caller is that run and holds it already).
    """
    store = Path(store)
    if not (store / "zarr.json").is_file():
        raise StoreError(f"{store} is not a zarr store")
    if not name or "/" in name or name.startswith("."):
        raise ValueError(f"invalid product name {name!r}")
    group = f"{PRODUCT_GROUP}/{name}"
    product = product.copy()
    product.attrs = {k: (json.dumps(v) if isinstance(v, (dict, list)) else v)
                     for k, v in product.attrs.items()}
    for v in product.variables.values():
        v.encoding = {}
    held = Lock(store)
    if lock:
        try:
            held.acquire()
        except StoreError:
            raise StoreError(f"{store} is locked by a running hertzmap run ({lock_path(store)}); "
                             "write products when it has finished") from None
    try:
        with quiet():
            product.to_zarr(str(store), group=group, mode="w", consolidated=True)
    finally:
        held.release()
    return group


def write_products(store: str | Path, products: dict[str, xr.Dataset]) -> list[str]:
    """write_product for each product; returns the group paths."""
    return [write_product(store, name, prod) for name, prod in products.items()]


def read_product(store: str | Path, name: str) -> xr.Dataset:
    """A stored product, in memory."""
    with quiet():
        return xr.open_zarr(str(store), group=f"{PRODUCT_GROUP}/{name}", chunks=None).load()


def list_products(store: str | Path) -> list[str]:
    """Names of the products stored in a store."""
    root = Path(store) / PRODUCT_GROUP
    if not root.is_dir():
        return []
    return sorted(p.name for p in root.iterdir() if (p / "zarr.json").is_file())


def has_run_product(store: str | Path, name: str, study_hash: str) -> bool:
    """True when the store holds the product ``name`` that a stage of a run of this study
    wrote whole (products/traced_curves, products/thresholds)."""
    meta = Path(store) / PRODUCT_GROUP / name / "zarr.json"
    if not meta.is_file():
        return False
    try:
        attrs = json.loads(meta.read_text()).get("attributes", {})
    except (OSError, ValueError):
        return False
    return attrs.get("hertzmap_study_hash") == study_hash


TRACED_CURVES = "traced_curves"


def finish_traced_curves(store: str | Path, product: xr.Dataset) -> str:
    """Write the combined product ``products/traced_curves`` (the caller, hertzmap run, holds
    the store's lock), then remove the parts it was combined from."""
    group = write_product(store, TRACED_CURVES, product, lock=False)
    remove_stage(store, CURVE_STAGE)
    return group
