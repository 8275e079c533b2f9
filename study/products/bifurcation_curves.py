"""Curves in (omega, sigma) per zeta: contours of the map's grid indicators, and the located
bifurcation points of a store linked across its sigma lines."""
from __future__ import annotations

import numpy as np
import xarray as xr

from hertzmap.study.products.results import var_attrs, source_attrs
from hertzmap.study.schema import BIFURCATION_KINDS

#: Curve kinds of :func:`bifurcation_curves`: (code, name, indicator, level, description).
CURVES: tuple[tuple[int, str, str, float, str], ...] = (
    (1, "flip_1T", "flip_indicator_1T", 0.0,
     "flip (period-doubling) of the 1T response: zero of (1 + mu1)(1 + mu2) = 1 + tr M + det M "
     "of the 1T orbit of slot 0"),
    (2, "grazing_1T", "contact_margin_1T", 0.0,
     "grazing of the 1T response of slot 0: zero of min q + n (contact is lost inside)"),
    (3, "grazing_2T", "contact_margin_2T", 0.0,
     "grazing of the stable 2T response of largest ptp: zero of min q + n"),
    (4, "boundary_2T", "exists_2T", 0.5,
     "boundary of the region where a 2T response exists (its folds, and the flip where it is "
     "born supercritically); level 0.5 of the 0/1 existence field: accurate to about one grid step"),
    (5, "coexistence_1T", "coexist_1T", 0.5,
     "boundary of the region with two or more 1T responses (folds of the primary resonance); "
     "level 0.5 of a 0/1 field: accurate to about one grid step"),
    (6, "isola", "isola_2T", 0.5,
     "boundary of the isolas of 2T responses with contact loss (heuristic, see isola_mask); "
     "level 0.5 of a 0/1 field: accurate to about one grid step"),
)


def contour_lines(x: np.ndarray, y: np.ndarray, z: np.ndarray, level: float = 0.0
                  ) -> list[np.ndarray]:
    """Lines of ``z(x, y) = level`` on a rectilinear grid (contourpy, as matplotlib's contour).

    ``z`` has shape (len(x), len(y)); NaN points are masked (no line crosses them). Returns a list
    of (k, 2) arrays of (x, y) vertices, one per connected line.
    """
    import contourpy

    x = np.asarray(x, float)
    y = np.asarray(y, float)
    z = np.asarray(z, float)
    if x.size < 2 or y.size < 2:
        return []
    zt = np.ma.masked_invalid(z.T)            # contourpy wants z[y, x]
    if zt.mask.all() if np.ma.is_masked(zt) else False:
        return []
    gen = contourpy.contour_generator(x, y, zt, name="serial", line_type="Separate")
    return [np.asarray(line, float) for line in gen.lines(level) if len(line) >= 2]


def bifurcation_curves(lcm: xr.Dataset) -> xr.Dataset:
    """Curves in the (omega, sigma) plane per zeta, contoured from a loss-of-contact map.

    A long table over dim ``vertex``: ``omega``, ``sigma``, ``zeta``, ``curve`` (code of
    :data:`CURVES`) and ``segment`` (one id per connected line; vertices of a segment are in
    order). Empty (0 vertices) for grids with fewer than two omega or sigma values.
    """
    om = lcm["omega"].values
    sg = lcm["sigma"].values
    rows = []
    seg = 0
    for k, z in enumerate(lcm["zeta"].values):
        for code, name, var, level, _ in CURVES:
            if var not in lcm:
                continue
            field = lcm[var].isel(zeta=k).transpose("omega", "sigma").values.astype(float)
            for line in contour_lines(om, sg, field, level):
                n = len(line)
                rows.append((line[:, 0], line[:, 1], np.full(n, z), np.full(n, code, np.int8),
                             np.full(n, seg, np.int32)))
                seg += 1
    if rows:
        cat = [np.concatenate(c) for c in zip(*rows)]
    else:
        cat = [np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, np.int8), np.zeros(0, np.int32)]
    out = xr.Dataset({
        "omega": ("vertex", cat[0], dict(lcm["omega"].attrs)),
        "sigma": ("vertex", cat[1], dict(lcm["sigma"].attrs)),
        "zeta": ("vertex", cat[2], dict(lcm["zeta"].attrs)),
        "curve": ("vertex", cat[3], var_attrs(
            "curve kind", "1", "; ".join(f"{c}: {n}: {d}" for c, n, _, _, d in CURVES),
            flag_values=np.array([c for c, *_ in CURVES], np.int8),
            flag_meanings=" ".join(n for _, n, *_ in CURVES))),
        "segment": ("vertex", cat[4], var_attrs(
            "line id", "1", "id of the connected line the vertex belongs to (vertices in order)")),
    })
    out.attrs = {k: v for k, v in lcm.attrs.items() if k.startswith("hertzmap") or k in
                 ("model", "exponent")}
    out.attrs["title"] = "bifurcation and grazing curves contoured from the grid"
    out.attrs["method"] = ("contourpy lines of grid indicators (linear interpolation between grid "
                           "points); see the curve attrs")
    return out



#: Codes of ``bifurcation_kind`` (study.schema), by code.
LOCATED_KINDS = {code: kind for kind, code in BIFURCATION_KINDS.items()}

