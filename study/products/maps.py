"""The loss-of-contact map: per grid point, which stable responses exist, how many orbits of each
class, whether contact is lost and how hard the impacts are; and the smooth indicators that
the curves are contoured from (flip, grazing, 2T existence)."""
from __future__ import annotations

import numpy as np
import xarray as xr

from hertzmap.study.orbit_rules import ORBIT_CLASSES
from hertzmap.study.schema import ATTRACTOR_KINDS
from hertzmap.study.products.classes import orbit_classes, valid_orbits
from hertzmap.study.products.results import (var_attrs, coord_attrs, quiet, source_attrs,
                                    contact_threshold, open_store)

#: Bits of ``stable_set``: which kinds of stable response exist at a point.
STABLE_SET_FLAGS: tuple[tuple[int, str], ...] = (
    (1, "stable_1T_contact"),
    (2, "stable_1T_contact_loss"),
    (4, "stable_2T_contact"),
    (8, "stable_2T_contact_loss"),
)


#: Codes of ``map_class`` beyond the 16 combinations of the stable_set bits (1T/2T, in contact or
#: not): what the contact does where longer periods or no periodic attractor are involved.
MAP_CLASS_LONGER = 16
MAP_CLASS_CHAOTIC = 17
MAP_CLASS_UNSETTLED = 18
MAP_CLASS_CHAOTIC_COEXISTING = 19
MAP_CLASSES: tuple[tuple[int, str, str], ...] = tuple(
    (c, "stable_" + "_".join(m.removeprefix("stable_") for b, m in STABLE_SET_FLAGS if c & b)
     if c else "none",
     "stable: " + ", ".join(m for b, m in STABLE_SET_FLAGS if c & b) if c else
     "no stable response found (or not computed)") for c in range(16)) + (
    (MAP_CLASS_LONGER, "stable_period_m_ge_3",
     "a stable orbit of period m >= 3 and no stable 1T or 2T one (beside them: their code, "
     "and stable_longer)"),
    (MAP_CLASS_CHAOTIC, "non_periodic",
     "no stable orbit; the census's transients are chaotic (positive Lyapunov exponent)"),
    (MAP_CLASS_UNSETTLED, "unsettled",
     "no stable orbit; the census's transients did not settle and are not shown chaotic"),
    (MAP_CLASS_CHAOTIC_COEXISTING, "non_periodic_and_stable",
     "a non-periodic attractor beside stable orbits"),
)


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
    out["stable_set"] = bits.astype("uint8").assign_attrs(var_attrs(
        "kinds of stable response", "1",
        "bit mask of the kinds of stable periodic response at the point: 1 stable 1T in contact, "
        "2 stable 1T with loss of contact, 4 stable 2T in contact, 8 stable 2T with loss of "
        "contact; 0: no stable periodic response found (or not computed)",
        flag_masks=np.array([b for b, _ in STABLE_SET_FLAGS], np.uint8),
        flag_meanings=" ".join(m for _, m in STABLE_SET_FLAGS)))

    codes = np.array([c for c, _, _ in ORBIT_CLASSES[1:]], np.int8)
    counts = np.stack([(cls.values == c).sum(-1) for c in codes], axis=-1).astype(np.int16)
    out["class_count"] = xr.DataArray(counts, dims=("omega", "sigma", "zeta", "orbit_class"),
                                      coords={"orbit_class": codes})
    out["class_count"].attrs = var_attrs(
        "orbits per class", "1", "number of distinct orbits of each class found at the point")
    out["orbit_class"].attrs = var_attrs(
        "orbit class", "1", "; ".join(f"{c}: {d}" for c, _, d in ORBIT_CLASSES[1:]),
        flag_values=codes, flag_meanings=" ".join(n for _, n, _ in ORBIT_CLASSES[1:]))

    def count(mask, long_name, desc):
        return mask.sum("solution").astype("int16").assign_attrs(var_attrs(long_name, "1", desc))

    out["n_orbits"] = count(ok, "coexisting periodic responses",
                            "number of distinct periodic orbits (1T and 2T) found at the point")
    out["n_stable"] = count(stable, "coexisting stable responses",
                            "number of distinct stable periodic orbits (multistability if >= 2)")
    out["n_1T"] = count(p1, "1T responses", "number of distinct 1T orbits")
    out["n_2T"] = count(p2, "2T responses", "number of distinct 2T orbits")
    has_stable = stable.any("solution")
    out["contact_loss_possible"] = (stable & loses).any("solution").assign_attrs(var_attrs(
        "a stable response loses contact", "1",
        "True where at least one stable periodic response loses contact"))
    out["contact_loss_certain"] = (has_stable & ~(stable & ~loses).any("solution")).assign_attrs(
        var_attrs("every stable response loses contact", "1",
               "True where stable responses exist and all of them lose contact"))
    with quiet(), np.errstate(all="ignore"):
        if "flight_fraction" in ds:
            ff = ds["flight_fraction"].where(stable).fillna(-1.0).max("solution")
            out["flight_fraction"] = ff.where(ff >= 0).assign_attrs(var_attrs(
                "largest flight fraction of the stable responses", "1",
                "largest fraction of the period spent out of contact over the stable responses "
                "at the point (0: all in contact; NaN: no stable response)"))
        if "max_impact_velocity" in ds:
            iv = xr.where(stable & ~loses, 0.0, ds["max_impact_velocity"].where(stable & loses))
            iv = iv.fillna(-1.0).max("solution")
            out["max_impact_velocity"] = iv.where(iv >= 0).assign_attrs(var_attrs(
                "largest impact velocity of the stable responses", "1",
                "largest |dq/dtau| at recontact over the stable responses at the point "
                "(0: all in contact; NaN: no stable response)"))

    out["flip_indicator_1T"] = _flip_indicator(_first_1t(ds, "multipliers", ok)).assign_attrs(var_attrs(
        "flip indicator of the 1T response", "1",
        "(1 + mu1)(1 + mu2) = 1 + tr M + det M of the 1T orbit of smallest ptp; negative past a flip (one multiplier below -1), zero on the flip curve"))
    if "min_q" in ds:
        out["contact_margin_1T"] = (_first_1t(ds, "min_q", ok) - q_lost).assign_attrs(var_attrs(
            "contact margin of the 1T response", "1",
            "min q - q_lost of the 1T orbit of slot 0 (q_lost = -n); negative: contact is lost"))
        sel = stable & p2
        ptp = ds["ptp"].where(sel).fillna(-np.inf)
        idx = ptp.argmax("solution")
        m2 = ds["min_q"].isel(solution=idx).where(sel.any("solution")) - q_lost
        out["contact_margin_2T"] = m2.assign_attrs(var_attrs(
            "contact margin of the stable 2T response", "1",
            "min q - q_lost of the stable 2T orbit of largest ptp; negative: contact is lost"))
    out["exists_2T"] = p2.any("solution").astype("int8").assign_attrs(var_attrs(
        "a 2T response exists", "1", "1 where a 2T orbit (stable or not) was found, else 0"))
    out["coexist_1T"] = ((p1.sum("solution") >= 2).astype("int8")).assign_attrs(var_attrs(
        "coexisting 1T responses", "1", "1 where two or more 1T orbits were found, else 0"))

    # isolas (heuristic, along omega lines)
    iso = isola_mask(out["exists_2T"].values.astype(bool), (out["flip_indicator_1T"] < 0).values,
                     (p2 & loses).any("solution").values)
    out["isola_2T"] = xr.DataArray(iso, dims=("omega", "sigma", "zeta")).assign_attrs(var_attrs(
        "2T response on an isola", "1",
        "heuristic: the point lies in a contiguous omega run of 2T responses (at fixed sigma, "
        "zeta) that contains no point past the 1T flip and has a 2T orbit with contact loss "
        "(study.products.isola_mask)"))
    _add_attractors(out, ds, ok, stable, loses, bits)
    out.attrs = source_attrs(ds, "loss-of-contact map")
    out = out.drop_vars([c for c in ("solution", "multiplier", "attractor", "strobe")
                         if c in out.coords])
    return coord_attrs(out, ds)


