"""Traced bifurcation curves as a product (the store's ``products/traced_curves``) and what is
read off them: the isola boundary, sigma** and where the isola joins the flip-born branch.

The traced curves are computed by ``hertzmap run`` for studies with the ``curves`` output
(study.solve.curve_seeds, one Dask task per curve) and stored by the scheduler one curve at a time;
this module defines their variables once, builds the product from the traces
(:func:`traced_curves_dataset`, :func:`combine_traced_curves`) and reads it
(:func:`traced_segments`, :func:`isola_boundary`). numpy / xarray only.

Four dims: ``vertex`` (every vertex of every curve, curve by curve, in order along each),
``curve`` (one entry per trace run and kept: the curves, and the seeds whose trace did not
start), ``codim2`` (the codimension-2 points located on the curves) and ``seed`` (every grid
cell where a test function changes sign, in seed order: the curve that covers it, or why none
does: the completeness check).
"""
from __future__ import annotations

import json

import numpy as np
import xarray as xr

from hertzmap.kernels.continuation import (BRANCH_STATUS, CODIM2_KINDS, VERTEX_END, VERTEX_EXTREMUM,
                                  VERTEX_FLAGS)
from hertzmap.kernels.records import VERTEX
from hertzmap.study.products.results import var_attrs
from hertzmap.study.schema import BIFURCATION_KINDS

#: Plane codes (study.solve.curve_seeds.PLANES order).
PLANE_CODES = {("omega", "sigma"): 1, ("omega", "zeta"): 2, ("sigma", "zeta"): 3}
#: Codimension-2 kinds, by code (1-based, kernels.continuation.CODIM2_KINDS order).
CODIM2_CODES = {k: i + 1 for i, k in enumerate(CODIM2_KINDS)}
#: End status codes of a curve (kernels.continuation.BRANCH_STATUS: "meets_1T_orbit" is a 2T
#: curve that ends on the 1T orbit).
STATUS_MEANINGS = BRANCH_STATUS
#: What became of each seed (study.solve.curve_seeds.SeedBook.outcomes), by code.
SEED_OUTCOMES = {1: "traced", 2: "covered", 3: "start_fail", 4: "on_earlier_curve",
                 5: "off_seed", 6: "near_untraced"}
_OUTCOME_CODE = {name: code for code, name in SEED_OUTCOMES.items()}
_STATUS_CODE = {name: code for code, name in BRANCH_STATUS.items()}

_KIND_DOC = "1 fold (a multiplier +1), 2 flip (a multiplier -1), 3 grazing (min q = -n)"
_KIND_ATTRS = dict(flag_values=np.array(sorted(BIFURCATION_KINDS.values()), np.int8),
                   flag_meanings=" ".join(sorted(BIFURCATION_KINDS, key=BIFURCATION_KINDS.get)))
_PLANE_ATTRS = dict(flag_values=np.array([1, 2, 3], np.int8),
                    flag_meanings="omega_sigma omega_zeta sigma_zeta")
_STATUS_ATTRS = dict(flag_values=np.array(sorted(STATUS_MEANINGS), np.int8),
                     flag_meanings=" ".join(STATUS_MEANINGS[c] for c in sorted(STATUS_MEANINGS)))
_OUTCOME_ATTRS = dict(flag_values=np.array(sorted(SEED_OUTCOMES), np.int8),
                      flag_meanings=" ".join(SEED_OUTCOMES[c] for c in sorted(SEED_OUTCOMES)))

