"""The products a store supports, computed and written: what ``hertzmap plot`` and the library's
``products`` run after a study (study.products computes them from the store's main group; the
store's products groups, scheduler.store.product_groups, hold them)."""
from __future__ import annotations

from pathlib import Path

import xarray as xr

from hertzmap.scheduler.errors import StoreError
from hertzmap.scheduler.store import list_products, read_product, write_products

def make_products(store: Path, which: list[str], *, write: bool = True,
                  ds: xr.Dataset | None = None) -> dict[str, xr.Dataset]:
    """The products of ``hertzmap plot STORE --which ...``: every product the registry
    (study.products.catalog) says the store supports that the figures ``which`` need,
    computed from the store's main group (``ds``: it, opened already) and the products the run
    wrote; written into the store's products/ groups and read back from them unless ``write``
    is False. Returns them with the run's products."""
    from hertzmap.study import plots
    from hertzmap.study import products as P

    if not (Path(store) / "zarr.json").is_file():
        raise StoreError(f"{store} is not a zarr store")
    ds = P.open_store(store) if ds is None else ds
    stored = list_products(store)
    given = {name: read_product(store, name) for name in P.RUN_PRODUCTS if name in stored}
    prods = P.compute_products(ds, wanted=plots.products_for(which), given=given)
    if write:
        write_products(store, prods)
        prods = {name: read_product(store, name) for name in prods}
    return {**given, **prods}
