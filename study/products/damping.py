"""The products of studies over damping (issue 33): ``thresholds`` (the subharmonic thresholds
as functions of damping) and ``impact_onset`` (where vibro-impacts start over (omega, zeta)).

For every zeta of a study: sigma* (the lowest point of the 1T flip curve, paper Eq. 26-27),
sigma** (the lowest point of the isola's 2T fold curve, paper Fig. 8-9) and the join (where the
isola's fold curve ends on the 1T flip curve), each with its accuracy, computed by continuation
(study.solve.thresholds: the extremum of the traced curve, refined by Brent on the curve's
sigma at fixed omega), not read off the grid; and, between the study's zeta values, sigma* and
sigma** continued in zeta as curves (dims ``star_vertex``, ``double_star_vertex``: dense,
adaptive-step vertices, the study's zeta values among them), and the join traced from each
vertex of sigma**(zeta) (dim ``join_vertex``).

sigma* starts from the multiple-scales estimate (no store data needed); sigma** from the isola
boundary read off the traced curves (``products/isola_boundary``: a refined vertex of the
isola's fold curve), so it needs a study with the ``curves`` output (NaN otherwise, and the
attrs say why). Dimensionless (paper Eq. 7 / 11).
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from hertzmap.kernels.continuation import VERTEX_EXTREMUM
from hertzmap.kernels.model import Model
from hertzmap.study.analytic import multiple_scales as mms
from hertzmap.study.products.results import (in_stored_order, source_attrs,
                                             stored_axes, var_attrs)
from hertzmap.study.products.traced_curves import isola_boundary
from hertzmap.study.solve import thresholds as th

#: The measured ratio sigma*/zeta on the paper's rig at zeta = 0.005 (paper section 4: "about
#: 40"), drawn on the thresholds figure beside the computed curve.
MEASURED_STAR_RATIO = 40.0
MEASURED_ZETA = 0.005

_NA = "NaN where it was not found (see the product's attrs)"
#: The product's variables, declared once: name -> (dim, long_name, units, description).
THRESHOLD_VARIABLES: dict[str, tuple[str, str, str, str]] = {
    # -- at the study's zeta values ----------------------------------------------------------
    "sigma_star": ("zeta", "sigma* (lowest sigma of the 1T flip curve)", "1",
                   "above it the subharmonic resonance is always excited (paper Eq. 26-27; "
                   "computed exactly, not by multiple scales: mms_curves holds Eq. 26)"),
    "omega_star": ("zeta", "omega at sigma*", "1", "where the 1T flip curve is lowest"),
    "sigma_star_accuracy": ("zeta", "accuracy of sigma*", "1",
                            "change of sigma* when the integrator's rtol is divided by 100"),
    "omega_star_accuracy": ("zeta", "accuracy of omega*", "1",
                            "half-width of the omega interval over which the flip curve stays "
                            "within sigma_star_accuracy of sigma*"),
    "sigma_double_star": ("zeta", "sigma** (lowest sigma of the isola)", "1",
                          "lowest point of the isola's 2T fold curve: below it no isola (paper "
                          "Fig. 8-9); " + _NA),
    "omega_double_star": ("zeta", "omega at sigma**", "1", _NA),
    "sigma_double_star_accuracy": ("zeta", "accuracy of sigma**", "1",
                                   "as sigma_star_accuracy"),
    "omega_double_star_accuracy": ("zeta", "accuracy of omega**", "1",
                                   "as omega_star_accuracy"),
    "sigma_join": ("zeta", "sigma where the isola joins the flip-born branch", "1",
                   "the fold_flip point ending the isola's 2T fold curve on the 1T flip curve "
                   "(traced from sigma**); NaN where the curve does not reach the flip curve"),
    "omega_join": ("zeta", "omega where the isola joins the flip-born branch", "1", ""),
    "join_accuracy": ("zeta", "accuracy of the join", "1",
                      "spread of the extrapolation of the fold curve onto the 1T orbit, in "
                      "omega and sigma"),
    "sigma_star_mms": ("zeta", "sigma* by multiple scales", "1",
                       "paper Eq. 26 as printed: 36 zeta / (1 + 16 zeta^2 / 9)"),
    # -- continued in zeta -------------------------------------------------------------------
    "star_zeta": ("star_vertex", "damping ratio", "1",
                  "vertices of sigma*(zeta), continued in zeta (adaptive steps, the study's "
                  "zeta values among them)"),
    "star_omega": ("star_vertex", "omega at sigma*", "1", ""),
    "star_sigma": ("star_vertex", "sigma*", "1", ""),
    "star_sigma_accuracy": ("star_vertex", "accuracy of sigma*", "1", "as sigma_star_accuracy"),
    "star_sigma_mms": ("star_vertex", "sigma* by multiple scales", "1", "paper Eq. 26"),
    "double_star_zeta": ("double_star_vertex", "damping ratio", "1",
                         "vertices of sigma**(zeta), continued in zeta"),
    "double_star_omega": ("double_star_vertex", "omega at sigma**", "1", ""),
    "double_star_sigma": ("double_star_vertex", "sigma**", "1", ""),
    "double_star_sigma_accuracy": ("double_star_vertex", "accuracy of sigma**", "1",
                                   "as sigma_star_accuracy"),
    "join_zeta": ("join_vertex", "damping ratio", "1",
                  "vertices of the join as a function of zeta: the join traced from each "
                  "vertex of sigma**(zeta) where it exists (the study's zeta values among "
                  "them)"),
    "join_omega": ("join_vertex", "omega where the isola joins the flip-born branch", "1", ""),
    "join_sigma": ("join_vertex", "sigma where the isola joins the flip-born branch", "1", ""),
    "join_vertex_accuracy": ("join_vertex", "accuracy of the join", "1", "as join_accuracy"),
}


def isola_start(traced: xr.Dataset | None, isola: xr.Dataset | None):
    """(zeta, (q0, v0, omega, sigma)) of the refined lowest vertex of the isola's fold curve in
    the traced curves (``isola``: products/isola_boundary) at the first zeta that has one, or
    None."""
    if traced is None or isola is None:
        return None
    for z, s, c in zip(isola["zeta"].values, isola["sigma_isola"].values,
                       isola["curve"].values):
        if not np.isfinite(s) or c < 0:
            continue
        sel = ((traced["curve_id"].values == c)
               & ((traced["flag"].values.astype(int) & VERTEX_EXTREMUM) != 0)
               & (traced["sigma"].values == s))
        k = np.nonzero(sel)[0]
        if k.size:
            k = int(k[0])
            return float(z), tuple(float(traced[n].values[k])
                                   for n in ("q0", "v0", "omega", "sigma"))
    return None


def _at(curve: th.ZetaCurve | None, zetas: np.ndarray) -> list:
    """The curve's vertex at each zeta (the continuation lands on them), or None."""
    out = []
    for z in zetas:
        v = ([p for p in curve.vertices if np.isclose(p.zeta, z, rtol=0.0, atol=1e-12)]
             if curve is not None else [])
        out.append(v[0] if v else None)
    return out


