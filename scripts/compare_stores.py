"""Are two stores of the same study identical? ``xr.testing.assert_identical`` on the main
group and on every product group both hold (data and attrs), leaving out the attrs that record
when and by which code they were made (history, the error estimate's wall time, the code hash).

    .venv/bin/python scripts/compare_stores.py A.zarr B.zarr
    .venv/bin/python scripts/compare_stores.py --shared A.zarr B.zarr

``--shared``: compare the variables both stores hold and list those only one holds (a change
that adds a stored variable leaves the others to compare).
"""
from __future__ import annotations

import sys
import warnings

import xarray as xr

from hertzmap.scheduler.store import list_products

#: attrs that legitimately differ between two runs of the same study
RUN_ATTRS = ("history", "hertzmap_error_estimate", "hertzmap_code_hash", "hertzmap_versions")


def load(path: str, group: str | None = None) -> xr.Dataset:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = xr.open_zarr(path, group=group, chunks=None).load()
    for a in RUN_ATTRS:
        ds.attrs.pop(a, None)
    return ds


def compare(a: xr.Dataset, b: xr.Dataset, shared: bool, what: str) -> str:
    only = sorted(set(a.data_vars) ^ set(b.data_vars))
    if shared and only:
        keep = [v for v in a.data_vars if v in b.data_vars]
        a, b = a[keep], b[keep]
    xr.testing.assert_identical(a, b)
    extra = f"; only in one: {', '.join(only)}" if shared and only else ""
    return f"{what}: identical ({len(a.data_vars)} variables, {dict(a.sizes)}{extra})"


def main(argv: list[str]) -> int:
    shared = "--shared" in argv
    paths = [p for p in argv if p != "--shared"]
    if len(paths) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    print(compare(*(load(p) for p in paths), shared, "main group"))
    groups = [set(list_products(p)) for p in paths]
    for name in sorted(groups[0] & groups[1]):
        g = f"products/{name}"
        print(compare(*(load(p, g) for p in paths), shared, g))
    for name in sorted(groups[0] ^ groups[1]):
        print(f"products/{name}: only in one store")
    print(f"identical: {paths[0]} and {paths[1]} (attrs except {', '.join(RUN_ATTRS)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
