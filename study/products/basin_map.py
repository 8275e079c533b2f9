"""The basin map product: a study.solve.basin_grid.BasinMap as a Dataset, stored by ``hertzmap
basins`` as the zarr group ``products/<basin_map_name(...)>`` of the store.

It is not an entry of the registry (catalog.PRODUCTS): a registry product is a function of
the stored results alone, computed by ``hertzmap plot`` for every store that supports it; a
basin map is computed on demand, at a grid point and on a grid of initial states the user
names (new transients, run on the cluster), and a store may hold several (one group per grid
point).
"""
from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from hertzmap.kernels.records import ATTRACTOR_KINDS, STROBE_POINTS
from hertzmap.study.basin_measures import (entropy_errors, uncertainty_exponent,
                                           wada_merging)
from hertzmap.study.schema import VARIABLES

#: per cell, how its label was found (study.solve.dense_basins.METHODS; a map of
#: study.solve.basin_grid has every cell's own census transient: ``census``)
METHOD_MEANINGS = "seed reused census"
#: the group name's prefix (products/basin_map_omega<w>_sigma<s>_zeta<z>)
BASIN_MAP_PREFIX = "basin_map"
#: the dim (and coordinate) of the map's own attractors, those its transients end on: not the
#: main group's ``attractor`` slots of the census (a store's product groups share the names of
#: its dims only where they share their values, so that the store opens as one xarray DataTree)
BASIN_ATTRACTOR = "basin_attractor"


def basin_map_name(omega: float, sigma: float, zeta: float) -> str:
    """The product group's name of the basin map at the grid point (omega, sigma, zeta)."""
    return f"{BASIN_MAP_PREFIX}_omega{omega:.6g}_sigma{sigma:.6g}_zeta{zeta:.6g}"


def _attrs(long_name: str, description: str, units: str = "1") -> dict[str, str]:
    return {"long_name": long_name, "units": units, "description": description}


