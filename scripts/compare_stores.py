"""Are two stores of the same study identical? ``xr.testing.assert_identical`` on the main
group, data and attrs, leaving out the attrs that record when and by which code they were made
(history, the error estimate's wall time, the code hash).

    .venv/bin/python scripts/compare_stores.py A.zarr B.zarr
"""
from __future__ import annotations

import sys
import warnings

import xarray as xr

#: attrs that legitimately differ between two runs of the same study
RUN_ATTRS = ("history", "hertzmap_error_estimate", "hertzmap_code_hash", "hertzmap_versions")


def load(path: str) -> xr.Dataset:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = xr.open_zarr(path, chunks=None).load()
    for a in RUN_ATTRS:
        ds.attrs.pop(a, None)
    return ds


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    a, b = (load(p) for p in argv)
    xr.testing.assert_identical(a, b)
    print(f"identical: {argv[0]} and {argv[1]} ({len(a.data_vars)} variables, "
          f"{dict(a.sizes)}; attrs except {', '.join(RUN_ATTRS)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
