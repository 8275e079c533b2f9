"""The class of every stored orbit (study.orbit_rules classes: paper Fig. 6 I-V, extended), and the
slots that hold distinct converged orbits (study.orbit_rules identity rule)."""
from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from hertzmap.study.orbit_rules import ORBIT_CLASSES, class_codes, first_of_duplicates
from hertzmap.study.products.results import var_attrs


def class_flag_attrs() -> dict[str, Any]:
    return {"flag_values": np.array([c for c, _, _ in ORBIT_CLASSES], np.int8),
            "flag_meanings": " ".join(n for _, n, _ in ORBIT_CLASSES)}


def valid_orbits(ds: xr.Dataset) -> xr.DataArray:
    """Bool (omega, sigma, zeta, solution): converged slots that hold distinct orbits.

    A slot that is the same orbit as a converged slot before it (study.orbit_rules identity rule:
    period, min q, max q and tr M) is left out; products count and classify valid orbits only.
    """
    ds = ds.transpose("omega", "sigma", "zeta", "solution", ...)
    ok = (ds["status"] == 0).values
    if "min_q" not in ds or ok.shape[-1] < 2:
        return xr.DataArray(ok, dims=ds["status"].dims, coords=ds["status"].coords)
    trace = ds["multipliers"].sum("multiplier").real.values
    keep = first_of_duplicates(ok, ds["period"].values, ds["min_q"].values,
                               ds["max_q"].values, trace)
    return xr.DataArray(keep, dims=ds["status"].dims, coords=ds["status"].coords)


def orbit_classes(ds: xr.Dataset) -> xr.DataArray:
    """Class of every slot (omega, sigma, zeta, solution), int8 codes of study.orbit_rules.ORBIT_CLASSES.

    Needs ``loses_contact`` (the ``measures`` output); without it contact loss is read as False.
    Duplicated slots (see :func:`valid_orbits`) get class 0.
    """
    loses = ds["loses_contact"] if "loses_contact" in ds else xr.zeros_like(ds["stable"])
    code = class_codes(valid_orbits(ds).values, ds["period"].values, ds["stable"].values,
                       loses.values)
    da = xr.DataArray(code, dims=ds["status"].dims, coords=ds["status"].coords, name="orbit_class")
    da.attrs = var_attrs("orbit class", "1",
                      "class of the orbit in the slot; 1-5 are the classes I-V of paper Fig. 6; "
                      + "; ".join(f"{c}: {d}" for c, _, d in ORBIT_CLASSES),
                      **class_flag_attrs())
    return da
