"""A study's results as xarray: the stored Dataset with the points not computed emptied, and
what the store says about its model (contact threshold, rig). Products start from here.

Reads only (``xr.open_zarr``); writing into a store is the scheduler's (scheduler.store).
"""
from __future__ import annotations

import contextlib
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from hertzmap.kernels.model import DEFAULT_EXPONENT, DEFAULT_LAW, Model
from hertzmap.study.analytic.rig import Rig
from hertzmap.study.schema import POINT_DIMS, check_format, study_from_attrs
from hertzmap.study.spec import StudyError

@contextlib.contextmanager
def quiet():
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Cc]onsolidated metadata.*")
        warnings.filterwarnings("ignore", message=".*not part in the Zarr format 3.*")
        # a run's staging folders (scheduler.store: .npz files, no zarr metadata)
        warnings.filterwarnings("ignore", message=".*not recognized as a component of a Zarr.*")
        warnings.filterwarnings("ignore", category=RuntimeWarning, message=".*All-NaN.*")
        yield


def completed(ds: xr.Dataset) -> xr.DataArray:
    """Bool (omega, sigma, zeta): the grid points whose block is written (``task_done``)."""
    if "task_done" not in ds:
        return xr.DataArray(np.ones((ds.sizes["omega"], ds.sizes["sigma"], ds.sizes["zeta"]), bool),
                            dims=("omega", "sigma", "zeta"),
                            coords={d: ds[d] for d in ("omega", "sigma", "zeta")})
    c = ds.attrs.get("hertzmap_chunk_shape") or ds["task_done"].attrs.get("chunk_shape")
    td = np.asarray(ds["task_done"].values, bool)
    done = (td.repeat(c[0], 0).repeat(c[1], 1).repeat(c[2], 2)
            [: ds.sizes["omega"], : ds.sizes["sigma"], : ds.sizes["zeta"]])
    return xr.DataArray(done, dims=("omega", "sigma", "zeta"),
                        coords={d: ds[d] for d in ("omega", "sigma", "zeta")})


def open_store(store: str | Path | xr.Dataset, *, load: bool = True) -> xr.Dataset:
    """The main group of a store, in memory (no Dask), with undone blocks emptied.

    Points whose block is not flagged in ``task_done`` get ``status = -1`` (empty) in every
    slot, whatever the chunk files hold; the result has a bool variable ``computed``.
    Axes are sorted (a study may list omega downwards). A store of another layout than this
    version writes is refused (study.schema.StoreFormatError, naming its format and what to
    do), never misread.
    """
    if isinstance(store, xr.Dataset):
        ds = store
        check_format(ds.attrs)
    else:
        with quiet():
            ds = xr.open_zarr(str(store), chunks=None)
        check_format(ds.attrs, str(store))
    if load:
        ds = ds.load()
    done = completed(ds)
    ds = ds.assign(computed=done)
    ds["computed"].attrs = {"long_name": "grid point computed", "units": "1",
                            "description": "True where the point's block is flagged in task_done"}
    if "status" in ds:
        ds["status"] = ds["status"].where(done, -1).astype("int8").assign_attrs(ds["status"].attrs)
    if "bifurcation_kind" in ds and "task_done" in ds:
        # per-block variables (omega_block, sigma, zeta, ...): undone blocks emptied as well
        c = ds.attrs.get("hertzmap_chunk_shape") or ds["task_done"].attrs.get("chunk_shape")
        td = np.asarray(ds["task_done"].values, bool)
        bd = xr.DataArray(td.repeat(c[1], 1).repeat(c[2], 2)[:, : ds.sizes["sigma"],
                                                              : ds.sizes["zeta"]],
                          dims=("omega_block", "sigma", "zeta"))
        ds["bifurcation_kind"] = (ds["bifurcation_kind"].where(bd, 0).astype("int8")
                                  .assign_attrs(ds["bifurcation_kind"].attrs))
        if "bifurcation_count" in ds:
            ds["bifurcation_count"] = (ds["bifurcation_count"].where(bd, -1).astype("int16")
                                       .assign_attrs(ds["bifurcation_count"].attrs))
    return ds.sortby(["omega", "sigma", "zeta"])