def located_curves(ds: xr.Dataset, max_jump: float | None = None) -> xr.Dataset:
    """The located bifurcation points of a store (``bifurcation_*`` variables, from
    ``open_store``) assembled into curves in (omega, sigma), per zeta, kind and period.

    Points of the same kind and period on consecutive sigma lines are linked greedily, closest
    omega first, when they are at most ``max_jump`` apart in omega (default: 10 % of the grid's
    omega range); a point left unlinked starts a new curve. Long table over dim ``vertex``
    (``omega``, ``sigma``, ``zeta``, ``kind``, ``period``, ``q0``, ``v0``, ``segment``),
    ordered by segment then sigma. Empty (0 vertices) when the store has no located points.
    """
    cols = {k: [] for k in ("omega", "sigma", "zeta", "kind", "period", "q0", "v0", "segment")}
    if "bifurcation_kind" in ds:
        om = ds["omega"].values
        if max_jump is None:
            max_jump = 0.1 * float(om.max() - om.min()) if om.size > 1 else np.inf
        kind = ds["bifurcation_kind"].transpose("omega_block", "sigma", "zeta", ...).values
        get = {n: ds[f"bifurcation_{n}"].transpose("omega_block", "sigma", "zeta", ...).values
               for n in ("omega", "period", "q0", "v0")}
        sg, zt = ds["sigma"].values, ds["zeta"].values
        seg = 0
        for k in range(zt.size):
            for code in sorted(LOCATED_KINDS):
                for per in (1, 2):
                    # per sigma line: the points (omega order) of this kind and period
                    lines = []
                    for j in range(sg.size):
                        sel = (kind[:, j, k] == code) & (get["period"][:, j, k] == per)
                        idx = np.argwhere(sel)
                        pts = sorted((get["omega"][b, j, k, s], get["q0"][b, j, k, s],
                                      get["v0"][b, j, k, s]) for b, s in idx)
                        lines.append(pts)
                    curves: list[list[tuple]] = []     # (sigma index, point)
                    open_ends: dict[int, int] = {}      # point index on previous line -> curve
                    for j, pts in enumerate(lines):
                        prev = lines[j - 1] if j else []
                        pairs = sorted((abs(p[0] - q[0]), a, b) for a, p in enumerate(pts)
                                       for b, q in enumerate(prev))
                        taken_a, taken_b, link = set(), set(), {}
                        for d, a, b in pairs:
                            if d <= max_jump and a not in taken_a and b not in taken_b \
                                    and b in open_ends:
                                taken_a.add(a)
                                taken_b.add(b)
                                link[a] = open_ends[b]
                        new_ends = {}
                        for a, p in enumerate(pts):
                            c = link.get(a)
                            if c is None:
                                curves.append([])
                                c = len(curves) - 1
                            curves[c].append((j, p))
                            new_ends[a] = c
                        open_ends = new_ends
                    for cv in curves:
                        for j, (w, q0, v0) in cv:
                            cols["omega"].append(w)
                            cols["sigma"].append(sg[j])
                            cols["zeta"].append(zt[k])
                            cols["kind"].append(code)
                            cols["period"].append(per)
                            cols["q0"].append(q0)
                            cols["v0"].append(v0)
                            cols["segment"].append(seg)
                        seg += 1
    dt = {"kind": np.int8, "period": np.int8, "segment": np.int32}
    arr = {k: np.asarray(v, dtype=dt.get(k, np.float64)) for k, v in cols.items()}
    out = xr.Dataset({
        "omega": ("vertex", arr["omega"], var_attrs(
            "excitation frequency", "1", "omega of the located point (solver accuracy)")),
        "sigma": ("vertex", arr["sigma"], var_attrs(
            "excitation amplitude", "1", "sigma of the grid line the point was located on")),
        "zeta": ("vertex", arr["zeta"], var_attrs("damping ratio", "1", "zeta of the grid line")),
        "kind": ("vertex", arr["kind"], var_attrs(
            "kind of bifurcation point", "1", "1 fold, 2 flip, 3 grazing (as bifurcation_kind)",
            flag_values=np.array(sorted(LOCATED_KINDS), np.int8),
            flag_meanings=" ".join(LOCATED_KINDS[c] for c in sorted(LOCATED_KINDS)))),
        "period": ("vertex", arr["period"], var_attrs(
            "period of the branch", "1", "1: 1T orbit, 2: 2T orbit")),
        "q0": ("vertex", arr["q0"], var_attrs("displacement at tau = 0", "1",
                                           "start point of the orbit at the located point")),
        "v0": ("vertex", arr["v0"], var_attrs("velocity at tau = 0", "1",
                                           "start point of the orbit at the located point")),
        "segment": ("vertex", arr["segment"], var_attrs(
            "curve id", "1", "id of the curve the vertex belongs to (vertices ordered by sigma)")),
    })
    out.attrs = source_attrs(ds, "bifurcation curves assembled from located points")
    out.attrs["method"] = ("fold/flip/grazing points located on each omega line (study.block "
                           "locate=True), linked across sigma lines, closest omega first, "
                           f"within max_jump = {max_jump} in omega")
    return out


def curve_segments(curves: xr.Dataset, name: str, zeta: float | None = None
                   ) -> list[np.ndarray]:
    """The lines (k, 2) of (omega, sigma) of one curve kind (by name), optionally at one zeta."""
    code = {n: c for c, n, *_ in CURVES}[name]
    sel = curves["curve"].values == code
    if zeta is not None:
        sel &= np.isclose(curves["zeta"].values, zeta)
    segs = curves["segment"].values[sel]
    om = curves["omega"].values[sel]
    sg = curves["sigma"].values[sel]
    return [np.column_stack([om[segs == s], sg[segs == s]]) for s in np.unique(segs)]