#: The variables of the product, defined once: name -> (dim(s), dtype, fill, attrs).
TRACED_VARIABLES: dict[str, tuple[tuple[str, ...], str, object, dict]] = {
    # -- vertices --------------------------------------------------------------------------
    # the vertex record's stored fields (kernels.records.VERTEX)
    **{f.name: (("vertex",), f.dtype, f.fill, var_attrs(f.long_name, f.units, f.description))
       for f in VERTEX.stored()},
    "kind": (("vertex",), "int8", 0, var_attrs(
        "kind of curve", "1", _KIND_DOC, **_KIND_ATTRS)),
    "period": (("vertex",), "int8", 0, var_attrs(
        "period of the orbit", "1", "period of the orbit on the curve in forcing periods T = "
        "2 pi / omega (a flip curve of period 2 is the 2T -> 4T flip)")),
    "plane": (("vertex",), "int8", 0, var_attrs(
        "plane of the curve", "1", "the two parameters the curve is traced in (the third "
        "fixed): 1 (omega, sigma), 2 (omega, zeta), 3 (sigma, zeta)", **_PLANE_ATTRS)),
    "curve_id": (("vertex",), "int32", -1, var_attrs(
        "curve id", "1", "index of the vertex's curve along dim curve; vertices of a curve are "
        "consecutive and in order along it")),
    "multipliers": (("vertex", "multiplier"), "complex128", complex(np.nan, np.nan), var_attrs(
        "Floquet multipliers", "1", "eigenvalues of the monodromy over the orbit's period, "
        "largest modulus first (one is +1 on a fold curve, -1 on a flip curve)")),
    "flag": (("vertex",), "int8", 0, var_attrs(
        "vertex flags", "1", "why the vertex is there (bit mask): seed, a refined extremum of "
        "a parameter along the curve, on the window's edge, the extrapolated end on the 1T "
        "orbit, a located codimension-2 point",
        flag_masks=np.array([m for m, _ in VERTEX_FLAGS], np.int8),
        flag_meanings=" ".join(n for _, n in VERTEX_FLAGS))),
    # -- curves ----------------------------------------------------------------------------
    "curve_kind": (("curve",), "int8", 0, var_attrs("kind of curve", "1", _KIND_DOC,
                                                     **_KIND_ATTRS)),
    "curve_period": (("curve",), "int8", 0, var_attrs(
        "period of the curve's orbits", "1", "in forcing periods")),
    "curve_plane": (("curve",), "int8", 0, var_attrs(
        "plane of the curve", "1", "as plane", **_PLANE_ATTRS)),
    "curve_fixed": (("curve",), "float64", np.nan, var_attrs(
        "value of the third parameter", "1", "the parameter not in the curve's plane is held "
        "at this value")),
    "curve_status_start": (("curve",), "int8", 5, var_attrs(
        "how the curve's first vertex ends it", "1", "why the trace stopped at the curve's "
        "start", **_STATUS_ATTRS)),
    "curve_status_end": (("curve",), "int8", 5, var_attrs(
        "how the curve's last vertex ends it", "1", "why the trace stopped at the curve's "
        "end (start_fail on both: the seed did not converge onto a curve)", **_STATUS_ATTRS)),
    "curve_seed": (("curve",), "int32", -1, var_attrs(
        "seed index", "1", "place of the curve's seed in the study's seed order "
        "(study.solve.curve_seeds.curve_seeds)")),
    "curve_seed_omega": (("curve",), "float64", np.nan, var_attrs(
        "omega of the seed", "1", "the estimated crossing of the seed the curve was traced from")),
    "curve_seed_sigma": (("curve",), "float64", np.nan, var_attrs("sigma of the seed", "1", "")),
    "curve_seed_zeta": (("curve",), "float64", np.nan, var_attrs("zeta of the seed", "1", "")),
    "curve_vertices": (("curve",), "int32", 0, var_attrs(
        "number of vertices", "1", "vertices of the curve along dim vertex")),
    "curve_length": (("curve",), "float64", 0.0, var_attrs(
        "length in the parameter plane", "1", "sum of the Euclidean distances between "
        "consecutive vertices in the curve's two parameters")),
    "curve_maps": (("curve",), "int64", 0, var_attrs(
        "period maps integrated", "1", "the trace's cost in period maps (the orbit's "
        "period, with its monodromy)")),
    # -- codimension-2 points ----------------------------------------------------------------
    "codim2_kind": (("codim2",), "int8", 0, var_attrs(
        "kind of codimension-2 point", "1",
        "1 cusp of a fold curve (its projection onto the parameter plane turns back), "
        "2 fold_flip (a 2T fold curve meets the 1T flip curve: the degenerate flip where the "
        "isola joins the flip-born branch), 3 fold_grazing, 4 flip_grazing (a grazing curve "
        "meets a fold or flip curve, or a 2T grazing curve ends on the 1T flip curve)",
        flag_values=np.array(sorted(CODIM2_CODES.values()), np.int8),
        flag_meanings=" ".join(CODIM2_KINDS))),
    "codim2_curve": (("codim2",), "int32", -1, var_attrs(
        "curve id", "1", "the curve (dim curve) the point was located on")),
    "codim2_vertex": (("codim2",), "int32", -1, var_attrs(
        "vertex index", "1", "index along dim vertex of the vertex holding the point")),
    "codim2_period": (("codim2",), "int8", 0, var_attrs("period of the orbit", "1", "")),
    "codim2_omega": (("codim2",), "float64", np.nan, var_attrs("excitation frequency", "1", "")),
    "codim2_sigma": (("codim2",), "float64", np.nan, var_attrs("excitation amplitude", "1", "")),
    "codim2_zeta": (("codim2",), "float64", np.nan, var_attrs("damping ratio", "1", "")),
    "codim2_q0": (("codim2",), "float64", np.nan, var_attrs("displacement at tau = 0", "1", "")),
    "codim2_v0": (("codim2",), "float64", np.nan, var_attrs("velocity at tau = 0", "1", "")),
    "codim2_multipliers": (("codim2", "multiplier"), "complex128", complex(np.nan, np.nan),
                           var_attrs("Floquet multipliers", "1", "of the orbit at the point "
                                     "(for fold_flip: of the 1T orbit)")),
    "codim2_value": (("codim2",), "float64", np.nan, var_attrs(
        "test function at the point", "1", "the other curve's test function at the point "
        "(cusp: the tangent's component along its direction before the cusp; fold_flip: "
        "1 + tr M + det M of the 1T orbit at the extrapolated point)")),
    "codim2_left": (("codim2",), "float64", np.nan, var_attrs(
        "test function before the point", "1", "its value at the vertex before the point "
        "(fold_flip: at the last traced vertex's parameters)")),
    "codim2_right": (("codim2",), "float64", np.nan, var_attrs(
        "test function after the point", "1", "its value at the vertex after the point "
        "(opposite sign to left; NaN for fold_flip, which ends the curve)")),
    "codim2_accuracy": (("codim2",), "float64", np.nan, var_attrs(
        "accuracy in the parameters", "1", "final bracket width in the curve's parameters "
        "(fold_flip: spread of the extrapolation to the 1T orbit)")),
    # -- seeds: the completeness check ---------------------------------------------------------
    "seed_kind": (("seed",), "int8", 0, var_attrs(
        "kind of the seed's sign change", "1", _KIND_DOC + " (study.solve.curve_seeds.crossings)",
        **_KIND_ATTRS)),
    "seed_period": (("seed",), "int8", 0, var_attrs(
        "period of the seed's orbits", "1", "in forcing periods")),
    "seed_plane": (("seed",), "int8", 0, var_attrs(
        "plane of the seed", "1", "as plane", **_PLANE_ATTRS)),
    "seed_fixed": (("seed",), "float64", np.nan, var_attrs(
        "value of the third parameter", "1", "as curve_fixed")),
    "seed_omega": (("seed",), "float64", np.nan, var_attrs(
        "omega of the seed", "1", "estimated crossing of the curve with the grid cell (the "
        "edge between two neighbouring grid points) where the test function changes sign")),
    "seed_sigma": (("seed",), "float64", np.nan, var_attrs("sigma of the seed", "1", "")),
    "seed_zeta": (("seed",), "float64", np.nan, var_attrs("zeta of the seed", "1", "")),
    "seed_curve": (("seed",), "int32", -1, var_attrs(
        "covering curve", "1", "the curve (dim curve) passing within COVER_CELLS grid steps of "
        "the seed with matching orbit invariants (study.solve.curve_seeds.covers); -1: none (see "
        "seed_outcome)")),
    "seed_outcome": (("seed",), "int8", 0, var_attrs(
        "what became of the seed", "1", "traced: a curve was traced from it (seed_curve); "
        "covered: it lies on a curve traced from another seed (seed_curve); not covered: "
        "start_fail (its trace did not converge onto a curve: seed_ref is its failed entry in "
        "dim curve), on_earlier_curve (its trace converged onto curve seed_ref, traced from an "
        "earlier seed, which does not pass through its cell), off_seed (the curve seed_ref "
        "traced from it does not pass through its cell), near_untraced (not tried: within "
        "FAILED_CELLS grid steps of seed seed_ref, of its kind and period, whose trace did not "
        "cover it)", **_OUTCOME_ATTRS)),
    "seed_ref": (("seed",), "int32", -1, var_attrs(
        "reference of the outcome", "1", "a curve id (dim curve) or, for near_untraced, a seed "
        "index (dim seed), as seed_outcome says; -1 for traced and covered")),
}

