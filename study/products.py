"""Products: from a study's store to the curves and maps of the paper (and beyond).

Everything here is post-processing of a stored dataset (``xr.open_zarr(store)``, schema in
``study/dataset.py``) into small xarray Datasets. Each product is built like an xclim
indicator: a pure numpy/xarray computation first, then the metadata (``long_name``, ``units``,
``description`` on every variable; CF ``flag_values``/``flag_masks``/``flag_meanings`` on
codes). Products are written back into the study's store as their own zarr groups
(``products/<name>``, see :func:`write_product`) and read with
``xr.open_zarr(store, group="products/<name>")``; writing a product never touches the main
group's data.

Products (docs/products.md has the reference):

* :func:`orbit_classes` - the class of every stored orbit (paper Fig. 6 classes I-V, extended to
  1T orbits with contact loss and unstable 1T orbits).
* :func:`loss_of_contact_map` - per (omega, sigma, zeta): which stable responses exist
  (bit mask), counts per class, coexistence, flight fraction and largest impact velocity of
  the stable responses, and the smooth indicators contoured into curves (flip, grazing).
* :func:`bifurcation_curves` - flip curve of the 1T response, grazing curves, boundaries of the
  2T existence region (folds), of 1T coexistence, and isola boundaries, contoured with
  contourpy (the library behind matplotlib's contour) from grid indicators.
* :func:`located_curves` - the fold, flip and grazing points located along each omega line
  by the block solver (``[products] outputs`` with ``"bifurcations"``), linked across the sigma
  lines into curves in (omega, sigma) per zeta, kind and period (solver accuracy, ~1e-8 in
  omega, instead of the grid's interpolation error).
* :func:`mms_curves`, :func:`mms_response` - the multiple-scales sigma1 / sigma2 curves
  (Fig. 3, 7, 9) and A(omega), min q (Fig. 4, 5) from ``study.multiple_scales``.
* :func:`frequency_response` - ptp (and min/max q) against omega with stability and class
  (Fig. 6, 8, 10).
* :func:`force_harmonics` - contact-force harmonics against omega on a common frequency axis
  (omega/2, omega, 3 omega/2, 2 omega), in N and Hz where the study has a ``[rig]`` table
  (numerical counterparts of Fig. 12-13).
* :func:`time_histories` - F_exp(t) = F/N - 1 (paper Eq. 30) of stored orbits, integrated by
  ``kernels.simulate`` (Fig. 14-15).

Curves from grid values are contours of smooth indicators (documented per curve); they are
accurate to the grid's interpolation error, not to the solver's tolerance. Exact curves come
from continuation (kernels/continuation.py, study/discovery.py) and can replace them.

numpy / xarray / contourpy / scipy.ndimage only: no Dask, no scheduler.
"""
from __future__ import annotations

import contextlib
import json
import warnings
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np
import xarray as xr

__all__ = [
    "ORBIT_CLASSES",
    "STABLE_SET_FLAGS",
    "CURVES",
    "PRODUCT_GROUP",
    "open_store",
    "completed",
    "located_curves",
    "exponent_of",
    "contact_threshold",
    "rig_of",
    "valid_orbits",
    "orbit_classes",
    "loss_of_contact_map",
    "isola_mask",
    "contour_lines",
    "bifurcation_curves",
    "mms_curves",
    "mms_response",
    "frequency_response",
    "force_harmonics",
    "time_histories",
    "write_product",
    "read_product",
    "list_products",
    "compute_products",
    "flip_minimum",
    "branch_end",
]

#: Stored products live under this group of the study's store.
PRODUCT_GROUP = "products"

#: MMS curves are computed on |omega - 2| <= MMS_HALF_WIDTH (the expansion is about omega = 2).
MMS_HALF_WIDTH = 0.25

#: Taylor model (Eq. 11): its restoring force vanishes at q = -1.3479 (Eq. 12).
TAYLOR_CONTACT_LOSS = -1.3479

#: Class of one orbit. Codes 1-5 are paper Fig. 6's classes I-V (I: 1T stable in contact).
ORBIT_CLASSES: tuple[tuple[int, str, str], ...] = (
    (0, "none", "empty slot, failed solve or not computed"),
    (1, "I_1T_stable", "I: 1T stable, in contact"),
    (2, "II_2T_stable_contact", "II: 2T stable without loss of contact"),
    (3, "III_2T_stable_contact_loss", "III: 2T stable with loss of contact"),
    (4, "IV_2T_unstable_contact", "IV: 2T unstable without loss of contact"),
    (5, "V_2T_unstable_contact_loss", "V: 2T unstable with loss of contact"),
    (6, "1T_stable_contact_loss", "1T stable with loss of contact (primary resonance impacts)"),
    (7, "1T_unstable_contact", "1T unstable, in contact"),
    (8, "1T_unstable_contact_loss", "1T unstable with loss of contact"),
)

#: Bits of ``stable_set``: which kinds of stable response exist at a point.
STABLE_SET_FLAGS: tuple[tuple[int, str], ...] = (
    (1, "stable_1T_contact"),
    (2, "stable_1T_contact_loss"),
    (4, "stable_2T_contact"),
    (8, "stable_2T_contact_loss"),
)

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


# ---------------------------------------------------------------------------------------------
# reading a store
# ---------------------------------------------------------------------------------------------

