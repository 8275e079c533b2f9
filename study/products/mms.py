"""The multiple-scales results as products: the sigma1 / sigma2 thresholds (paper Eq. 25-27,
Fig. 3, 7, 9) and the frequency response A(omega), min q (Fig. 4, 5), from
study.analytic.multiple_scales; :func:`mms_curves_over` and :func:`mms_response_over` over a
study's omega window (the products ``mms_curves`` and ``mms_response``)."""
from __future__ import annotations

from typing import Iterable

import numpy as np
import xarray as xr

from hertzmap.kernels.model import TAYLOR_CONTACT_LOSS
from hertzmap.study.analytic import multiple_scales as mms
from hertzmap.study.products.results import var_attrs

#: MMS curves are computed on |omega - 2| <= MMS_HALF_WIDTH (the expansion is about omega = 2).
MMS_HALF_WIDTH = 0.25
#: omega values of the MMS products of a study, across its window
MMS_POINTS = 801
#: the dim (and coordinate) of the MMS products' own omega grid: not the study's omega axis (a
#: store's product groups share the names of its dims only where they share their values, so
#: that the store opens as one xarray DataTree)
MMS_OMEGA = "mms_omega"


def _omega_attrs() -> dict:
    return var_attrs("excitation frequency", "1", "dimensionless excitation frequency: the "
                     "multiple-scales grid's own values (not the study's omega axis)")


def mms_curves(omega: Iterable[float], zeta: Iterable[float]) -> xr.Dataset:
    """MMS thresholds on an omega grid: sigma1 (Eq. 25a), sigma2 (Eq. 25b, implicit, derived
    gamma), region boundaries of paper Fig. 3; and sigma* per zeta (Eq. 26, and the minimum of
    sigma2). Dims (mms_omega, zeta): ``omega``'s values along :data:`MMS_OMEGA`."""
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
        {"sigma1": ((MMS_OMEGA, "zeta"), s1, var_attrs(
            "MMS saddle-node threshold sigma1", "1",
            "Eq. 25a, 2 zeta / |beta|: lower bound of region II (drawn on the softening side, "
            "left of the minimum of sigma2)")),
         "sigma2": ((MMS_OMEGA, "zeta"), s2, var_attrs(
             "MMS flip threshold sigma2", "1",
             "Eq. 25b solved exactly as an implicit equation, with the re-derived gamma (Eq. 22, "
             "see docs/analytic.md)")),
         "sigma_star": (("zeta",), np.broadcast_to(star, zt.shape).copy(), var_attrs(
             "MMS threshold sigma*", "1", "Eq. 26 as printed: 36 zeta / (1 + 16 zeta^2 / 9)")),
         "sigma_star_min": (("zeta",), np.broadcast_to(smin, zt.shape).copy(), var_attrs(
             "minimum of the MMS flip curve", "1", "min over omega of sigma2 (derived gamma)"))},
        coords={MMS_OMEGA: (MMS_OMEGA, om, _omega_attrs()),
                "zeta": ("zeta", zt, var_attrs("damping ratio", "1", "damping ratio"))})
    out.attrs = {"title": "multiple-scales thresholds (paper Eq. 25-27, Fig. 3, 7, 9)"}
    return out


def mms_response(omega: Iterable[float], sigma: float, zeta: float) -> xr.Dataset:
    """MMS frequency response at one (sigma, zeta): A (Eq. 23) and min q (Fig. 5) of the upper
    (stable) and lower (unstable) branches, and the region (Fig. 3). Dim mms_omega
    (:data:`MMS_OMEGA`: ``omega``'s values)."""
    om = np.asarray(list(omega), float)
    with np.errstate(all="ignore"):
        data = {}
        for br in ("upper", "lower"):
            data[f"A_{br}"] = ((MMS_OMEGA,), np.asarray(mms.amplitude(om, sigma, zeta, br), float),
                               var_attrs(f"MMS subharmonic amplitude, {br} branch", "1",
                                      f"A of Eq. 23, {br} (" + ("stable" if br == "upper" else
                                                                "unstable") + ") root"))
            data[f"min_q_{br}"] = ((MMS_OMEGA,), np.asarray(mms.min_response(om, sigma, zeta, br),
                                                          float),
                                   var_attrs(f"MMS minimum of q, {br} branch", "1",
                                          "minimum over 2T of the response Eq. 19 (Fig. 5)"))
        data["region"] = ((MMS_OMEGA,), np.asarray(mms.region(om, sigma, zeta), np.int8), var_attrs(
            "MMS region", "1", "region of paper Fig. 3 (1: I, 2: II, 3: III)",
            flag_values=np.array([1, 2, 3], np.int8), flag_meanings="I II III"))
    out = xr.Dataset(data, coords={MMS_OMEGA: (MMS_OMEGA, om, _omega_attrs())})
    out.attrs = {"title": "multiple-scales frequency response (paper Fig. 4, 5)",
                 "sigma": float(sigma), "zeta": float(zeta),
                 "taylor_contact_loss": TAYLOR_CONTACT_LOSS}
    return out



def mms_window(omega: Iterable[float]) -> tuple[float, float] | None:
    """The part of abs(omega - 2) <= MMS_HALF_WIDTH within the range of ``omega``, or None."""
    om = np.asarray(list(omega), float)
    a, b = max(float(om.min()), 2.0 - MMS_HALF_WIDTH), min(float(om.max()), 2.0 + MMS_HALF_WIDTH)
    return (a, b) if a < b else None


def mms_curves_over(ds: xr.Dataset) -> xr.Dataset:
    """:func:`mms_curves` over the study's omega window (:func:`mms_window`; the whole of
    abs(omega - 2) <= MMS_HALF_WIDTH when the grid is outside it) at its zeta values."""
    a, b = mms_window(ds["omega"].values) or (2.0 - MMS_HALF_WIDTH, 2.0 + MMS_HALF_WIDTH)
    return mms_curves(np.linspace(a, b, MMS_POINTS), ds["zeta"].values)


def mms_response_over(ds: xr.Dataset) -> xr.Dataset:
    """:func:`mms_response` on each (sigma, zeta) line of the study, over its omega window
    (:func:`mms_window`, which must not be None). Dims (sigma, zeta, mms_omega): the study's
    sigma and zeta, the window's own omega grid."""
    a, b = mms_window(ds["omega"].values)
    fine = np.linspace(a, b, MMS_POINTS)
    resp = [mms_response(fine, float(s), float(z)).expand_dims(sigma=[float(s)], zeta=[float(z)])
            for s in ds["sigma"].values for z in ds["zeta"].values]
    out = xr.combine_by_coords([r.drop_attrs(deep=False) for r in resp])
    for c in ("sigma", "zeta"):
        out[c].attrs = dict(ds[c].attrs)
    out.attrs = {"title": "multiple-scales frequency response (paper Fig. 4, 5)",
                 "taylor_contact_loss": TAYLOR_CONTACT_LOSS}
    return out
