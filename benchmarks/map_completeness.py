"""What two stores of one scene say the contact does, side by side: orbits by class and period,
points holding a stable orbit of each period, the census's attractors by kind (and why the
unsettled ones are), orbits the slots dropped, orbits the atlas added.

    .venv/bin/python benchmarks/map_completeness.py BEFORE.zarr AFTER.zarr

Counts only (the stores' own variables, nothing recomputed); the costs are the run summaries'.
"""
from __future__ import annotations

import sys
import warnings

import numpy as np
import xarray as xr

from hertzmap.study import products as P
from hertzmap.study.orbits import CLASS_LABELS


def counts(path: str) -> dict[str, int]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = xr.open_zarr(path, chunks=None).load()
    out: dict[str, int] = {"points": int(np.prod([ds.sizes[a] for a in ("omega", "sigma", "zeta")]))}
    ok = P.valid_orbits(ds).values
    cls = P.orbit_classes(ds).values
    for code, label in CLASS_LABELS.items():
        out[f"orbits: {label}"] = int(((cls == code) & ok).sum())
    period = ds["period"].values
    stable = ds["stable"].values & ok
    for m in np.unique(period[ok]):
        out[f"orbits of period {int(m)}"] = int(((period == m) & ok).sum())
        out[f"points with a stable {int(m)}T orbit"] = int(((period == m) & stable).any(-1).sum())
    if "attractor_kind" in ds:
        kind = ds["attractor_kind"].values
        for name, code in (("periodic", 1), ("non_periodic", 2), ("unsettled", 3), ("failed", 4)):
            out[f"points with a {name} attractor"] = int((kind == code).any(-1).sum())
        if "unsettled_reason" in ds:
            reason = ds["unsettled_reason"].values
            for name, code in (("period_limit", 1), ("work_budget", 2)):
                out[f"unsettled points: {name}"] = int(((kind == 3) & (reason == code)).any(-1).sum())
    if "orbits_dropped" in ds:
        out["orbits dropped (slots full)"] = int(np.clip(ds["orbits_dropped"].values, 0, None).sum())
    if "atlas_round" in ds:
        out["orbits added by the atlas"] = int(((ds["atlas_round"].values > 0) & ok).sum())
    return out


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    a, b = counts(argv[0]), counts(argv[1])
    width = max(len(k) for k in a | b)
    print(f"{'':{width}}  {'before':>10}  {'after':>10}")
    for key in list(a) + [k for k in b if k not in a]:
        print(f"{key:{width}}  {a.get(key, '-'):>10}  {b.get(key, '-'):>10}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