def thresholds(ds: xr.Dataset, traced_curves: xr.Dataset | None = None) -> xr.Dataset:
    """sigma*, sigma** and the join at each zeta of the study, and sigma*(zeta), sigma**(zeta)
    continued over the study's zeta range (module docstring), computed in this process: what
    the run's thresholds stage (scheduler.stages.threshold_tasks, the ``thresholds`` output) computes
    on its workers and stores as products/thresholds. ``traced_curves``: that product, when
    at hand (sigma** starts from it)."""
    zetas = np.sort(np.asarray(ds["zeta"].values, float))
    model = Model.of(ds.attrs)
    kw = dict(exponent=model.exponent, model=model.law, rtol=model.rtol)
    star = th.star_threshold(zetas, **kw)
    double = th.double_star_threshold(zetas, isola_start_of(traced_curves), **kw)
    return thresholds_dataset(ds, star, double)


def isola_start_of(traced_curves: xr.Dataset | None):
    """Where sigma** starts: the refined lowest vertex of the isola's fold curve among the
    traced curves (:func:`isola_start` on their isola boundary), or None."""
    if traced_curves is None:
        return None
    return isola_start(traced_curves, isola_boundary(traced_curves))


def thresholds_dataset(ds: xr.Dataset, star: tuple, double: tuple) -> xr.Dataset:
    """The ``thresholds`` product from what study.solve.thresholds computed: ``star``
    (star_threshold's curve and note), ``double`` (double_star_threshold's curve, joins and
    note); ``ds``: the results (the study's zeta values, the source attrs). Its dim zeta is
    in the store's order (results.in_stored_order: the group aligns with the main group)."""
    zetas = np.sort(np.asarray(ds["zeta"].values, float))
    star_curve, star_note = star
    double_curve, join_path, double_note = double
    notes = {"hertzmap_star_ends": star_note, "hertzmap_double_star_ends": double_note}
    star_at, double_at = _at(star_curve, zetas), _at(double_curve, zetas)
    # the join from every vertex of sigma**(zeta): a curve in zeta like sigma* and sigma**
    # (the study's zeta values are vertices: their joins are read from it)
    joins = [next((j for z, j in join_path if p is not None and z == p.zeta), None)
             for p in double_at]
    join_curve = [j for _, j in join_path if j is not None]

    def col(points, field):
        return np.array([getattr(p, field) if p is not None else np.nan for p in points], float)

    def verts(curve, field):
        return np.array([getattr(p, field) for p in curve.vertices] if curve is not None
                        else [], float)

    values = {
        "sigma_star": col(star_at, "sigma"), "omega_star": col(star_at, "omega"),
        "sigma_star_accuracy": col(star_at, "sigma_accuracy"),
        "omega_star_accuracy": col(star_at, "omega_accuracy"),
        "sigma_double_star": col(double_at, "sigma"),
        "omega_double_star": col(double_at, "omega"),
        "sigma_double_star_accuracy": col(double_at, "sigma_accuracy"),
        "omega_double_star_accuracy": col(double_at, "omega_accuracy"),
        "sigma_join": col(joins, "sigma"), "omega_join": col(joins, "omega"),
        "join_accuracy": col(joins, "accuracy"),
        "sigma_star_mms": np.asarray(mms.sigma_star(zetas, "paper"), float),
        "star_zeta": verts(star_curve, "zeta"), "star_omega": verts(star_curve, "omega"),
        "star_sigma": verts(star_curve, "sigma"),
        "star_sigma_accuracy": verts(star_curve, "sigma_accuracy"),
        "double_star_zeta": verts(double_curve, "zeta"),
        "double_star_omega": verts(double_curve, "omega"),
        "double_star_sigma": verts(double_curve, "sigma"),
        "double_star_sigma_accuracy": verts(double_curve, "sigma_accuracy"),
        "join_zeta": np.array([j.zeta for j in join_curve], float),
        "join_omega": np.array([j.omega for j in join_curve], float),
        "join_sigma": np.array([j.sigma for j in join_curve], float),
        "join_vertex_accuracy": np.array([j.accuracy for j in join_curve], float),
    }
    values["star_sigma_mms"] = np.asarray(mms.sigma_star(values["star_zeta"], "paper"), float)
    out = xr.Dataset(
        {name: (dim, values[name], var_attrs(long_name, units, description))
         for name, (dim, long_name, units, description) in THRESHOLD_VARIABLES.items()},
        coords={"zeta": ("zeta", zetas, var_attrs("damping ratio", "1", "the study's zeta "
                                                                       "values"))})
    out.attrs = {**source_attrs(ds, "subharmonic thresholds sigma*, sigma** and the isola's "
                                    "join as functions of damping"),
                 "method": "the lowest point of the 1T flip curve and of the isola's 2T fold "
                           "curve: Brent over omega on the curve's sigma at fixed omega, "
                           "continued in zeta (study.solve.thresholds)",
                 "maps": int((star_curve.maps if star_curve else 0)
                             + (double_curve.maps if double_curve else 0)
                             + sum(j.maps for j in join_curve)),
                 **notes}
    return in_stored_order(out, stored_axes(ds))