#: the variables a one-curve part holds: all but the seeds' records (the ``seed`` dim), which
#: only the combined product holds (combine_traced_curves, seeds_dataset)
CURVE_VARIABLES = {name: spec for name, spec in TRACED_VARIABLES.items() if spec[0] != ("seed",)}


#: the vertex record's fields the product stores as they are
_VERTEX_STORED = tuple(f.name for f in VERTEX.stored())


def _status_code(name: str) -> int:
    return _STATUS_CODE.get(name, 5)


def traced_curves_dataset(results: list[dict], attrs: dict | None = None) -> xr.Dataset:
    """The product from traces (study.solve.curve_seeds.trace_seed results, in seed order): one
    entry of dim ``curve`` per result (a failed trace has no vertices), its vertices and its
    codimension-2 points. Curve ids are positions in ``results``."""
    cols: dict[str, list] = {name: [] for name in TRACED_VARIABLES}
    offset = 0
    for cid, r in enumerate(results):
        s = r["seed"]
        V = r["vertices"]
        n = len(V.get("omega", ()))
        plane = PLANE_CODES[tuple(s["plane"])]
        kcode = BIFURCATION_KINDS[s["kind"]]
        for name in _VERTEX_STORED:
            cols[name].append(np.asarray(V[name], float) if n else np.zeros(0))
        cols["multipliers"].append(np.asarray(V["multipliers"], complex).reshape(n, 2) if n
                                   else np.zeros((0, 2), complex))
        cols["flag"].append(np.asarray(V["flag"]).astype(np.int8) if n else np.zeros(0, np.int8))
        cols["kind"].append(np.full(n, kcode, np.int8))
        cols["period"].append(np.full(n, s["period"], np.int8))
        cols["plane"].append(np.full(n, plane, np.int8))
        cols["curve_id"].append(np.full(n, cid, np.int32))
        a, b = s["plane"]
        length = float(np.sum(np.hypot(np.diff(V[a]), np.diff(V[b])))) if n > 1 else 0.0
        st = r["status"]
        for name, value in (("curve_kind", kcode), ("curve_period", s["period"]),
                            ("curve_plane", plane), ("curve_fixed", s["fixed"]),
                            ("curve_status_start", _status_code(st[0])),
                            ("curve_status_end", _status_code(st[1])),
                            ("curve_seed", s["index"]), ("curve_seed_omega", s["omega"]),
                            ("curve_seed_sigma", s["sigma"]), ("curve_seed_zeta", s["zeta"]),
                            ("curve_vertices", n), ("curve_length", length),
                            ("curve_maps", r["maps"])):
            cols[name].append(np.array([value]))
        for c in r["codim2"]:
            cols["codim2_kind"].append(np.array([CODIM2_CODES[c["kind"]]]))
            cols["codim2_curve"].append(np.array([cid]))
            cols["codim2_vertex"].append(np.array([offset + c["vertex"]]))
            cols["codim2_period"].append(np.array([c["period"]]))
            for name in ("omega", "sigma", "zeta", "q0", "v0", "value", "left", "right",
                         "accuracy"):
                cols[f"codim2_{name}"].append(np.array([c[name]], float))
            mu = np.asarray(c["multipliers"], complex).reshape(1, -1)[:, :2]
            cols["codim2_multipliers"].append(mu)
        offset += n
    data = {}
    for name, (dims, dtype, fill, vattrs) in CURVE_VARIABLES.items():
        parts = cols[name]
        shape = (0, 2) if len(dims) == 2 else (0,)
        arr = np.concatenate(parts) if parts else np.zeros(shape)
        data[name] = xr.Variable(dims, arr.astype(dtype), dict(vattrs))
    out = xr.Dataset(data, coords={"multiplier": ("multiplier", np.arange(2, dtype=np.int16))})
    out.attrs = {
        "title": "bifurcation curves traced by two-parameter continuation",
        "method": "pseudo-arclength continuation of Phi(x) - x = 0, g = 0 (g: fold, flip or "
                  "grazing test function) from the grid cells where a test function changes "
                  "sign (kernels.continuation.trace_curve, study.solve.curve_seeds)",
        "accuracy": "vertices solve the curve's equations to the integrator's tolerance "
                    "(residual); refined extrema, edges and codimension-2 points are vertices",
        **(attrs or {}),
    }
    return out