def _add_attractors(out: xr.Dataset, ds: xr.Dataset, ok, stable, loses, bits) -> None:
    """What the contact does at each point (``map_class``), from the stable orbits and the
    attractor census; the largest Lyapunov exponent of the point's attractors; the impact
    severity over every attractor (non-periodic ones included)."""
    longer = (stable & (ds["period"] >= 3)).any("solution").values
    census = ds["attractor_count"].values >= 0 if "attractor_count" in ds else np.zeros(
        longer.shape, bool)
    kinds = ds["attractor_kind"].values if "attractor_kind" in ds else np.zeros(
        longer.shape + (1,), np.int8)
    chaotic = (kinds == ATTRACTOR_KINDS["non_periodic"]).any(-1)
    unsettled = (kinds == ATTRACTOR_KINDS["unsettled"]).any(-1)
    has_stable = stable.any("solution").values
    # where a stable mT orbit coexists with stable 1T / 2T ones the map keeps their kinds (the
    # loss-of-contact map of the paper) and says so in stable_longer
    code = np.where(longer & (bits.values == 0), MAP_CLASS_LONGER,
                    bits.values.astype(np.int8)).astype(np.int8)
    code = np.where(~has_stable & chaotic, MAP_CLASS_CHAOTIC, code)
    code = np.where(~has_stable & ~chaotic & unsettled, MAP_CLASS_UNSETTLED, code)
    code = np.where(has_stable & chaotic, MAP_CLASS_CHAOTIC_COEXISTING, code)
    code = np.where(out["computed"].values, code, 0).astype(np.int8)
    out["stable_longer"] = xr.DataArray(
        (longer & out["computed"].values).astype(np.int8),
        dims=("omega", "sigma", "zeta")).assign_attrs(var_attrs(
            "a stable orbit of period m >= 3", "1",
            "1 where a stable orbit of period m >= 3 exists at the point (alone: map_class 16; "
            "beside stable 1T / 2T ones, whose kinds map_class keeps), else 0"))
    out["map_class"] = xr.DataArray(code, dims=("omega", "sigma", "zeta")).assign_attrs(var_attrs(
        "what the contact does", "1",
        "the kinds of stable response at the point (codes 0-15: the stable_set bits of the 1T "
        "and 2T responses), or: " + "; ".join(f"{c}: {d}" for c, _, d in MAP_CLASSES[16:]),
        flag_values=np.array([c for c, _, _ in MAP_CLASSES], np.int8),
        flag_meanings=" ".join(n for _, n, _ in MAP_CLASSES)))
    # the exponent of every attractor: the census's, else those of the stable orbits
    T = 2.0 * np.pi / ds["omega"]
    with np.errstate(all="ignore"):
        rho = np.abs(ds["multipliers"]).max("multiplier")
        orbit_exp = (np.log(rho) / (ds["period"] * T)).where(stable)
        lam = orbit_exp.max("solution")
        if "lyapunov_exponent" in ds:
            lam_c = ds["lyapunov_exponent"].where(ds["attractor_kind"] > 0).max("attractor")
            lam = xr.where(xr.DataArray(census, dims=lam.dims), lam_c, lam)
    out["lyapunov_exponent"] = lam.where(out["computed"]).assign_attrs(var_attrs(
        "largest Lyapunov exponent of the point's attractors", "1",
        "per unit tau: the largest over the attractors the census found (Benettin over the "
        "record window for a non-periodic one), or, where it did not run, over the stable "
        "orbits (log|mu_max| / (m T)); positive: chaos"))
    if "attractor_max_impact_velocity" in ds:
        iv_a = ds["attractor_max_impact_velocity"].where(ds["attractor_kind"] > 0).max("attractor")
        base = out["max_impact_velocity"] if "max_impact_velocity" in out else xr.full_like(
            iv_a, np.nan)
        out["max_impact_velocity"] = np.fmax(base, iv_a).assign_attrs(var_attrs(
            "largest impact velocity of the point's attractors", "1",
            "largest |dq/dtau| at recontact over the stable orbits and the attractors the "
            "census found (non-periodic ones included) at the point (0: all in contact)"))
        pf = ds["attractor_peak_force"].where(ds["attractor_kind"] > 0).max("attractor")
        out["peak_contact_force"] = pf.assign_attrs(var_attrs(
            "largest peak contact force of the census's attractors", "1",
            "largest F/N over the windows of the attractors the census found at the point "
            "(NaN where it did not run)"))

