"""The products, declared once: which exist, when the results support each and how each is
computed (the figures drawn from them are declared in study.plots.figure_catalog).

Each :class:`Product` of :data:`PRODUCTS` (in the order they are computed: a product comes
after the products it takes) names

* ``needs(ds, context)``: whether the results support it (``ds``: study.products.open_store;
  ``context``: a :class:`Context`, the products asked for and those at hand);
* ``compute(ds, *inputs, **optional)``: the pure function, given the results and the products
  named in ``inputs`` (earlier entries, or :data:`RUN_PRODUCTS`, written by ``hertzmap run``),
  and those named in ``optional`` that are at hand, by name.

The thresholds that decide a product (how many lines, which lines) are declared here, next to
their entry, and nowhere else. :func:`compute_products` is the loop over the registry;
``hertzmap plot`` writes what it returns into the store (scheduler.store) and draws the
figures from the stored groups (study.plots.plot_results).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping, Sequence

import xarray as xr

from hertzmap.study.products.stroboscopic import attractor_ids, stroboscopic_diagrams
from hertzmap.study.products.classes import orbit_classes
from hertzmap.study.products.bifurcation_curves import bifurcation_curves, located_curves
from hertzmap.study.products.maps import loss_of_contact_map
from hertzmap.study.products.mms import (MMS_HALF_WIDTH, mms_curves_over,
                                                     mms_response_over, mms_window)
from hertzmap.study.products.response import force_harmonics, frequency_response, time_histories
from hertzmap.study.products.results import (in_stored_order, open_store, rig_of, sorted_axes,
                                             source_attrs, stored_axes)
from hertzmap.study.products.damping import impact_onset
from hertzmap.study.products.traced_curves import isola_boundary

__all__ = ["Product", "Context", "PRODUCTS", "RUN_PRODUCTS", "MAX_LINES",
           "NAMED_FREQUENCIES", "STROBE_SIGMA_LINES", "STROBE_ZETA_LINES", "product",
           "compute_products"]


@dataclass(frozen=True)
class Context:
    """What besides the results decides a product: ``wanted``, the products asked for by name
    (the figures of ``hertzmap plot --which``: study.plots.products_for; None: every product
    the results support), and ``products``, the products at hand by name (those of
    :data:`RUN_PRODUCTS` the store holds, and those computed so far)."""
    wanted: tuple[str, ...] | None = None
    products: Mapping[str, xr.Dataset] = field(default_factory=dict)


@dataclass(frozen=True)
class Product:
    """One product: the zarr group ``products/<name>`` (docs/products.md has a row for each)."""
    name: str
    description: str
    needs: Callable[[xr.Dataset, Context], bool]
    compute: Callable[..., xr.Dataset]
    inputs: tuple[str, ...] = ()
    #: products it takes when at hand (keyword arguments of ``compute``, by name)
    optional: tuple[str, ...] = ()


#: Products that ``hertzmap run`` writes itself (its stages for the ``curves``, ``thresholds``
#: and ``sweeps`` outputs: scheduler.stages.curve_tasks, scheduler.stages.threshold_tasks,
#: scheduler.stages.sweep_tasks; the last built by study.products.stepped_sweeps.sweeps_dataset) and
#: the others may take.
RUN_PRODUCTS = ("traced_curves", "thresholds", "sweeps")

#: frequency_response and mms_response: studies of at most this many (sigma, zeta) lines.
MAX_LINES = 16
#: time_histories: a study of at most this many omega values is a scene of named frequencies
#: (its histories are drawn unless other figures are asked for; study.plots draws no response
#: or harmonics figure of it unless asked).
NAMED_FREQUENCIES = 8
#: stroboscopic_diagram: its lines, at most this many sigma values (evenly spread) at each of
#: the first this many zeta values.
STROBE_SIGMA_LINES = 4
STROBE_ZETA_LINES = 2


def _always(ds: xr.Dataset, context: Context) -> bool:
    return True


def _few_lines(ds: xr.Dataset, context: Context) -> bool:
    return ds.sizes["sigma"] * ds.sizes["zeta"] <= MAX_LINES


def _mms_window_in_few_lines(ds: xr.Dataset, context: Context) -> bool:
    return _few_lines(ds, context) and mms_window(ds["omega"].values) is not None


def _zeta_swept(ds: xr.Dataset, context: Context) -> bool:
    return ds.sizes["zeta"] >= 2


def _zeta_swept_map(ds: xr.Dataset, context: Context) -> bool:
    return _zeta_swept(ds, context) and ds.sizes["sigma"] >= 2


def _stored(*names: str) -> Callable[[xr.Dataset, Context], bool]:
    """needs: the results hold these variables (the study's outputs stored them)."""
    return lambda ds, context: all(n in ds for n in names)


def _at_hand(name: str) -> Callable[[xr.Dataset, Context], bool]:
    return lambda ds, context: name in context.products


def _histories_wanted(ds: xr.Dataset, context: Context) -> bool:
    if context.wanted is not None:
        return "time_histories" in context.wanted
    return ds.sizes["omega"] <= NAMED_FREQUENCIES


PRODUCTS: tuple[Product, ...] = (
    Product("orbit_classes", "the class of every orbit slot (paper Fig. 6 I-V, extended)",
            _always,
            lambda ds: orbit_classes(ds).to_dataset().assign_attrs(
                source_attrs(ds, "orbit classes"))),
    Product("loss_of_contact_map", "per grid point: the kinds of stable response, contact loss, "
            "coexistence, the census's attractors and the curves' indicators",
            _always, loss_of_contact_map),
    Product("bifurcation_curves", "contour lines of the map's indicators (flip, grazing, 2T "
            "boundary, isola)",
            _always, lambda ds, lcm: bifurcation_curves(lcm), inputs=("loss_of_contact_map",)),
    Product("located_bifurcations", "the stored fold / flip / grazing points linked into curves",
            _stored("bifurcation_kind"), located_curves),
    Product("mms_curves", "the multiple-scales thresholds sigma1, sigma2, sigma*",
            _always, mms_curves_over),
    Product("frequency_response", f"response curves of every orbit (at most {MAX_LINES} lines)",
            _few_lines, lambda ds: frequency_response(ds, rig=rig_of(ds))),
    Product("mms_response", f"the multiple-scales frequency response (at most {MAX_LINES} "
            f"lines; omega within abs(omega - 2) <= {MMS_HALF_WIDTH:g})",
            _mms_window_in_few_lines, mms_response_over),
    Product("force_harmonics", "contact-force harmonics on a common frequency axis",
            _stored("force_harmonics"), lambda ds: force_harmonics(ds, rig=rig_of(ds))),
    Product("stroboscopic_diagram", "the census's stroboscopic points and the stored orbits "
            f"along at most {STROBE_SIGMA_LINES} x {STROBE_ZETA_LINES} (sigma, zeta) lines",
            _stored("strobe_q"),
            lambda ds: stroboscopic_diagrams(ds, sigma_lines=STROBE_SIGMA_LINES,
                                             zeta_lines=STROBE_ZETA_LINES)),
    Product("attractor_ids", "an identity for the census's attractors across the grid "
            "(continued orbits, overlapping stroboscopic clouds), with each one's extent",
            _stored("attractor_kind", "strobe_q"), attractor_ids),
    Product("time_histories", "F_exp of every stable orbit over 4 forcing cycles (scenes of at "
            f"most {NAMED_FREQUENCIES} omega values, or asked for)",
            _histories_wanted, lambda ds: time_histories(ds, rig=rig_of(ds))),
    Product("isola_boundary", "sigma** of the isola and where it joins the flip curve, read off "
            "the traced curves",
            _at_hand("traced_curves"),
            lambda ds, traced, thresholds=None: isola_boundary(traced, thresholds,
                                                               ds["zeta"].values),
            inputs=("traced_curves",), optional=("thresholds",)),
    Product("impact_onset", "where vibro-impacts start: the lowest sigma at which a stable "
            "response loses contact, over (omega, zeta), in the rig's units with a [rig] "
            "(maps of two or more zeta values)",
            _zeta_swept_map, lambda ds, lcm: impact_onset(lcm, rig_of(ds)),
            inputs=("loss_of_contact_map",)),
)

def product(name: str) -> Product:
    """The registry's entry ``name``."""
    for p in PRODUCTS:
        if p.name == name:
            return p
    raise KeyError(f"no product {name!r}; the products: {', '.join(p.name for p in PRODUCTS)}")


def compute_products(results: str | Path | xr.Dataset, *, wanted: Sequence[str] | None = None,
                     given: Mapping[str, xr.Dataset] | None = None) -> dict[str, xr.Dataset]:
    """Every product of :data:`PRODUCTS` that the results support, by name (a pure function:
    nothing is written). ``wanted``: the products asked for (study.plots.products_for of the
    figures asked for; it decides ``time_histories``), None for every one;
    ``given``: products at hand (those of :data:`RUN_PRODUCTS` the store holds), taken by
    the products that need them and not returned.

    Computed on the results' sorted axes (open_store), each product is returned with its
    dims omega, sigma, zeta in the store's order (results.in_stored_order): written as a
    group ``products/<name>``, it aligns with the main group, and the store opens as one
    xarray DataTree (a product on a grid of its own names its own dims: ``mms_omega``)."""
    ds = open_store(results)
    axes = stored_axes(ds)
    at_hand = {name: sorted_axes(prod) for name, prod in (given or {}).items()}
    out: dict[str, xr.Dataset] = {}
    context = Context(None if wanted is None else tuple(wanted), at_hand)
    for p in PRODUCTS:
        if p.needs(ds, context):
            at_hand[p.name] = p.compute(ds, *(at_hand[n] for n in p.inputs),
                                        **{n: at_hand[n] for n in p.optional if n in at_hand})
            out[p.name] = in_stored_order(at_hand[p.name], axes)
    return out
