"""Products: from a study's results to the curves and maps of the paper (and beyond).

Every product is a pure function of the stored Dataset (``xr.open_zarr(store)``, schema in
study/schema.py, or :func:`open_store`, which empties the points not computed) into a small
xarray Dataset, built like an xclim indicator: a numpy/xarray computation first, then the
metadata (``long_name``, ``units``, ``description`` on every variable; CF
``flag_values``/``flag_masks``/``flag_meanings`` on codes). ``hertzmap plot`` writes them into the
study's store as zarr groups ``products/<name>`` (scheduler.store); read them back with
``xr.open_zarr(store, group="products/<name>")``. Which products exist, when the results support
each, what each takes and which figures draw from it is declared once, in ``catalog``
(:data:`PRODUCTS`); :func:`compute_products` computes every product the results support.

One module per topic (docs/products.md has the reference):

* ``results``: :func:`open_store`, :func:`completed`, :func:`contact_threshold`, :func:`rig_of`;
* ``classes``: :func:`orbit_classes`, :func:`valid_orbits` (study.orbit_rules rules over the slots);
* ``maps``: :func:`loss_of_contact_map`, :func:`isola_mask`;
* ``curves``: :func:`bifurcation_curves` (contours of grid indicators), :func:`located_curves`
  (located points linked across sigma lines), :func:`contour_lines`, :func:`curve_segments`;
* ``multiple_scales``: :func:`mms_curves`, :func:`mms_response` (paper Eq. 19-27);
* ``response``: :func:`frequency_response`, :func:`force_harmonics`, :func:`time_histories`;
* ``paper_numbers``: :func:`flip_minimum`, :func:`branch_end` (VALIDATION.md);
* ``attractors``: :func:`stroboscopic_diagram` (the brute-force bifurcation diagram of a line),
  :func:`stroboscopic_diagrams` (a few lines: the product), :func:`diagram_line`;
* ``traced_curves``: the stored traced curves (``products/traced_curves``, written by
  ``hertzmap run`` for studies with the ``curves`` output): :func:`traced_segments`,
  :func:`failed_traces`, :func:`isola_boundary` (sigma** and where the isola joins the flip);
* ``damping``: :func:`thresholds` (sigma*, sigma** and the isola's join at each zeta, and
  continued in zeta: study.solve.thresholds), :func:`impact_onset` (where vibro-impacts
  start, over (omega, zeta));
* ``stepped_sweeps``: the ``sweeps`` product (stepped-sine sweeps up and down each line with
  their jumps, written by ``hertzmap run`` for studies with the ``sweeps`` output):
  :func:`sweeps_dataset`, :func:`stepped_sweeps` (the same in one process), :func:`sweep_line`,
  :func:`jumps_of`;
* ``catalog``: the registry (:class:`Product`, :data:`PRODUCTS`), :func:`compute_products`.

numpy / xarray / contourpy / scipy.ndimage only: no Dask, no scheduler, no writes.
"""
from __future__ import annotations

from hertzmap.study.products.stroboscopic import diagram_line, stroboscopic_diagram, stroboscopic_diagrams
from hertzmap.study.products.catalog import (PRODUCTS, RUN_PRODUCTS, Context, Product,
                                             compute_products)
from hertzmap.study.products.classes import orbit_classes, valid_orbits
from hertzmap.study.products.bifurcation_curves import (CURVES, LOCATED_KINDS, bifurcation_curves, contour_lines,
                                   curve_segments, located_curves)
from hertzmap.study.products.maps import MAP_CLASSES, STABLE_SET_FLAGS, isola_mask, loss_of_contact_map
from hertzmap.study.products.mms import (MMS_HALF_WIDTH, MMS_OMEGA, mms_curves,
                                         mms_curves_over, mms_response, mms_response_over)
from hertzmap.study.products.paper_numbers import branch_end, flip_minimum
from hertzmap.study.products.response import force_harmonics, frequency_response, time_histories
from hertzmap.study.products.damping import (MEASURED_STAR_RATIO, MEASURED_ZETA,
                                               THRESHOLD_VARIABLES, impact_onset, thresholds)
from hertzmap.study.products.traced_curves import (TRACED_VARIABLES, failed_traces, isola_boundary,
                                          traced_segments)
from hertzmap.study.products.results import (completed, contact_threshold, exponent_of, open_store,
                                    rig_of, source_attrs)
from hertzmap.study.products.stepped_sweeps import (jumps_of, stepped_sweeps, sweep_line,
                                                    sweeps_dataset)

__all__ = [
    "STABLE_SET_FLAGS", "CURVES", "LOCATED_KINDS", "MMS_HALF_WIDTH", "MMS_OMEGA",
    "open_store", "completed", "exponent_of", "contact_threshold", "rig_of",
    "valid_orbits", "orbit_classes", "loss_of_contact_map", "isola_mask",
    "contour_lines", "bifurcation_curves", "located_curves", "curve_segments",
    "mms_curves", "mms_response", "frequency_response", "force_harmonics", "time_histories",
    "flip_minimum", "branch_end", "compute_products", "stroboscopic_diagram", "MAP_CLASSES",
    "TRACED_VARIABLES", "traced_segments", "failed_traces", "isola_boundary",
    "stroboscopic_diagrams", "diagram_line", "mms_curves_over", "mms_response_over",
    "thresholds", "impact_onset", "THRESHOLD_VARIABLES", "MEASURED_STAR_RATIO", "MEASURED_ZETA",
    "PRODUCTS", "RUN_PRODUCTS", "Context", "Product",
    "stepped_sweeps", "sweeps_dataset", "sweep_line", "jumps_of",
]