def seeds_dataset(seeds: list[dict] | None) -> xr.Dataset:
    """The ``seed`` dim's variables from the seeds' records (study.solve.curve_seeds.SeedBook.outcomes:
    dicts kind, period, plane, fixed, omega, sigma, zeta, curve, outcome, ref), in seed order."""
    seeds = seeds or []
    col = {
        "seed_kind": [BIFURCATION_KINDS[d["kind"]] for d in seeds],
        "seed_period": [d["period"] for d in seeds],
        "seed_plane": [PLANE_CODES[tuple(d["plane"])] for d in seeds],
        "seed_fixed": [d["fixed"] for d in seeds],
        "seed_omega": [d["omega"] for d in seeds],
        "seed_sigma": [d["sigma"] for d in seeds],
        "seed_zeta": [d["zeta"] for d in seeds],
        "seed_curve": [d["curve"] for d in seeds],
        "seed_outcome": [_OUTCOME_CODE[d["outcome"]] for d in seeds],
        "seed_ref": [d["ref"] for d in seeds],
    }
    return xr.Dataset({name: xr.Variable(TRACED_VARIABLES[name][0],
                                         np.asarray(values, TRACED_VARIABLES[name][1]),
                                         dict(TRACED_VARIABLES[name][3]))
                       for name, values in col.items()})