def impact_onset(lcm: xr.Dataset, rig=None) -> xr.Dataset:
    """Where vibro-impacts start, a design chart over (omega, zeta): ``sigma_impact_onset``,
    the lowest sigma of the grid at which a stable response loses contact
    (loss_of_contact_map's ``contact_loss_possible``; NaN where none does in the window), and
    ``sigma_below_onset``, the grid's sigma below it (the onset lies between the two: the
    chart's accuracy is the grid's sigma step). With a rig (study.analytic.rig.Rig, paper
    Eq. 1-8): ``force_amplitude_N`` (sigma N) and the coordinate ``frequency_hz``
    (omega f0). Dims (omega, zeta)."""
    possible = lcm["contact_loss_possible"] & lcm["computed"]
    sig = lcm["sigma"].values
    first = possible.transpose("omega", "zeta", "sigma").values
    any_loss = first.any(axis=2)
    k = np.argmax(first, axis=2)
    onset = np.where(any_loss, sig[k], np.nan)
    below = np.where(any_loss & (k > 0), sig[np.maximum(k - 1, 0)], np.nan)
    out = xr.Dataset(
        {"sigma_impact_onset": (("omega", "zeta"), onset, var_attrs(
            "vibro-impact onset", "1", "lowest sigma of the grid at which a stable response "
            "loses contact (min q < -n); NaN: none in the study's sigma window")),
         "sigma_below_onset": (("omega", "zeta"), below, var_attrs(
             "grid sigma below the onset", "1", "the sigma line below sigma_impact_onset, where "
             "every stable response stays in contact (NaN at the window's first line): the "
             "onset lies between the two"))},
        coords={"omega": ("omega", lcm["omega"].values, dict(lcm["omega"].attrs)),
                "zeta": ("zeta", lcm["zeta"].values, dict(lcm["zeta"].attrs))})
    if rig is not None:
        out["force_amplitude_N"] = (("omega", "zeta"),
                                    np.asarray(rig.sigma_to_force_amplitude(onset), float),
                                    var_attrs("excitation force amplitude at the onset", "N",
                                              f"sigma N, N = {rig.N:g} N (the study's [rig])"))
        out = out.assign_coords(frequency_hz=("omega", np.asarray(
            rig.omega_to_frequency(lcm["omega"].values), float), var_attrs(
            "excitation frequency", "Hz", f"omega f0, f0 = {rig.f0:.6g} Hz (the study's "
            "[rig])")))
    out.attrs = {"title": "vibro-impact onset over (omega, zeta): the lowest sigma at which a "
                          "stable response loses contact",
                 "source": "products/loss_of_contact_map (contact_loss_possible)"}
    return out
