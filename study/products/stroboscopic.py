"""The attractor census as products: the brute-force bifurcation diagram (the stroboscopic points
of every attractor against omega along a sigma line), with the stored periodic orbits over it.

:func:`stroboscopic_diagram` is one line's; :func:`stroboscopic_diagrams` those of a few lines
in one Dataset (the product ``stroboscopic_diagram``, its lines chosen by the registry,
study.products.catalog), and :func:`diagram_line` one line of it back.

This is the standard picture of vibro-impact work: each grid point's attractors leave their
last stroboscopic points q(tau = k T) on a vertical line at its omega (one point for a 1T orbit,
m points for an orbit of period m, a cloud for a chaotic one), and the continuation branches (the
stored orbits' start points, stable and unstable) are drawn over it.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from hertzmap.study.products.classes import valid_orbits
from hertzmap.study.products.results import open_store, source_attrs, var_attrs
from hertzmap.study.schema import ATTRACTOR_KINDS

_TITLE = "brute-force bifurcation diagram (stroboscopic points)"


def stroboscopic_diagram(ds: xr.Dataset, sigma: float | None = None,
                         zeta: float | None = None) -> xr.Dataset:
    """Along the omega line at the nearest (sigma, zeta) (default: the first): the census's
    stroboscopic points (dim ``point``: omega, q, q', the attractor's kind and period) and the
    stored orbits (dim ``orbit``: omega, q0, period, stable)."""
    if "computed" not in ds:
        ds = open_store(ds)
    line = ds.sel(sigma=ds["sigma"].values[0] if sigma is None else sigma, method="nearest")
    line = line.sel(zeta=line["zeta"].values[0] if zeta is None else zeta, method="nearest")
    om = line["omega"].values
    cols = {"omega": [], "q": [], "v": [], "kind": [], "period": []}
    if "strobe_q" in line:
        kind = line["attractor_kind"].transpose("omega", "attractor").values
        per = line["attractor_period"].transpose("omega", "attractor").values
        q = line["strobe_q"].transpose("omega", "attractor", "strobe").values
        v = line["strobe_v"].transpose("omega", "attractor", "strobe").values
        for i, a in np.argwhere(kind > 0):
            keep = np.isfinite(q[i, a])
            cols["omega"].append(np.full(keep.sum(), om[i]))
            cols["q"].append(q[i, a][keep])
            cols["v"].append(v[i, a][keep])
            cols["kind"].append(np.full(keep.sum(), kind[i, a], np.int8))
            cols["period"].append(np.full(keep.sum(), per[i, a], np.int8))
    cat = {k: (np.concatenate(v) if v else np.zeros(0)) for k, v in cols.items()}
    ok = valid_orbits(line.expand_dims(["sigma", "zeta"])).isel(sigma=0, zeta=0).transpose(
        "omega", "solution").values
    idx = np.argwhere(ok)
    per = line["period"].transpose("omega", "solution").values
    stab = line["stable"].transpose("omega", "solution").values
    q0 = line["q0"].transpose("omega", "solution").values
    flags = np.array(sorted(ATTRACTOR_KINDS.values()), np.int8)
    out = xr.Dataset(
        {"strobe_omega": ("point", cat["omega"].astype(float), var_attrs(
            "excitation frequency", "1", "omega of the grid point the stroboscopic point is of")),
         "strobe_q": ("point", cat["q"].astype(float), var_attrs(
             "stroboscopic displacement", "1", "q at tau = 0 mod T on an attractor")),
         "strobe_v": ("point", cat["v"].astype(float), var_attrs(
             "stroboscopic velocity", "1", "dq/dtau at tau = 0 mod T on an attractor")),
         "strobe_kind": ("point", cat["kind"].astype(np.int8), var_attrs(
             "kind of attractor", "1", "as attractor_kind (docs/dataset.md)",
             flag_values=flags,
             flag_meanings=" ".join(k for k, _ in sorted(ATTRACTOR_KINDS.items(),
                                                         key=lambda kv: kv[1])))),
         "strobe_period": ("point", cat["period"].astype(np.int8), var_attrs(
             "period of the attractor", "1", "m of a periodic attractor, 0 otherwise")),
         "orbit_omega": ("orbit", om[idx[:, 0]].astype(float), var_attrs(
             "excitation frequency", "1", "omega of a stored orbit")),
         "orbit_q0": ("orbit", q0[idx[:, 0], idx[:, 1]].astype(float), var_attrs(
             "displacement at tau = 0", "1", "start point of a stored orbit (a point of its "
             "stroboscopic cycle)")),
         "orbit_period": ("orbit", per[idx[:, 0], idx[:, 1]].astype(np.int8), var_attrs(
             "period of the orbit", "1", "in forcing periods")),
         "orbit_stable": ("orbit", stab[idx[:, 0], idx[:, 1]].astype(bool), var_attrs(
             "orbit is stable", "1", "both multipliers inside the unit circle"))})
    out.attrs = source_attrs(ds, _TITLE)
    out.attrs.update({"sigma": float(line["sigma"]), "zeta": float(line["zeta"])})
    return out


#: the per-line bookkeeping of :func:`stroboscopic_diagrams` (dropped by :func:`diagram_line`)
_LINE_VARIABLES = ("line_sigma", "line_zeta", "strobe_line", "orbit_line")


def stroboscopic_diagrams(ds: xr.Dataset, *, sigma_lines: int, zeta_lines: int) -> xr.Dataset:
    """:func:`stroboscopic_diagram` along a few lines in one Dataset: at most ``sigma_lines``
    sigma values at each of at most ``zeta_lines`` zeta values (all of them, or that many evenly
    spread from the first to the last). Dim ``line`` (``line_sigma``, ``line_zeta``); the
    lines' points and orbits one after the other along ``point`` and ``orbit``, each with the
    index of its line (``strobe_line``, ``orbit_line``)."""
    if "computed" not in ds:
        ds = open_store(ds)
    def spread(values, n):
        if values.size <= n:
            return values
        return values[np.round(np.linspace(0, values.size - 1, n)).astype(int)]

    parts = [stroboscopic_diagram(ds, float(s), float(z))
             for s in spread(ds["sigma"].values, sigma_lines)
             for z in spread(ds["zeta"].values, zeta_lines)]
    data = {name: (var.dims, np.concatenate([p[name].values for p in parts]), var.attrs)
            for name, var in parts[0].data_vars.items()}
    for dim, name in (("point", "strobe_line"), ("orbit", "orbit_line")):
        data[name] = (dim, np.concatenate([np.full(p.sizes[dim], i, np.int16)
                                           for i, p in enumerate(parts)]), var_attrs(
            f"line of the {dim}", "1", "index along line (line_sigma, line_zeta)"))
    data["line_sigma"] = ("line", np.array([p.attrs["sigma"] for p in parts], float), var_attrs(
        "excitation amplitude", "1", "sigma of the line (the grid value)"))
    data["line_zeta"] = ("line", np.array([p.attrs["zeta"] for p in parts], float), var_attrs(
        "damping ratio", "1", "zeta of the line (the grid value)"))
    out = xr.Dataset(data)
    out.attrs = source_attrs(ds, f"{_TITLE}, {len(parts)} line(s)")
    return out


def diagram_line(diagrams: xr.Dataset, line: int) -> xr.Dataset:
    """Line ``line`` of :func:`stroboscopic_diagrams`: as :func:`stroboscopic_diagram` of it
    (its points and orbits, attrs ``sigma`` and ``zeta``)."""
    one = diagrams.isel(point=np.flatnonzero(diagrams["strobe_line"].values == line),
                        orbit=np.flatnonzero(diagrams["orbit_line"].values == line))
    one = one.drop_vars(_LINE_VARIABLES)
    one.attrs = dict(diagrams.attrs, title=_TITLE,
                     sigma=float(diagrams["line_sigma"].values[line]),
                     zeta=float(diagrams["line_zeta"].values[line]))
    return one


#: Two chaotic (or unsettled) attractors at neighbouring points are one when each stroboscopic
#: cloud's mean distance to the other's nearest point is below this share of their extent.
CLOUD_SHARE = 0.15


def _cloud_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric mean nearest-point distance of two clouds of (q, q') points, relative to their
    joint extent (Attractors.jl's set-distance matching, averaged instead of worst-case: a few
    points of a short record window are allowed to lie off the other's)."""
    if a.shape[0] == 0 or b.shape[0] == 0:
        return np.inf
    d = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    both = np.vstack([a, b])
    extent = float(np.hypot(*(both.max(axis=0) - both.min(axis=0)))) + 1e-12
    return 0.5 * (d.min(axis=1).mean() + d.min(axis=0).mean()) / extent