def combine_traced_curves(parts: list[xr.Dataset], attrs: dict | None = None,
                          seeds: list[dict] | None = None) -> xr.Dataset:
    """One product from per-curve parts (each a :func:`traced_curves_dataset` of one trace),
    in the given order: curve ids and vertex indices renumbered; with the seeds' records
    (:func:`seeds_dataset`) on dim ``seed``."""
    if not parts:
        out = traced_curves_dataset([], attrs)
    else:
        fixed = []
        offset = 0
        for cid, p in enumerate(parts):
            p = p.copy()
            p["curve_id"] = p["curve_id"].copy(data=np.full(p.sizes["vertex"], cid, np.int32))
            p["codim2_curve"] = p["codim2_curve"].copy(data=np.full(p.sizes["codim2"], cid,
                                                                    np.int32))
            p["codim2_vertex"] = p["codim2_vertex"].copy(
                data=(p["codim2_vertex"].values + offset).astype(np.int32))
            offset += p.sizes["vertex"]
            fixed.append(p)
        out = xr.Dataset()
        for name, (dims, dtype, _, vattrs) in CURVE_VARIABLES.items():
            arr = np.concatenate([np.asarray(p[name].values) for p in fixed], axis=0)
            out[name] = xr.Variable(dims, arr.astype(dtype), dict(vattrs))
        out = out.assign_coords(multiplier=("multiplier", np.arange(2, dtype=np.int16)))
        out.attrs = {k: v for k, v in parts[0].attrs.items() if k not in PART_ATTRS}
        out.attrs.update(attrs or {})
    for name, var in seeds_dataset(seeds).variables.items():
        out[name] = var
    return out