def basin_map_dataset(bm, source: dict[str, Any]) -> xr.Dataset:
    """The Dataset of a basin map ``bm`` (study.solve.basin_grid.BasinMap); ``source``: the attrs
    naming the store it was computed from (study.products.results.source_attrs)."""
    k = len(bm.attractors)
    strobe_q = np.full((k, STROBE_POINTS), np.nan)
    strobe_v = np.full((k, STROBE_POINTS), np.nan)
    for a_index, a in enumerate(bm.attractors):
        pts = np.asarray(a["strobe"], float).reshape(-1, 2)[-STROBE_POINTS:]
        if pts.size:
            strobe_q[a_index, STROBE_POINTS - len(pts):] = pts[:, 0]
            strobe_v[a_index, STROBE_POINTS - len(pts):] = pts[:, 1]
    col = {name: np.array([a[name] for a in bm.attractors]) for name in ("period", "q0", "v0",
                                                                         "count")}
    kind = VARIABLES["attractor_kind"]
    total = bm.labels.size
    e = bm.entropy
    errors = entropy_errors(bm.labels, bm.box)
    unc = uncertainty_exponent(bm.labels)
    wada = wada_merging(bm.labels)
    method = bm.method if bm.method is not None else np.full(bm.labels.shape, 2, np.int8)
    counts = np.bincount(method.ravel(), minlength=3)
    ds = xr.Dataset(
        {
            "basin_method": (("v", "q"), method.astype(np.int8), {
                **_attrs("how the cell's label was found",
                         "0 seed: the state lies in a certified neighbourhood of a stable orbit; "
                         "1 reused: its own transient ran until its point lay in a uniform block "
                         "of cells whose states reached that attractor (or in a certified "
                         "neighbourhood); 2 census: the census's whole transient (period "
                         "detection, shooting): study.solve.dense_basins"),
                "flag_values": np.array([0, 1, 2], np.int8), "flag_meanings": METHOD_MEANINGS}),
            "basin_entropy_error": ((), errors.basin_entropy_error, _attrs(
                "standard error of the basin entropy", "standard deviation of the boxes' "
                "entropies over the square root of their number", "nats")),
            "boundary_basin_entropy_error": ((), errors.boundary_basin_entropy_error, _attrs(
                "standard error of the boundary basin entropy", "the same over the boundary "
                "boxes", "nats")),
            "uncertain_share": ("epsilon", unc.fraction, _attrs(
                "share of eps-uncertain states", "f(eps): share of the cells (those with all "
                "four cells eps away along q and q' on the grid) whose label differs from one "
                "of those four (Grebogi et al. 1983)")),
            "uncertainty_exponent": ((), unc.alpha, _attrs(
                "uncertainty exponent", "alpha: the slope of log f against log eps "
                "(least squares over the epsilon values); f ~ eps^alpha")),
            "uncertainty_exponent_error": ((), unc.alpha_error, _attrs(
                "standard error of the uncertainty exponent", "the slope's standard error from "
                "the fit's residuals")),
            "boundary_dimension": ((), unc.dimension, _attrs(
                "box-counting dimension of the basin boundary", "d = 2 - alpha (1: smooth; "
                "above 1: fractal)")),
            "boundary_dimension_error": ((), unc.alpha_error, _attrs(
                "standard error of the boundary's dimension", "that of alpha")),
            "wada_hausdorff_max": ((), wada.hausdorff_max, _attrs(
                "largest distance between merged boundaries", "the merging method (Daza et al., "
                "Sci. Rep. 8, 9954, 2018): the largest Hausdorff distance, in cells, between the "
                "boundaries of two maps each with every basin but one merged", "cells")),
            "wada_hausdorff_min": ((), wada.hausdorff_min, _attrs(
                "smallest distance between merged boundaries", "the smallest such Hausdorff "
                "distance", "cells")),
            "wada": ((), np.int8(wada.wada), {
                **_attrs("Wada boundary", "1: three or more basins whose merged boundaries all "
                         f"lie within {wada.dilation} cells of one another (the merging method)"),
                "flag_values": np.array([0, 1], np.int8), "flag_meanings": "not_wada wada"}),
            "wada_share": ((), wada.wada_share, _attrs(
                "share of Wada boundary cells", f"share of the boundary's cells within "
                f"{wada.dilation} cells of every basin's merged boundary")),
            "wada_share_error": ((), wada.wada_share_error, _attrs(
                "standard error of the Wada share", "binomial, over the boundary's cells")),
            "basin_label": (("v", "q"), bm.labels.astype(np.int16), _attrs(
                "attractor of the initial state",
                f"index along the {BASIN_ATTRACTOR} dim of the attractor the transient from "
                "the cell's initial state (q, v) at tau = 0 ends on (-1: not computed)")),
            "attractor_kind": (BASIN_ATTRACTOR, np.array([ATTRACTOR_KINDS[a["kind"]]
                                                          for a in bm.attractors], np.int8),
                               kind.attrs()),
            "attractor_period": (BASIN_ATTRACTOR, col["period"].astype(np.int8),
                                 VARIABLES["attractor_period"].attrs()),
            "attractor_q0": (BASIN_ATTRACTOR, col["q0"].astype(float), _attrs(
                "displacement at tau = 0 of a periodic attractor",
                "start point q(0) of the stable orbit (refined by shooting); NaN otherwise")),
            "attractor_v0": (BASIN_ATTRACTOR, col["v0"].astype(float), _attrs(
                "velocity at tau = 0 of a periodic attractor",
                "start point dq/dtau(0) of the stable orbit; NaN otherwise")),
            "attractor_cells": (BASIN_ATTRACTOR, col["count"].astype(np.int64), _attrs(
                "cells of the basin", "initial states of the grid ending on the attractor")),
            "basin_fraction": (BASIN_ATTRACTOR, col["count"] / total, _attrs(
                "basin fraction", "share of the grid's initial states ending on the attractor "
                "(a measure of its basin over the box q x v)")),
            "strobe_q": ((BASIN_ATTRACTOR, "strobe"), strobe_q, VARIABLES["strobe_q"].attrs()),
            "strobe_v": ((BASIN_ATTRACTOR, "strobe"), strobe_v, VARIABLES["strobe_v"].attrs()),
            "basin_entropy": ((), e.basin_entropy, _attrs(
                "basin entropy", "S_b (Daza et al., Sci. Rep. 6, 31416, 2016): the mean over "
                f"boxes of {bm.box} x {bm.box} cells of -sum_i p_i log p_i, p_i the share of the "
                "box's cells ending on attractor i", "nats")),
            "boundary_basin_entropy": ((), e.boundary_basin_entropy, _attrs(
                "boundary basin entropy", "S_bb: the same mean over the boxes holding more than "
                "one attractor (0 where none does); S_bb > log 2: the boundary is fractal "
                "(a sufficient condition)", "nats")),
            "uncertainty_fraction": ((), bm.uncertainty, _attrs(
                "uncertainty fraction", "share of the cells whose attractor differs from that "
                "of a neighbouring cell (eps = one cell along q or v)")),
        },
        coords={
            "q": ("q", bm.q, _attrs("initial displacement", "q at tau = 0 of the cell's "
                                    "initial state (cell centre)")),
            "v": ("v", bm.v, _attrs("initial velocity", "dq/dtau at tau = 0 of the cell's "
                                    "initial state (cell centre)")),
            BASIN_ATTRACTOR: (BASIN_ATTRACTOR, np.arange(k, dtype=np.int16), _attrs(
                "attractor index", "periodic attractors by basin size, then the transients "
                "that did not settle, then the failures")),
            "epsilon": ("epsilon", unc.epsilon, _attrs(
                "uncertainty radius", "eps of the uncertain share, in cells of the grid",
                "cells")),
            "strobe": ("strobe", np.arange(STROBE_POINTS, dtype=np.int16), _attrs(
                "stroboscopic point index", "k-th of the last stroboscopic points of a "
                "transient that reached the attractor, in time order")),
        },
        attrs={**source, "title": f"basin map at omega = {bm.omega:g}, sigma = {bm.sigma:g}, "
                                  f"zeta = {bm.zeta:g}",
               "omega": bm.omega, "sigma": bm.sigma, "zeta": bm.zeta,
               "box_side": bm.box, "boxes": e.boxes, "boundary_boxes": e.boundary_boxes,
               "transient_periods": bm.transient_periods, "record_periods": bm.record_periods,
               "method": "transients" if bm.method is None else "reuse",
               "cells_seed": int(counts[0]), "cells_reused": int(counts[1]),
               "cells_census": int(counts[2]), "wada_dilation": wada.dilation,
               "wada_basins": wada.basins},
    )
    return ds