def attractor_ids(ds: xr.Dataset) -> xr.Dataset:
    """An identity for the census's attractors across the grid: two attractors of neighbouring
    grid points (one step along omega, sigma or zeta) are one when both are periodic and their
    orbits lie on one branch (study.orbit_rules.match_neighbours: the same period, invariants close,
    no fold between them), or both are chaotic or unsettled and their stroboscopic clouds
    overlap (:data:`CLOUD_SHARE`); an id is a connected set of such attractors (numbered in grid
    order, so the same store gives the same ids). ``attractor_id`` (omega, sigma, zeta,
    attractor), and per id its kind, period, points and mean basin fraction."""
    from hertzmap.study.orbit_rules import match_neighbours

    if "computed" not in ds:
        ds = open_store(ds)
    dims = ("omega", "sigma", "zeta", "attractor")
    kind = ds["attractor_kind"].transpose(*dims).values
    sol = ds["attractor_solution"].transpose(*dims).values
    basin = ds["basin_fraction"].transpose(*dims).values
    period = ds["attractor_period"].transpose(*dims).values
    sq = ds["strobe_q"].transpose(*dims, "strobe").values
    sv = ds["strobe_v"].transpose(*dims, "strobe").values
    slots = {n: ds[n].transpose("omega", "sigma", "zeta", "solution", ...).values
             for n in ("period", "min_q", "max_q", "ptp", "multipliers")}
    shape = kind.shape
    parent = np.arange(kind.size)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    def union(i, j):
        ri, rj = find(i), find(j)
        if ri != rj:
            parent[max(ri, rj)] = min(ri, rj)

    def orbit(idx, a):
        s = int(sol[idx + (a,)])
        return {n: slots[n][idx + (s,)] for n in slots}

    def cloud(idx, a):
        q, v = sq[idx + (a,)], sv[idx + (a,)]
        keep = np.isfinite(q) & np.isfinite(v)
        return np.column_stack([q[keep], v[keep]])

    flat = np.arange(kind.size).reshape(shape)
    for idx in np.ndindex(shape[:3]):
        for axis in range(3):
            nb = list(idx)
            nb[axis] += 1
            if nb[axis] >= shape[axis]:
                continue
            nb = tuple(nb)
            here = [a for a in range(shape[3]) if kind[idx + (a,)] > 0]
            there = [b for b in range(shape[3]) if kind[nb + (b,)] > 0]
            per_a = [a for a in here if kind[idx + (a,)] == 1 and sol[idx + (a,)] >= 0]
            per_b = [b for b in there if kind[nb + (b,)] == 1 and sol[nb + (b,)] >= 0]
            if per_a and per_b:
                for ia, ib in match_neighbours([orbit(idx, a) for a in per_a],
                                               [orbit(nb, b) for b in per_b]):
                    union(flat[idx + (per_a[ia],)], flat[nb + (per_b[ib],)])
            for a in (a for a in here if kind[idx + (a,)] in (2, 3)):
                for b in (b for b in there if kind[nb + (b,)] in (2, 3)):
                    if _cloud_distance(cloud(idx, a), cloud(nb, b)) <= CLOUD_SHARE:
                        union(flat[idx + (a,)], flat[nb + (b,)])
    ids = np.full(kind.size, -1, np.int32)
    number: dict[int, int] = {}
    for i in np.flatnonzero(kind.ravel() > 0):
        ids[i] = number.setdefault(find(i), len(number))
    ids = ids.reshape(shape)
    n = len(number)
    id_kind = np.zeros(n, np.int8)
    id_period = np.zeros(n, np.int8)
    id_points = np.zeros(n, np.int32)
    id_basin = np.zeros(n)
    for i in np.flatnonzero(ids.ravel() >= 0):
        k = ids.ravel()[i]
        id_kind[k] = kind.ravel()[i]
        id_period[k] = period.ravel()[i]
        id_points[k] += 1
        id_basin[k] += basin.ravel()[i]
    flags = np.array(sorted(ATTRACTOR_KINDS.values()), np.int8)
    meanings = " ".join(sorted(ATTRACTOR_KINDS, key=ATTRACTOR_KINDS.get))
    out = xr.Dataset(
        {"attractor_id": (dims, ids, var_attrs(
            "attractor identity across the grid", "1", "the same number for the census's "
            "attractors of neighbouring grid points that are one attractor (a periodic one: "
            "its orbit continued, on one branch; a chaotic or unsettled one: overlapping "
            "stroboscopic clouds); -1 empty slot")),
         "id_kind": ("id", id_kind, var_attrs("kind of the attractor", "1", "as attractor_kind",
                                              flag_values=flags, flag_meanings=meanings)),
         "id_period": ("id", id_period, var_attrs("period of a periodic attractor", "1",
                                                  "m (its orbit has period m T), 0 otherwise")),
         "id_points": ("id", id_points, var_attrs("grid points holding the attractor", "1",
                                                  "how many grid points the id spans")),
         "id_basin": ("id", id_basin / np.maximum(id_points, 1), var_attrs(
             "mean basin fraction", "1", "the attractor's basin_fraction averaged over its "
             "points"))},
        coords={d: ds[d] for d in dims[:3]} | {"attractor": ("attractor", np.arange(shape[3]),
                                                             var_attrs("attractor slot", "1",
                                                                       "as in the store"))})
    out.attrs = source_attrs(ds, "attractors identified across the grid")
    return out