@contextlib.contextmanager
def _quiet():
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Cc]onsolidated metadata.*")
        warnings.filterwarnings("ignore", message=".*not part in the Zarr format 3.*")
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
    Axes are sorted (a study may list omega downwards).
    """
    if isinstance(store, xr.Dataset):
        ds = store
    else:
        with _quiet():
            ds = xr.open_zarr(str(store), chunks=None)
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


def exponent_of(ds: xr.Dataset) -> float:
    """The contact exponent n of the store (1.5 for the Taylor model, whose threshold differs)."""
    e = ds.attrs.get("exponent", 1.5)
    try:
        return float(e)
    except (TypeError, ValueError):
        return 1.5


def contact_threshold(ds: xr.Dataset) -> float:
    """q at which contact is lost: -n (Hertz, Eq. 7) or -1.3479 (Taylor, Eq. 12)."""
    if ds.attrs.get("model") == "taylor":
        return TAYLOR_CONTACT_LOSS
    return -exponent_of(ds)


def rig_of(ds: xr.Dataset):
    """The study's rig (``study.rig.Rig``) from the store's study file, or None."""
    toml = ds.attrs.get("hertzmap_study_toml")
    if not toml:
        return None
    from study.rig import Rig
    from study.spec import StudyError, parse_study
    try:
        study = parse_study(toml, default_name=ds.attrs.get("hertzmap_study_name", "study"))
    except StudyError:
        return None
    r = study.rig_dict
    if not r:
        return None
    return Rig.hertz(r["E"], r["nu"], r["R"], r["m"], r["N"], contact=r.get("contact", "double"))


def _attrs(long_name: str, units: str, description: str, **extra) -> dict[str, Any]:
    return {"long_name": long_name, "units": units, "description": description, **extra}


def _source_attrs(ds: xr.Dataset, title: str) -> dict[str, Any]:
    comp = ds["computed"].values if "computed" in ds else completed(ds).values
    return {
        "title": title,
        "hertzmap_study_name": ds.attrs.get("hertzmap_study_name", ""),
        "hertzmap_study_hash": ds.attrs.get("hertzmap_study_hash", ""),
        "hertzmap_product_source": "main group of the store",
        "hertzmap_points_computed": f"{int(comp.sum())}/{comp.size}",
        "model": ds.attrs.get("model", "hertz"),
        "exponent": ds.attrs.get("exponent", 1.5),
    }


def _coord_attrs(out: xr.Dataset, ds: xr.Dataset) -> xr.Dataset:
    for c in out.coords:
        if c in ds.coords and not out[c].attrs:
            out[c].attrs = dict(ds[c].attrs)
    return out


# ---------------------------------------------------------------------------------------------
# classes and the loss-of-contact map
# ---------------------------------------------------------------------------------------------

def _class_codes(ok, period, stable, loses):
    """Pure numpy: class code (ORBIT_CLASSES) of each orbit from its flags."""
    ok = np.asarray(ok, bool)
    p1 = ok & (np.asarray(period) == 1)
    p2 = ok & (np.asarray(period) == 2)
    s = np.asarray(stable, bool)
    lc = np.asarray(loses, bool)
    code = np.zeros(ok.shape, np.int8)
    code[p1 & s & ~lc] = 1
    code[p2 & s & ~lc] = 2
    code[p2 & s & lc] = 3
    code[p2 & ~s & ~lc] = 4
    code[p2 & ~s & lc] = 5
    code[p1 & s & lc] = 6
    code[p1 & ~s & ~lc] = 7
    code[p1 & ~s & lc] = 8
    return code


def _class_flag_attrs() -> dict[str, Any]:
    return {"flag_values": np.array([c for c, _, _ in ORBIT_CLASSES], np.int8),
            "flag_meanings": " ".join(n for _, n, _ in ORBIT_CLASSES)}


#: Two slots hold the same orbit when their period, min q and max q agree to this (relative).
SAME_ORBIT_TOL = 1e-6


def valid_orbits(ds: xr.Dataset) -> xr.DataArray:
    """Bool (omega, sigma, zeta, solution): converged slots that are not duplicates.

    The block solver may store one 1T orbit twice: once from a 1T solve and once from a 2T solve
    that landed on it (minimal period 1), the latter with the multipliers of the 2T map (the
    squares of the 1T ones). Such slots agree in period, min q and max q; the one whose
    multipliers satisfy Liouville's formula over one period (det M = exp(-2 zeta P)) is kept,
    else the first. Products count and classify valid orbits only.
    """
    ds = ds.transpose("omega", "sigma", "zeta", "solution", ...)
    ok = (ds["status"] == 0).values
    n_slots = ok.shape[-1]
    if "min_q" not in ds or n_slots < 2:
        return xr.DataArray(ok, dims=ds["status"].dims, coords=ds["status"].coords)
    per = ds["period"].values.astype(int)
    lo = ds["min_q"].values
    hi = ds["max_q"].values
    mult = ds["multipliers"].values
    det = (mult[..., 0] * mult[..., 1]).real
    om = ds["omega"].values[:, None, None, None]
    ze = ds["zeta"].values[None, None, :, None]
    with np.errstate(all="ignore"):
        liouville = np.abs(det - np.exp(-2.0 * ze * per * 2.0 * np.pi / om))
    valid = ok.copy()
    for j in range(1, n_slots):
        for i in range(j):
            tol = SAME_ORBIT_TOL * (1.0 + np.abs(hi[..., i] - lo[..., i]))
            with np.errstate(invalid="ignore"):
                same = (ok[..., i] & ok[..., j] & (per[..., i] == per[..., j])
                        & (np.abs(lo[..., i] - lo[..., j]) <= tol)
                        & (np.abs(hi[..., i] - hi[..., j]) <= tol))
            same &= valid[..., i] & valid[..., j]
            # keep the slot that satisfies Liouville over its period (ties: the first)
            j_better = same & (liouville[..., j] < liouville[..., i])
            valid[..., i] &= ~j_better
            valid[..., j] &= ~(same & ~j_better)
    return xr.DataArray(valid, dims=ds["status"].dims, coords=ds["status"].coords)


def orbit_classes(ds: xr.Dataset) -> xr.DataArray:
    """Class of every slot (omega, sigma, zeta, solution), int8 codes of :data:`ORBIT_CLASSES`.

    Needs ``loses_contact`` (the ``measures`` output); without it contact loss is read as False.
    Duplicated slots (see :func:`valid_orbits`) get class 0.
    """
    loses = ds["loses_contact"] if "loses_contact" in ds else xr.zeros_like(ds["stable"])
    code = _class_codes(valid_orbits(ds).values, ds["period"].values, ds["stable"].values,
                        loses.values)
    da = xr.DataArray(code, dims=ds["status"].dims, coords=ds["status"].coords, name="orbit_class")
    da.attrs = _attrs("orbit class", "1",
                      "class of the orbit in the slot; 1-5 are the classes I-V of paper Fig. 6; "
                      + "; ".join(f"{c}: {d}" for c, _, d in ORBIT_CLASSES),
                      **_class_flag_attrs())
    return da


def _first_1t(ds: xr.Dataset, name: str, valid: xr.DataArray) -> xr.DataArray:
    """Variable of the first valid 1T slot (the 1T orbit of smallest ptp; slots are in ptp order
    within a period), NaN where there is none."""
    one = valid & (ds["period"] == 1)
    first = one.argmax("solution")
    return ds[name].isel(solution=first).where(one.any("solution")).drop_vars(
        "solution", errors="ignore")


def _flip_indicator(mult: xr.DataArray) -> xr.DataArray:
    """(1 + mu1)(1 + mu2) = 1 + tr M + det M, real; negative past a flip (one mu < -1)."""
    m1 = mult.isel(multiplier=0)
    m2 = mult.isel(multiplier=1)
    return ((1 + m1) * (1 + m2)).real


def isola_mask(exists_2t: np.ndarray, flip_past: np.ndarray,
               loses_2t: np.ndarray | None = None) -> np.ndarray:
    """Heuristic isolas of 2T responses on a grid whose first axis is omega.

    Along each line of constant (sigma, zeta), a contiguous run of omega points where a 2T
    response exists is *flip-born* when it contains a point where the 1T response is past its
    flip (a multiplier below -1, ``flip_past``); otherwise it is an *isola* (paper Fig. 8-9),
    provided one of its 2T orbits loses contact (``loses_2t``, if given). Returns a bool array
    like ``exists_2t``.

    This is a grid heuristic, not continuation: a run is judged as a whole, so where an isola
    and the flip-born branch overlap or touch in omega (above the transcritical point, paper
    Fig. 10) the isola is counted as flip-born, and a gap narrower than the grid step joins two
    runs. Exact isola boundaries (2T saddle-node curves) come from continuation.
    """
    from scipy import ndimage

    exists_2t = np.asarray(exists_2t, bool)
    flip_past = np.asarray(flip_past, bool)
    if exists_2t.ndim == 0 or not exists_2t.any():
        return np.zeros_like(exists_2t)
    structure = np.zeros((3,) * exists_2t.ndim, bool)
    structure[(slice(None),) + (1,) * (exists_2t.ndim - 1)] = True   # neighbours along omega only
    labels, n = ndimage.label(exists_2t, structure=structure)
    tied = np.zeros(n + 1, bool)
    tied[np.unique(labels[flip_past & exists_2t])] = True
    tied[0] = True
    iso = ~tied[labels]
    if loses_2t is not None:
        lc = np.zeros(n + 1, bool)
        lc[np.unique(labels[np.asarray(loses_2t, bool) & exists_2t])] = True
        iso &= lc[labels]
    return iso


def loss_of_contact_map(ds: xr.Dataset) -> xr.Dataset:
    """Per grid point (omega, sigma, zeta): the responses, their classes and contact measures.

    Variables: ``computed``, ``stable_set`` (bit mask of the kinds of stable response present),
    ``class_count`` (orbits per class, dim ``orbit_class``), ``n_orbits``, ``n_stable``,
    ``n_1T``, ``n_2T``, ``contact_loss_possible`` (a stable orbit loses contact),
    ``contact_loss_certain`` (every stable orbit does), ``flight_fraction`` and
    ``max_impact_velocity`` (largest over the stable responses), ``isola_2T`` (heuristic), and
    the indicators contoured by :func:`bifurcation_curves`: ``flip_indicator_1T``,
    ``contact_margin_1T``, ``contact_margin_2T``, ``exists_2T``, ``coexist_1T``.
    """
    if "computed" not in ds:
        ds = open_store(ds)
    ok = valid_orbits(ds)
    stable = ok & ds["stable"]
    loses = ds["loses_contact"] if "loses_contact" in ds else xr.zeros_like(ds["stable"])
    p1 = ok & (ds["period"] == 1)
    p2 = ok & (ds["period"] == 2)
    cls = orbit_classes(ds)
    q_lost = contact_threshold(ds)

    out = xr.Dataset(coords={d: ds[d] for d in ("omega", "sigma", "zeta")})
    out["computed"] = ds["computed"]

    bits = ((stable & p1 & ~loses).any("solution").astype("uint8") * 1
            + (stable & p1 & loses).any("solution").astype("uint8") * 2
            + (stable & p2 & ~loses).any("solution").astype("uint8") * 4
            + (stable & p2 & loses).any("solution").astype("uint8") * 8)
    out["stable_set"] = bits.astype("uint8").assign_attrs(_attrs(
        "kinds of stable response", "1",
        "bit mask of the kinds of stable periodic response at the point: 1 stable 1T in contact, "
        "2 stable 1T with loss of contact, 4 stable 2T in contact, 8 stable 2T with loss of "
        "contact; 0: no stable periodic response found (or not computed)",
        flag_masks=np.array([b for b, _ in STABLE_SET_FLAGS], np.uint8),
        flag_meanings=" ".join(m for _, m in STABLE_SET_FLAGS)))

    codes = np.array([c for c, _, _ in ORBIT_CLASSES[1:]], np.int8)
    counts = np.stack([(cls.values == c).sum(-1) for c in codes], axis=-1).astype(np.int8)
    out["class_count"] = xr.DataArray(counts, dims=("omega", "sigma", "zeta", "orbit_class"),
                                      coords={"orbit_class": codes})
    out["class_count"].attrs = _attrs(
        "orbits per class", "1", "number of distinct orbits of each class found at the point")
    out["orbit_class"].attrs = _attrs(
        "orbit class", "1", "; ".join(f"{c}: {d}" for c, _, d in ORBIT_CLASSES[1:]),
        flag_values=codes, flag_meanings=" ".join(n for _, n, _ in ORBIT_CLASSES[1:]))

    def count(mask, long_name, desc):
        return mask.sum("solution").astype("int8").assign_attrs(_attrs(long_name, "1", desc))

    out["n_orbits"] = count(ok, "coexisting periodic responses",
                            "number of distinct periodic orbits (1T and 2T) found at the point")
    out["n_stable"] = count(stable, "coexisting stable responses",
                            "number of distinct stable periodic orbits (multistability if >= 2)")
    out["n_1T"] = count(p1, "1T responses", "number of distinct 1T orbits")
    out["n_2T"] = count(p2, "2T responses", "number of distinct 2T orbits")
    has_stable = stable.any("solution")
    out["contact_loss_possible"] = (stable & loses).any("solution").assign_attrs(_attrs(
        "a stable response loses contact", "1",
        "True where at least one stable periodic response loses contact"))
    out["contact_loss_certain"] = (has_stable & ~(stable & ~loses).any("solution")).assign_attrs(
        _attrs("every stable response loses contact", "1",
               "True where stable responses exist and all of them lose contact"))
    with _quiet(), np.errstate(all="ignore"):
        if "flight_fraction" in ds:
            ff = ds["flight_fraction"].where(stable).fillna(-1.0).max("solution")
            out["flight_fraction"] = ff.where(ff >= 0).assign_attrs(_attrs(
                "largest flight fraction of the stable responses", "1",
                "largest fraction of the period spent out of contact over the stable responses "
                "at the point (0: all in contact; NaN: no stable response)"))
        if "max_impact_velocity" in ds:
            iv = xr.where(stable & ~loses, 0.0, ds["max_impact_velocity"].where(stable & loses))
            iv = iv.fillna(-1.0).max("solution")
            out["max_impact_velocity"] = iv.where(iv >= 0).assign_attrs(_attrs(
                "largest impact velocity of the stable responses", "1",
                "largest |dq/dtau| at recontact over the stable responses at the point "
                "(0: all in contact; NaN: no stable response)"))

    out["flip_indicator_1T"] = _flip_indicator(_first_1t(ds, "multipliers", ok)).assign_attrs(_attrs(
        "flip indicator of the 1T response", "1",
        "(1 + mu1)(1 + mu2) = 1 + tr M + det M of the 1T orbit of smallest ptp; negative past a flip (one multiplier below -1), zero on the flip curve"))
    if "min_q" in ds:
        out["contact_margin_1T"] = (_first_1t(ds, "min_q", ok) - q_lost).assign_attrs(_attrs(
            "contact margin of the 1T response", "1",
            "min q - q_lost of the 1T orbit of slot 0 (q_lost = -n); negative: contact is lost"))
        sel = stable & p2
        ptp = ds["ptp"].where(sel).fillna(-np.inf)
        idx = ptp.argmax("solution")
        m2 = ds["min_q"].isel(solution=idx).where(sel.any("solution")) - q_lost
        out["contact_margin_2T"] = m2.assign_attrs(_attrs(
            "contact margin of the stable 2T response", "1",
            "min q - q_lost of the stable 2T orbit of largest ptp; negative: contact is lost"))
    out["exists_2T"] = p2.any("solution").astype("int8").assign_attrs(_attrs(
        "a 2T response exists", "1", "1 where a 2T orbit (stable or not) was found, else 0"))
    out["coexist_1T"] = ((p1.sum("solution") >= 2).astype("int8")).assign_attrs(_attrs(
        "coexisting 1T responses", "1", "1 where two or more 1T orbits were found, else 0"))

    # isolas (heuristic, along omega lines)
    iso = isola_mask(out["exists_2T"].values.astype(bool), (out["flip_indicator_1T"] < 0).values,
                     (p2 & loses).any("solution").values)
    out["isola_2T"] = xr.DataArray(iso, dims=("omega", "sigma", "zeta")).assign_attrs(_attrs(
        "2T response on an isola", "1",
        "heuristic: the point lies in a contiguous omega run of 2T responses (at fixed sigma, "
        "zeta) that contains no point past the 1T flip and has a 2T orbit with contact loss "
        "(study.products.isola_mask)"))
    out.attrs = _source_attrs(ds, "loss-of-contact map")
    out = out.drop_vars([c for c in ("solution", "multiplier") if c in out.coords])
    return _coord_attrs(out, ds)


# ---------------------------------------------------------------------------------------------
# curves (contours of grid indicators)
# ---------------------------------------------------------------------------------------------

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
        "curve": ("vertex", cat[3], _attrs(
            "curve kind", "1", "; ".join(f"{c}: {n}: {d}" for c, n, _, _, d in CURVES),
            flag_values=np.array([c for c, *_ in CURVES], np.int8),
            flag_meanings=" ".join(n for _, n, *_ in CURVES))),
        "segment": ("vertex", cat[4], _attrs(
            "line id", "1", "id of the connected line the vertex belongs to (vertices in order)")),
    })
    out.attrs = {k: v for k, v in lcm.attrs.items() if k.startswith("hertzmap") or k in
                 ("model", "exponent")}
    out.attrs["title"] = "bifurcation and grazing curves contoured from the grid"
    out.attrs["method"] = ("contourpy lines of grid indicators (linear interpolation between grid "
                           "points); see the curve attrs")
    return out


#: Codes of ``bifurcation_kind`` (study/dataset.py), by name.
LOCATED_KINDS = {1: "fold", 2: "flip", 3: "grazing"}


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
        "omega": ("vertex", arr["omega"], _attrs(
            "excitation frequency", "1", "omega of the located point (solver accuracy)")),
        "sigma": ("vertex", arr["sigma"], _attrs(
            "excitation amplitude", "1", "sigma of the grid line the point was located on")),
        "zeta": ("vertex", arr["zeta"], _attrs("damping ratio", "1", "zeta of the grid line")),
        "kind": ("vertex", arr["kind"], _attrs(
            "kind of bifurcation point", "1", "1 fold, 2 flip, 3 grazing (as bifurcation_kind)",
            flag_values=np.array(sorted(LOCATED_KINDS), np.int8),
            flag_meanings=" ".join(LOCATED_KINDS[c] for c in sorted(LOCATED_KINDS)))),
        "period": ("vertex", arr["period"], _attrs(
            "period of the branch", "1", "1: 1T orbit, 2: 2T orbit")),
        "q0": ("vertex", arr["q0"], _attrs("displacement at tau = 0", "1",
                                           "start point of the orbit at the located point")),
        "v0": ("vertex", arr["v0"], _attrs("velocity at tau = 0", "1",
                                           "start point of the orbit at the located point")),
        "segment": ("vertex", arr["segment"], _attrs(
            "curve id", "1", "id of the curve the vertex belongs to (vertices ordered by sigma)")),
    })
    out.attrs = _source_attrs(ds, "bifurcation curves assembled from located points")
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


# ---------------------------------------------------------------------------------------------
# multiple scales (analytic)
# ---------------------------------------------------------------------------------------------

def mms_curves(omega: Iterable[float], zeta: Iterable[float]) -> xr.Dataset:
    """MMS thresholds on an omega grid: sigma1 (Eq. 25a), sigma2 (Eq. 25b, implicit, derived
    gamma), region boundaries of paper Fig. 3; and sigma* per zeta (Eq. 26, and the minimum of
    sigma2). Dims (omega, zeta)."""
    from study import multiple_scales as mms

    om = np.asarray(list(omega), float)
    zt = np.atleast_1d(np.asarray(list(zeta) if not np.isscalar(zeta) else [zeta], float))
    W, Z = np.meshgrid(om, zt, indexing="ij")
    with np.errstate(all="ignore"):
        s1 = np.asarray(mms.sigma1(W, Z), float)
        s2 = np.asarray(mms.sigma2(W, Z), float)
        # sigma1 bounds region II only on the softening side: left of the minimum of sigma2
        # (where the two curves meet), and where it lies below sigma2
        w_min = om[np.nanargmin(np.where(np.isfinite(s2), s2, np.inf), axis=0)] if om.size else 2.0
        s1 = np.where(np.isfinite(s2) & (s1 <= s2) & (W <= w_min[None, :]), s1, np.nan)
        star = np.asarray(mms.sigma_star(zt, "paper"), float)
        smin = np.asarray(mms.sigma_star(zt, "min"), float)
    out = xr.Dataset(
        {"sigma1": (("omega", "zeta"), s1, _attrs(
            "MMS saddle-node threshold sigma1", "1",
            "Eq. 25a, 2 zeta / |beta|: lower bound of region II (drawn on the softening side, "
            "left of the minimum of sigma2)")),
         "sigma2": (("omega", "zeta"), s2, _attrs(
             "MMS flip threshold sigma2", "1",
             "Eq. 25b solved exactly as an implicit equation, with the re-derived gamma (Eq. 22, "
             "see docs/analytic.md)")),
         "sigma_star": (("zeta",), np.broadcast_to(star, zt.shape).copy(), _attrs(
             "MMS threshold sigma*", "1", "Eq. 26 as printed: 36 zeta / (1 + 16 zeta^2 / 9)")),
         "sigma_star_min": (("zeta",), np.broadcast_to(smin, zt.shape).copy(), _attrs(
             "minimum of the MMS flip curve", "1", "min over omega of sigma2 (derived gamma)"))},
        coords={"omega": ("omega", om, _attrs("excitation frequency", "1",
                                              "dimensionless excitation frequency")),
                "zeta": ("zeta", zt, _attrs("damping ratio", "1", "damping ratio"))})
    out.attrs = {"title": "multiple-scales thresholds (paper Eq. 25-27, Fig. 3, 7, 9)"}
    return out


def mms_response(omega: Iterable[float], sigma: float, zeta: float) -> xr.Dataset:
    """MMS frequency response at one (sigma, zeta): A (Eq. 23) and min q (Fig. 5) of the upper
    (stable) and lower (unstable) branches, and the region (Fig. 3). Dim omega."""
    from study import multiple_scales as mms

    om = np.asarray(list(omega), float)
    with np.errstate(all="ignore"):
        data = {}
        for br in ("upper", "lower"):
            data[f"A_{br}"] = (("omega",), np.asarray(mms.amplitude(om, sigma, zeta, br), float),
                               _attrs(f"MMS subharmonic amplitude, {br} branch", "1",
                                      f"A of Eq. 23, {br} (" + ("stable" if br == "upper" else
                                                                "unstable") + ") root"))
            data[f"min_q_{br}"] = (("omega",), np.asarray(mms.min_response(om, sigma, zeta, br),
                                                          float),
                                   _attrs(f"MMS minimum of q, {br} branch", "1",
                                          "minimum over 2T of the response Eq. 19 (Fig. 5)"))
        data["region"] = (("omega",), np.asarray(mms.region(om, sigma, zeta), np.int8), _attrs(
            "MMS region", "1", "region of paper Fig. 3 (1: I, 2: II, 3: III)",
            flag_values=np.array([1, 2, 3], np.int8), flag_meanings="I II III"))
    out = xr.Dataset(data, coords={"omega": ("omega", om, _attrs(
        "excitation frequency", "1", "dimensionless excitation frequency"))})
    out.attrs = {"title": "multiple-scales frequency response (paper Fig. 4, 5)",
                 "sigma": float(sigma), "zeta": float(zeta),
                 "taylor_contact_loss": TAYLOR_CONTACT_LOSS}
    return out


# ---------------------------------------------------------------------------------------------
# frequency responses, force harmonics, time histories
# ---------------------------------------------------------------------------------------------

def _add_frequency_hz(out: xr.Dataset, rig) -> xr.Dataset:
    if rig is None:
        return out
    out = out.assign_coords(frequency_hz=("omega", np.asarray(rig.omega_to_frequency(
        out["omega"].values), float), _attrs(
        "excitation frequency", "Hz", f"omega f0, f0 = {rig.f0:.6g} Hz (study's [rig])")))
    out.attrs.update({"rig_f0_hz": rig.f0, "rig_N": rig.N, "rig_m": rig.m, "rig_k": rig.k,
                      "rig_z_s": rig.z_s})
    return out


def frequency_response(ds: xr.Dataset, sigma: float | None = None, zeta: float | None = None,
                       *, rig=None) -> xr.Dataset:
    """Response curves against omega (paper Fig. 6, 8, 10): ptp, min q, max q, period, stable,
    loses_contact and class of every slot; at the nearest (sigma, zeta) if given, else every line.
    Physical units (displacement in m, frequency in Hz) are added when ``rig`` is given."""
    if "computed" not in ds:
        ds = open_store(ds)
    if sigma is not None:
        ds = ds.sel(sigma=[sigma], method="nearest")
    if zeta is not None:
        ds = ds.sel(zeta=[zeta], method="nearest")
    cls = orbit_classes(ds)
    ok = valid_orbits(ds)
    out = xr.Dataset(coords={d: ds[d] for d in ("omega", "sigma", "zeta", "solution")})
    out["orbit_class"] = cls
    for name in ("period", "stable", "ptp", "min_q", "max_q", "loses_contact", "flight_fraction"):
        if name in ds:
            v = ds[name]
            out[name] = (v.where(ok) if v.dtype.kind == "f" else v.where(ok, v.dtype.type(0))
                         ).astype(v.dtype).assign_attrs(v.attrs)
    if rig is not None and "ptp" in out:
        # q = n (z - z_s) / z_s: displacement differences are z_s / n times q differences
        out["ptp_m"] = (out["ptp"] * rig.z_s / rig.n).assign_attrs(_attrs(
            "peak-to-peak displacement", "m", "ptp z_s / n (paper Eq. 5)"))
    out.attrs = _source_attrs(ds, "frequency response curves (paper Fig. 6, 8, 10)")
    out = _add_frequency_hz(out, rig)
    return _coord_attrs(out, ds)


def force_harmonics(ds: xr.Dataset, *, rig=None) -> xr.Dataset:
    """Contact-force harmonic amplitudes on a common frequency axis (Fig. 12-13).

    The store's ``force_harmonics`` are at k omega / period (k = 1..4): for a 1T orbit at
    omega, 2 omega, 3 omega, 4 omega, for a 2T orbit at omega/2, omega, 3 omega/2, 2 omega. They
    are placed on ``ratio`` = frequency / excitation frequency in (0.5, 1, 1.5, 2); a 1T orbit
    has no component at 0.5 and 1.5 (zero). H1 is ratio 1 (excitation frequency), H2 ratio 2;
    ratio 0.5 is the subharmonic, non-zero only on 2T orbits. In N with a rig (F = N * F/N).
    """
    if "force_harmonics" not in ds:
        raise KeyError("the store has no force_harmonics (add it to [products] outputs)")
    if "computed" not in ds:
        ds = open_store(ds)
    ok = valid_orbits(ds).values
    period = ds["period"].values
    fh = ds["force_harmonics"].transpose("omega", "sigma", "zeta", "solution", "harmonic").values
    ratios = np.array([0.5, 1.0, 1.5, 2.0])
    amp = np.full(fh.shape[:4] + (4,), np.nan)
    one = ok & (period == 1)
    two = ok & (period == 2)
    amp[one, 0] = 0.0
    amp[one, 1] = fh[one, 0]
    amp[one, 2] = 0.0
    amp[one, 3] = fh[one, 1]
    amp[two, :] = fh[two, :]
    out = xr.Dataset(
        {"force_amplitude": (("omega", "sigma", "zeta", "solution", "ratio"), amp, _attrs(
            "contact force harmonic amplitude", "1",
            "amplitude of F/N at the frequency ratio x omega (F_exp has the same harmonics, "
            "paper Eq. 30)")),
         "orbit_class": orbit_classes(ds),
         "stable": ds["stable"] & valid_orbits(ds)},
        coords={d: ds[d] for d in ("omega", "sigma", "zeta", "solution")})
    out = out.assign_coords(ratio=("ratio", ratios, _attrs(
        "frequency ratio", "1", "frequency of the component / excitation frequency")))
    if rig is not None:
        out["force_amplitude_N"] = (out["force_amplitude"] * rig.N).assign_attrs(_attrs(
            "contact force harmonic amplitude", "N", "N times force_amplitude"))
    out.attrs = _source_attrs(ds, "contact-force harmonics (numerical counterpart of Fig. 12-13)")
    out = _add_frequency_hz(out, rig)
    return _coord_attrs(out, ds)


def time_histories(ds: xr.Dataset, omegas: Iterable[float] | None = None,
                   sigma: float | None = None, zeta: float | None = None, *, cycles: float = 4.0,
                   samples_per_cycle: int = 128, stable_only: bool = True, rig=None
                   ) -> xr.Dataset:
    """F_exp(t) = F/N - 1 (paper Eq. 30) over ``cycles`` forcing periods of the stored orbits.

    For each requested omega (nearest grid value; default all) at the nearest (sigma, zeta), every
    (stable, by default) converged orbit is integrated from its start point with
    ``kernels.simulate`` at the store's rtol. Dims (case, time); ``time`` is omega tau / 2 pi
    (forcing cycles, the paper's axis); with a rig, ``t_s`` (seconds) and ``force_N`` are added.
    """
    from kernels import simulate

    if "computed" not in ds:
        ds = open_store(ds)
    ds = ds.sel(sigma=sigma if sigma is not None else ds["sigma"].values[0], method="nearest")
    ds = ds.sel(zeta=zeta if zeta is not None else ds["zeta"].values[0], method="nearest")
    om_all = ds["omega"].values
    if omegas is None:
        idx = list(range(om_all.size))
    else:
        idx = [int(np.argmin(np.abs(om_all - w))) for w in omegas]
    n = exponent_of(ds)
    model = ds.attrs.get("model", "hertz")
    rtol = float(ds.attrs.get("rtol", 1e-10))
    cyc = np.linspace(0.0, cycles, int(round(cycles * samples_per_cycle)) + 1)
    valid = valid_orbits(ds.expand_dims(["sigma", "zeta"])).isel(sigma=0, zeta=0).transpose(
        "omega", "solution")
    cases = []
    for i in idx:
        w = float(om_all[i])
        for s in range(ds.sizes["solution"]):
            slot = ds.isel(omega=i, solution=s)
            if not bool(valid.values[i, s]) or (stable_only and not bool(slot["stable"])):
                continue
            T = 2 * np.pi / w
            r = simulate(w, float(ds["sigma"]), float(ds["zeta"]),
                         (float(slot["q0"]), float(slot["v0"])), t_end=cycles * T,
                         t_eval=cyc * T, exponent=n, model=model, rtol=rtol)
            cases.append((w, s, int(slot["period"]), bool(slot["stable"]),
                          r["force"] - 1.0, r["q"], float(slot["ptp"]) if "ptp" in slot else np.nan))
    nc = len(cases)
    fexp = np.array([c[4] for c in cases]).reshape(nc, cyc.size)
    q = np.array([c[5] for c in cases]).reshape(nc, cyc.size)
    out = xr.Dataset(
        {"F_exp": (("case", "time"), fexp, _attrs(
            "dimensionless normal force F_exp", "1",
            "(F - N) / N, paper Eq. 30 (F/N - 1; -1 in flight)")),
         "q": (("case", "time"), q, _attrs("displacement", "1", "q(tau)"))},
        coords={"time": ("time", cyc, _attrs("dimensionless time", "1",
                                             "omega tau / 2 pi: forcing cycles (paper Fig. 14-15)")),
                "omega": ("case", np.array([c[0] for c in cases], float),
                          dict(ds["omega"].attrs)),
                "solution": ("case", np.array([c[1] for c in cases], np.int16),
                             dict(ds["solution"].attrs)),
                "period": ("case", np.array([c[2] for c in cases], np.int8), _attrs(
                    "period of the orbit", "1", "in forcing periods")),
                "stable": ("case", np.array([c[3] for c in cases], bool), _attrs(
                    "orbit is stable", "1", "both multipliers inside the unit circle")),
                "ptp": ("case", np.array([c[6] for c in cases], float), _attrs(
                    "peak-to-peak displacement", "1", "max q - min q of the orbit"))})
    out.attrs = _source_attrs(ds, "time histories of F_exp (numerical counterpart of Fig. 14-15)")
    out.attrs.update({"sigma": float(ds["sigma"]), "zeta": float(ds["zeta"])})
    if rig is not None and nc:
        out = out.assign_coords(t_s=(("case", "time"), cyc[None, :] * 2 * np.pi
                                     / out["omega"].values[:, None] / rig.Omega, _attrs(
                                         "time", "s", "tau / Omega (paper Eq. 6)")))
        out["force_N"] = (rig.N * (1.0 + out["F_exp"])).assign_attrs(_attrs(
            "contact force", "N", "N (1 + F_exp)"))
        out = out.assign_coords(frequency_hz=("case", np.asarray(rig.omega_to_frequency(
            out["omega"].values), float), _attrs("excitation frequency", "Hz", "omega f0")))
        out.attrs.update({"rig_f0_hz": rig.f0, "rig_N": rig.N})
    return out


# ---------------------------------------------------------------------------------------------
# derived numbers (VALIDATION.md)
# ---------------------------------------------------------------------------------------------

def flip_minimum(lcm: xr.Dataset, zeta: float) -> tuple[float, float]:
    """(omega, sigma) of the lowest point of the numerical flip curve at ``zeta`` (sigma*).

    On each omega line of the grid, the lowest sigma where ``flip_indicator_1T`` changes sign
    (+ to -) is interpolated linearly; a parabola through the lowest such crossing and its two
    neighbours gives the minimum (accurate when the omega step is below about zeta)."""
    m = lcm.sel(zeta=zeta, method="nearest")
    f = m["flip_indicator_1T"].transpose("omega", "sigma").values
    om, sg = m["omega"].values, m["sigma"].values
    cross = np.full(om.size, np.nan)
    for i in range(om.size):
        with np.errstate(invalid="ignore"):
            k = np.flatnonzero((f[i, :-1] > 0) & (f[i, 1:] <= 0))
        if k.size:
            j = k[0]
            cross[i] = sg[j] + (sg[j + 1] - sg[j]) * f[i, j] / (f[i, j] - f[i, j + 1])
    if not np.isfinite(cross).any():
        return (np.nan, np.nan)
    i = int(np.nanargmin(cross))
    if 0 < i < om.size - 1 and np.isfinite(cross[i - 1:i + 2]).all():
        a, b, c = np.polyfit(om[i - 1:i + 2], cross[i - 1:i + 2], 2)
        if a > 0:
            w = -b / (2 * a)
            return float(w), float(c - b * b / (4 * a))
    return float(om[i]), float(cross[i])


def branch_end(fr: xr.Dataset, classes: Iterable[int] = (2, 3), side: str = "low"
               ) -> float:
    """Lowest (``side="low"``) or highest omega of a line where an orbit of the given classes
    exists (default: stable 2T), e.g. the downward jump of paper Fig. 6 (accurate to one step)."""
    c = fr["orbit_class"].values
    has = np.isin(c, list(classes)).any(axis=tuple(range(1, c.ndim)))
    om = fr["omega"].values[has]
    if om.size == 0:
        return float("nan")
    return float(om.min() if side == "low" else om.max())


# ---------------------------------------------------------------------------------------------
# storing products
# ---------------------------------------------------------------------------------------------

def _lock_file(store: Path) -> Path:
    return store.with_name(store.name + ".lock")


def write_product(store: str | Path, name: str, product: xr.Dataset) -> str:
    """Write a product into the store as the zarr group ``products/<name>`` (replacing it).

    Only that group is written: the main group's arrays and attrs are untouched (zarr's
    consolidated metadata at the root is refreshed to list the group). Refused while a
    ``hertzmap run`` holds the store's lock. Returns the group path.
    """
    store = Path(store)
    if not (store / "zarr.json").is_file():
        raise FileNotFoundError(f"{store} is not a zarr store")
    if _lock_file(store).exists():
        raise RuntimeError(f"{store} is locked by a running hertzmap run ({_lock_file(store)}); "
                           "write products when it has finished")
    if not name or "/" in name or name.startswith("."):
        raise ValueError(f"invalid product name {name!r}")
    group = f"{PRODUCT_GROUP}/{name}"
    product = product.copy()
    product.attrs = {k: (json.dumps(v) if isinstance(v, (dict, list)) else v)
                     for k, v in product.attrs.items()}
    for v in product.variables.values():
        v.encoding = {}
    with _quiet():
        product.to_zarr(str(store), group=group, mode="w", consolidated=True)
    return group


def read_product(store: str | Path, name: str) -> xr.Dataset:
    """A stored product, in memory."""
    with _quiet():
        return xr.open_zarr(str(store), group=f"{PRODUCT_GROUP}/{name}", chunks=None).load()


def list_products(store: str | Path) -> list[str]:
    """Names of the products stored in a store."""
    root = Path(store) / PRODUCT_GROUP
    if not root.is_dir():
        return []
    return sorted(p.name for p in root.iterdir() if (p / "zarr.json").is_file())


def compute_products(store: str | Path | xr.Dataset, *, write: bool = True,
                     max_lines: int = 16) -> dict[str, xr.Dataset]:
    """Every product that the store supports, optionally written back into it.

    Always: ``orbit_classes``, ``loss_of_contact_map``, ``bifurcation_curves`` (empty for line
    studies), ``mms_curves``. When the study has at most ``max_lines`` (sigma, zeta) lines:
    ``frequency_response`` and, per line, ``mms_response``. With ``force_harmonics`` stored:
    ``force_harmonics``. With ``bifurcations`` stored: ``located_bifurcations``. Physical units where the study has a ``[rig]`` table.
    """
    ds = open_store(store)
    rig = rig_of(ds)
    out: dict[str, xr.Dataset] = {}
    cls = orbit_classes(ds)
    out["orbit_classes"] = cls.to_dataset().assign_attrs(_source_attrs(ds, "orbit classes"))
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
        fine = np.linspace(a, b, 801) if a < b else None
        if fine is not None:
            resp = [mms_response(fine, float(s), float(z)).expand_dims(sigma=[float(s)],
                                                                       zeta=[float(z)])
                    for s in ds["sigma"].values for z in ds["zeta"].values]
            m = xr.combine_by_coords([r.drop_attrs(deep=False) for r in resp])
            m.attrs = {"title": "multiple-scales frequency response (paper Fig. 4, 5)",
                       "taylor_contact_loss": TAYLOR_CONTACT_LOSS}
            out["mms_response"] = m
    if "force_harmonics" in ds:
        out["force_harmonics"] = force_harmonics(ds, rig=rig)
    if write and not isinstance(store, xr.Dataset):
        for name, prod in out.items():
            write_product(store, name, prod)
    return out