def traced_segments(traced: xr.Dataset | None, *, kind: str, period: int, zeta: float | None
                    = None, plane: tuple[str, str] = ("omega", "sigma")) -> list[np.ndarray]:
    """The traced curves of one kind and period as (k, 2) arrays of their plane's parameters,
    optionally at one value of the third parameter (``zeta`` for the (omega, sigma) plane)."""
    if traced is None or not traced.sizes.get("vertex", 0):
        return []
    sel = ((traced["kind"].values == BIFURCATION_KINDS[kind])
           & (traced["period"].values == period)
           & (traced["plane"].values == PLANE_CODES[tuple(plane)]))
    if zeta is not None:
        third = [n for n in ("omega", "sigma", "zeta") if n not in plane][0]
        sel &= np.isclose(traced[third].values, zeta)
    ids = traced["curve_id"].values[sel]
    a, b = (traced[plane[0]].values[sel], traced[plane[1]].values[sel])
    return [np.column_stack([a[ids == c], b[ids == c]]) for c in np.unique(ids)]


def failed_traces(traced: xr.Dataset | None, zeta: float | None = None) -> list[dict]:
    """The seeds whose trace failed at once (start_fail on both ends), with their kind and
    period: where the grid's curves stand in for a traced one."""
    if traced is None or not traced.sizes.get("curve", 0):
        return []
    out = []
    for i in range(traced.sizes["curve"]):
        if int(traced["curve_vertices"].values[i]) > 0:
            continue
        z = float(traced["curve_seed_zeta"].values[i])
        if zeta is not None and not np.isclose(z, zeta):
            continue
        out.append({"kind": int(traced["curve_kind"].values[i]),
                    "period": int(traced["curve_period"].values[i]),
                    "status": STATUS_MEANINGS[int(traced["curve_status_end"].values[i])],
                    "omega": float(traced["curve_seed_omega"].values[i]),
                    "sigma": float(traced["curve_seed_sigma"].values[i]), "zeta": z})
    return out


def isola_boundary(traced: xr.Dataset, thresholds: xr.Dataset | None = None,
                   zeta: np.ndarray | None = None) -> xr.Dataset:
    """The isola boundary read off the traced curves, per zeta: the 2T fold curve in the
    (omega, sigma) plane that ends on the 1T orbit (a fold_flip point: where the isola joins
    the flip-born branch) with the lowest interior minimum of sigma (sigma**, paper Fig. 8-9:
    below it no isola). Dims ``zeta``: ``sigma_isola`` (sigma**; NaN when it lies below the
    window), ``omega_isola`` (omega there), ``sigma_join``, ``omega_join`` (the fold_flip
    point), ``curve`` (its id; -1 and NaN where no such curve was traced).

    ``zeta``: the study's zeta values, the dim's values (the product ``isola_boundary``: a
    product group on the study's axis has all of its values, so that the store opens as one
    xarray DataTree); None: the zeta values of the curves traced in the (omega, sigma) plane.

    ``thresholds``: the run's products/thresholds, when the study has it: sigma** is computed
    once, there (Brent on the curve, with its accuracy), and read from it at the zeta values
    where it holds one (the attrs' ``sigma_isola_source`` says which)."""
    if zeta is not None:
        zs = np.asarray(zeta, float)
    else:
        zs = np.unique(traced["zeta"].values[traced["plane"].values == 1]) \
            if traced.sizes.get("vertex", 0) else np.zeros(0)
    rows = []
    for z in zs:
        best = None
        fold2 = ((traced["curve_kind"].values == BIFURCATION_KINDS["fold"])
                 & (traced["curve_period"].values == 2) & (traced["curve_plane"].values == 1)
                 & np.isclose(traced["curve_fixed"].values, z))
        for cid in np.nonzero(fold2)[0]:
            joins = np.nonzero((traced["codim2_curve"].values == cid)
                               & (traced["codim2_kind"].values == CODIM2_CODES["fold_flip"]))[0]
            if joins.size == 0:
                continue
            sel = traced["curve_id"].values == cid
            flags = traced["flag"].values[sel].astype(int)
            ext = ((flags & VERTEX_EXTREMUM) != 0) & ((flags & VERTEX_END) == 0)
            s = traced["sigma"].values[sel]
            w = traced["omega"].values[sel]
            # sigma**: the lowest interior minimum (NaN when it lies outside the window)
            k = int(np.argmin(np.where(ext, s, np.inf))) if ext.any() else -1
            low = (float(s[k]), float(w[k])) if k >= 0 else (np.nan, np.nan)
            if best is not None and not (low[0] < best[0] or np.isnan(best[0])):
                continue
            j = joins[0]
            best = (low[0], low[1], float(traced["codim2_sigma"].values[j]),
                    float(traced["codim2_omega"].values[j]), int(cid))
        rows.append(best or (np.nan, np.nan, np.nan, np.nan, -1))
    arr = np.array(rows, dtype=object).reshape(len(zs), 5) if rows else np.zeros((0, 5))
    out = xr.Dataset({
        "sigma_isola": ("zeta", arr[:, 0].astype(float), var_attrs(
            "sigma** (lowest sigma of the isola)", "1", "interior minimum of sigma along the "
            "isola's fold curve (a refined extremum vertex): below it there is no isola")),
        "omega_isola": ("zeta", arr[:, 1].astype(float), var_attrs(
            "omega at sigma**", "1", "")),
        "sigma_join": ("zeta", arr[:, 2].astype(float), var_attrs(
            "sigma where the isola joins the flip-born branch", "1", "the fold_flip point "
            "that ends the isola's fold curve on the 1T flip curve")),
        "omega_join": ("zeta", arr[:, 3].astype(float), var_attrs(
            "omega where the isola joins the flip-born branch", "1", "")),
        "curve": ("zeta", arr[:, 4].astype(np.int32), var_attrs(
            "curve id", "1", "the isola's fold curve in products/traced_curves (-1: none)")),
    }, coords={"zeta": ("zeta", np.asarray(zs, float), var_attrs("damping ratio", "1", ""))})
    out.attrs = {"title": "isola boundary from the traced 2T fold curves",
                 "source": "products/traced_curves",
                 "sigma_isola_source": "the traced curve's refined extremum vertex"}
    if thresholds is not None and zs.size:
        at = thresholds["sigma_double_star"].reindex(zeta=out["zeta"].values, method="nearest",
                                                     tolerance=1e-12)
        w = thresholds["omega_double_star"].reindex(zeta=out["zeta"].values, method="nearest",
                                                    tolerance=1e-12)
        have = np.isfinite(at.values)
        out["sigma_isola"].values[have] = at.values[have]
        out["omega_isola"].values[have] = w.values[have]
        out.attrs["sigma_isola_source"] = (
            f"products/thresholds (sigma_double_star) at {int(have.sum())} of {zs.size} zeta "
            "values, the traced curve's refined extremum vertex elsewhere")
    return out