def stored_axes(ds: xr.Dataset) -> dict[str, np.ndarray]:
    """The axes omega, sigma, zeta in the order the store's main group holds them (the
    study's order, which :func:`open_store` sorts), read from the study in the attrs ({} when
    they hold none)."""
    try:
        study = study_from_attrs(ds.attrs)
    except StudyError:
        return {}
    return {d: study.axis(d) for d in POINT_DIMS}


def in_stored_order(product: xr.Dataset, axes: dict[str, np.ndarray]) -> xr.Dataset:
    """``product`` with each of its dims omega, sigma, zeta that holds the values of the
    store's axis (``axes``: :func:`stored_axes`) in the store's order: a product group's dims
    align with the main group's (the store opens as one xarray DataTree)."""
    order = {}
    for d, values in axes.items():
        if d in product.indexes:
            have = np.asarray(product.indexes[d])
            if (not np.array_equal(have, values)
                    and np.array_equal(np.sort(have), np.sort(values))):
                order[d] = values
    return product.sel(order) if order else product


def sorted_axes(product: xr.Dataset) -> xr.Dataset:
    """``product`` with its dims omega, sigma, zeta sorted (as :func:`open_store` gives the
    results: what the products are computed from and the figures drawn from)."""
    dims = [d for d in POINT_DIMS if d in product.indexes
            and not product.indexes[d].is_monotonic_increasing]
    return product.sortby(dims) if dims else product


def exponent_of(ds: xr.Dataset) -> float:
    """The contact exponent n of the store (1.5 for the Taylor model, whose threshold differs)."""
    return Model.of(ds.attrs).exponent



def contact_threshold(ds: xr.Dataset) -> float:
    """q at which contact is lost: -n (Hertz, Eq. 7) or kernels.model.TAYLOR_CONTACT_LOSS
    (Taylor, Eq. 12)."""
    return Model.of(ds.attrs).loss_level


def rig_of(ds: xr.Dataset) -> Rig | None:
    """The study's rig (``study.analytic.rig.Rig``) from the store's study file, or None."""
    try:
        study = study_from_attrs(ds.attrs)
    except StudyError:
        return None
    r = study.rig_dict
    if not r:
        return None
    return Rig.hertz(r["E"], r["nu"], r["R"], r["m"], r["N"], contact=r.get("contact", "double"))


def var_attrs(long_name: str, units: str, description: str, **extra) -> dict[str, Any]:
    """The metadata every product variable carries (CF long_name and units, a description)."""
    return {"long_name": long_name, "units": units, "description": description, **extra}


def source_attrs(ds: xr.Dataset, title: str) -> dict[str, Any]:
    """The attrs of a product: its title and the study it was computed from."""
    comp = ds["computed"].values if "computed" in ds else completed(ds).values
    return {
        "title": title,
        "hertzmap_study_name": ds.attrs.get("hertzmap_study_name", ""),
        "hertzmap_study_hash": ds.attrs.get("hertzmap_study_hash", ""),
        "hertzmap_product_source": "main group of the store",
        "hertzmap_points_computed": f"{int(comp.sum())}/{comp.size}",
        "model": ds.attrs.get("model", DEFAULT_LAW),
        "exponent": ds.attrs.get("exponent", DEFAULT_EXPONENT),
    }


def coord_attrs(out: xr.Dataset, ds: xr.Dataset) -> xr.Dataset:
    """Coordinates of ``out`` without attrs get those of ``ds``."""
    for c in out.coords:
        if c in ds.coords and not out[c].attrs:
            out[c].attrs = dict(ds[c].attrs)
    return out

