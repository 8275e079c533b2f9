"""Products: from a study's results to the curves and maps of the paper (and beyond).

Every product is a pure function of the stored Dataset (``xr.open_zarr(store)``, schema in
study/schema.py, or :func:`open_store`, which empties the points not computed) into a small
xarray Dataset, built like an xclim indicator: a numpy/xarray computation first, then the
metadata (``long_name``, ``units``, ``description`` on every variable; CF
``flag_values``/``flag_masks``/``flag_meanings`` on codes). ``hertzmap plot`` writes them into the
study's store as zarr groups ``products/<name>`` (scheduler.store); read them back with
``xr.open_zarr(store, group="products/<name>")``.

One module per topic (docs/products.md has the reference):

* ``results``: :func:`open_store`, :func:`completed`, :func:`contact_threshold`, :func:`rig_of`;
* ``classes``: :func:`orbit_classes`, :func:`valid_orbits` (study.orbits rules over the slots);
* ``maps``: :func:`loss_of_contact_map`, :func:`isola_mask`;
* ``curves``: :func:`bifurcation_curves` (contours of grid indicators), :func:`located_curves`
  (located points linked across sigma lines), :func:`contour_lines`, :func:`curve_segments`;
* ``multiple_scales``: :func:`mms_curves`, :func:`mms_response` (paper Eq. 19-27);
* ``response``: :func:`frequency_response`, :func:`force_harmonics`, :func:`time_histories`;
* ``paper_numbers``: :func:`flip_minimum`, :func:`branch_end` (VALIDATION.md);
* ``attractors``: :func:`stroboscopic_diagram` (the brute-force bifurcation diagram).
* ``traced_curves``: the stored traced curves (``products/traced_curves``, written by
  ``hertzmap run`` for studies with the ``curves`` output): :func:`traced_segments`,
  :func:`failed_traces`, :func:`isola_boundary` (sigma** and where the isola joins the flip).

numpy / xarray / contourpy / scipy.ndimage only: no Dask, no scheduler, no writes.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from hertzmap.kernels.model import TAYLOR_CONTACT_LOSS
from hertzmap.study.products.attractors import stroboscopic_diagram
from hertzmap.study.products.classes import orbit_classes, valid_orbits
from hertzmap.study.products.curves import (CURVES, LOCATED_KINDS, bifurcation_curves, contour_lines,
                                   curve_segments, located_curves)
from hertzmap.study.products.maps import MAP_CLASSES, STABLE_SET_FLAGS, isola_mask, loss_of_contact_map
from hertzmap.study.products.multiple_scales import MMS_HALF_WIDTH, mms_curves, mms_response
from hertzmap.study.products.paper_numbers import branch_end, flip_minimum
from hertzmap.study.products.response import force_harmonics, frequency_response, time_histories
from hertzmap.study.products.traced_curves import (TRACED_VARIABLES, failed_traces, isola_boundary,
                                          traced_segments)
from hertzmap.study.products.results import (completed, contact_threshold, exponent_of, open_store,
                                    rig_of, source_attrs)

__all__ = [
    "STABLE_SET_FLAGS", "CURVES", "LOCATED_KINDS", "MMS_HALF_WIDTH",
    "open_store", "completed", "exponent_of", "contact_threshold", "rig_of",
    "valid_orbits", "orbit_classes", "loss_of_contact_map", "isola_mask",
    "contour_lines", "bifurcation_curves", "located_curves", "curve_segments",
    "mms_curves", "mms_response", "frequency_response", "force_harmonics", "time_histories",
    "flip_minimum", "branch_end", "compute_products", "stroboscopic_diagram", "MAP_CLASSES",
    "TRACED_VARIABLES", "traced_segments", "failed_traces", "isola_boundary",
]


def compute_products(results: str | Path | xr.Dataset, *, max_lines: int = 16
                     ) -> dict[str, xr.Dataset]:
    """Every product that the results support, by name (a pure function: nothing is written).

    Always: ``orbit_classes``, ``loss_of_contact_map``, ``bifurcation_curves`` (empty for line
    studies), ``mms_curves``. When the study has at most ``max_lines`` (sigma, zeta) lines:
    ``frequency_response`` and, per line, ``mms_response``. With ``force_harmonics`` stored:
    ``force_harmonics``. With ``bifurcations`` stored: ``located_bifurcations``. Physical units
    where the study has a ``[rig]`` table.
    """
    ds = open_store(results)
    rig = rig_of(ds)
    out: dict[str, xr.Dataset] = {}
    cls = orbit_classes(ds)
    out["orbit_classes"] = cls.to_dataset().assign_attrs(source_attrs(ds, "orbit classes"))
    lcm = loss_of_contact_map(ds)
    out["loss_of_contact_map"] = lcm
    out["bifurcation_curves"] = bifurcation_curves(lcm)
    if "bifurcation_kind" in ds:
        out["located_bifurcations"] = located_curves(ds)
    om = ds["omega"].values
    lo, hi = float(om.min()), float(om.max())
    # the MMS expansion is about omega = 2: its curves are drawn on |omega - 2| <= 0.25
    a, b = max(lo, 2.0 - MMS_HALF_WIDTH), min(hi, 2.0 + MMS_HALF_WIDTH)
    if a >= b:
        a, b = 2.0 - MMS_HALF_WIDTH, 2.0 + MMS_HALF_WIDTH
    out["mms_curves"] = mms_curves(np.linspace(a, b, 801), ds["zeta"].values)
    if ds.sizes["sigma"] * ds.sizes["zeta"] <= max_lines:
        out["frequency_response"] = frequency_response(ds, rig=rig)
        a, b = max(lo, 2.0 - MMS_HALF_WIDTH), min(hi, 2.0 + MMS_HALF_WIDTH)
        if a < b:
            fine = np.linspace(a, b, 801)
            resp = [mms_response(fine, float(s), float(z)).expand_dims(sigma=[float(s)],
                                                                       zeta=[float(z)])
                    for s in ds["sigma"].values for z in ds["zeta"].values]
            m = xr.combine_by_coords([r.drop_attrs(deep=False) for r in resp])
            m.attrs = {"title": "multiple-scales frequency response (paper Fig. 4, 5)",
                       "taylor_contact_loss": TAYLOR_CONTACT_LOSS}
            out["mms_response"] = m
    if "force_harmonics" in ds:
        out["force_harmonics"] = force_harmonics(ds, rig=rig)
    return out