#: the attrs of a stored one-curve part that belong to it alone (not to the combined product)
SEED_ATTR, STATUS_ATTR, DUPLICATE_ATTR = ("hertzmap_curve_seed", "hertzmap_curve_status",
                                          "hertzmap_curve_duplicate_of")
PART_ATTRS = (SEED_ATTR, STATUS_ATTR, DUPLICATE_ATTR)


def part_attrs(result: dict, duplicate_of: int = -1) -> dict:
    """Attrs of a stored one-curve part: its seed and status (JSON), for reading back; for a
    trace that converged onto a curve traced from an earlier seed (a duplicate, stored without
    vertices), that seed's index."""
    out = {SEED_ATTR: json.dumps(result["seed"]), STATUS_ATTR: json.dumps(list(result["status"]))}
    if duplicate_of >= 0:
        out[DUPLICATE_ATTR] = int(duplicate_of)
    return out


def trace_from_part(part: xr.Dataset) -> dict:
    """A stored one-curve part read back as a trace (seed, status, duplicate_of (-1 unless a
    duplicate), vertices: omega, sigma, zeta, q0, v0, min_q, max_q, flag), enough to tell
    which seeds lie on it (study.solve.curve_seeds.covers)."""
    seed = json.loads(part.attrs[SEED_ATTR])
    seed["plane"] = tuple(seed["plane"])
    return {"seed": seed, "status": tuple(json.loads(part.attrs[STATUS_ATTR])),
            "duplicate_of": int(part.attrs.get(DUPLICATE_ATTR, -1)),
            "vertices": {n: np.asarray(part[n].values, float)
                         for n in ("omega", "sigma", "zeta", "q0", "v0", "min_q", "max_q",
                                   "flag")}}
