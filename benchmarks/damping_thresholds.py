"""The subharmonic thresholds as functions of damping (issue 33; VALIDATION.md): the table of
sigma*(zeta), sigma**(zeta) and the isola's join from a store's products/thresholds, the ratio
sigma*/zeta against the multiple-scales 36 / (1 + 16 zeta^2 / 9) (paper Eq. 26-27) and the rig's
measured ~40 at zeta = 0.005, and sigma* against the scipy oracle at two zeta values.

    hertzmap run scenes/damping.toml --workers 2
    .venv/bin/python -m benchmarks.damping_thresholds results/damping.zarr
    .venv/bin/python -m benchmarks.damping_thresholds results/damping.zarr --oracle 0.005 0.02

The run writes products/thresholds (the scene's thresholds output). A store of a study without
that output gets it computed here, in memory, from the store and its traced curves.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import xarray as xr

from benchmarks import oracle
from hertzmap.study import products as P
from hertzmap.study.solve import thresholds as th


def thresholds_of(store: str) -> xr.Dataset:
    try:
        return xr.open_zarr(store, group="products/thresholds").load()
    except (FileNotFoundError, KeyError, OSError, ValueError):
        ds = P.open_store(store)
        traced = xr.open_zarr(store, group="products/traced_curves").load()
        return P.thresholds(ds, traced)


def print_table(t: xr.Dataset) -> None:
    print("| zeta | sigma* | omega* | acc. sigma* | sigma*/zeta | Eq. 26 / zeta | sigma** | "
          "omega** | acc. sigma** | sigma**/zeta | join (omega, sigma) | acc. join |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for k, z in enumerate(t["zeta"].values):
        v = {n: float(t[n].values[k]) for n in t.data_vars if t[n].dims == ("zeta",)}
        print(f"| {z:g} | {v['sigma_star']:.8f} | {v['omega_star']:.6f} | "
              f"{v['sigma_star_accuracy']:.0e} | {v['sigma_star'] / z:.4f} | "
              f"{v['sigma_star_mms'] / z:.4f} | {v['sigma_double_star']:.8f} | "
              f"{v['omega_double_star']:.6f} | {v['sigma_double_star_accuracy']:.0e} | "
              f"{v['sigma_double_star'] / z:.4f} | ({v['omega_join']:.6f}, "
              f"{v['sigma_join']:.8f}) | {v['join_accuracy']:.0e} |")
    for name in ("star", "double_star"):
        z, s = t[f"{name}_zeta"].values, t[f"{name}_sigma"].values
        if z.size:
            print(f"{name}: {z.size} vertices continued in zeta {z.min():g} .. {z.max():g}, "
                  f"steps {np.diff(z).min():.2e} .. {np.diff(z).max():.2e}; "
                  f"ratio sigma/zeta {s[0] / z[0]:.4f} at zeta {z[0]:g}, {s[-1] / z[-1]:.4f} "
                  f"at {z[-1]:g}; ends: {t.attrs.get(f'hertzmap_{name}_ends')}")


def oracle_check(zeta: float) -> None:
    t0 = time.perf_counter()
    low = th.curve_minimum("flip", 1, zeta, th.flip_start(zeta),
                           half_width=th.star_half_width(zeta))
    t1 = time.perf_counter()
    s_mms = 36.0 * zeta
    s_ref, w_ref, _ = oracle.flip_curve_minimum(zeta, (2.0 - zeta, 2.0 + zeta / 2),
                                                (0.9 * s_mms, 1.5 * s_mms), (-12.0 * zeta, 0.0))
    t2 = time.perf_counter()
    print(f"zeta {zeta:g}: sigma* {low.sigma:.10f} (oracle {s_ref:.10f}, difference "
          f"{abs(low.sigma - s_ref):.1e}), omega* {low.omega:.8f} (oracle {w_ref:.8f}, "
          f"difference {abs(low.omega - w_ref):.1e}); hertzmap {t1 - t0:.2f} s "
          f"({low.maps} maps), oracle {t2 - t1:.1f} s")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("store")
    ap.add_argument("--oracle", nargs="*", type=float, default=[], metavar="ZETA")
    a = ap.parse_args(argv)
    print_table(thresholds_of(a.store))
    for z in a.oracle:
        oracle_check(z)


if __name__ == "__main__":
    main()
