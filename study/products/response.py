"""Along omega: frequency responses (paper Fig. 6, 8, 10), contact-force harmonics (Fig. 12-13)
and time histories of the contact force (Fig. 14-15) of the stored orbits."""
from __future__ import annotations

from typing import Iterable

import numpy as np
import xarray as xr

from hertzmap.kernels import simulate
from hertzmap.kernels.model import Model
from hertzmap.study.products.classes import orbit_classes, valid_orbits
from hertzmap.study.products.results import (var_attrs, coord_attrs, source_attrs,
                                    open_store)

def _add_frequency_hz(out: xr.Dataset, rig) -> xr.Dataset:
    if rig is None:
        return out
    out = out.assign_coords(frequency_hz=("omega", np.asarray(rig.omega_to_frequency(
        out["omega"].values), float), var_attrs(
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
        out["ptp_m"] = (out["ptp"] * rig.z_s / rig.n).assign_attrs(var_attrs(
            "peak-to-peak displacement", "m", "ptp z_s / n (paper Eq. 5)"))
    out.attrs = source_attrs(ds, "frequency response curves (paper Fig. 6, 8, 10)")
    out = _add_frequency_hz(out, rig)
    return coord_attrs(out, ds)


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
        {"force_amplitude": (("omega", "sigma", "zeta", "solution", "ratio"), amp, var_attrs(
            "contact force harmonic amplitude", "1",
            "amplitude of F/N at the frequency ratio x omega (F_exp has the same harmonics, "
            "paper Eq. 30)")),
         "orbit_class": orbit_classes(ds),
         "stable": ds["stable"] & valid_orbits(ds)},
        coords={d: ds[d] for d in ("omega", "sigma", "zeta", "solution")})
    out = out.assign_coords(ratio=("ratio", ratios, var_attrs(
        "frequency ratio", "1", "frequency of the component / excitation frequency")))
    if rig is not None:
        out["force_amplitude_N"] = (out["force_amplitude"] * rig.N).assign_attrs(var_attrs(
            "contact force harmonic amplitude", "N", "N times force_amplitude"))
    out.attrs = source_attrs(ds, "contact-force harmonics (numerical counterpart of Fig. 12-13)")
    out = _add_frequency_hz(out, rig)
    return coord_attrs(out, ds)


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
    if "computed" not in ds:
        ds = open_store(ds)
    ds = ds.sel(sigma=sigma if sigma is not None else ds["sigma"].values[0], method="nearest")
    ds = ds.sel(zeta=zeta if zeta is not None else ds["zeta"].values[0], method="nearest")
    om_all = ds["omega"].values
    if omegas is None:
        idx = list(range(om_all.size))
    else:
        idx = [int(np.argmin(np.abs(om_all - w))) for w in omegas]
    law = Model.of(ds.attrs)
    n, model, rtol = law.exponent, law.law, law.rtol
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
        {"F_exp": (("case", "time"), fexp, var_attrs(
            "dimensionless normal force F_exp", "1",
            "(F - N) / N, paper Eq. 30 (F/N - 1; -1 in flight)")),
         "q": (("case", "time"), q, var_attrs("displacement", "1", "q(tau)"))},
        coords={"time": ("time", cyc, var_attrs("dimensionless time", "1",
                                             "omega tau / 2 pi: forcing cycles (paper Fig. 14-15)")),
                "omega": ("case", np.array([c[0] for c in cases], float),
                          dict(ds["omega"].attrs)),
                "solution": ("case", np.array([c[1] for c in cases], np.int16),
                             dict(ds["solution"].attrs)),
                "period": ("case", np.array([c[2] for c in cases], np.int8), var_attrs(
                    "period of the orbit", "1", "in forcing periods")),
                "stable": ("case", np.array([c[3] for c in cases], bool), var_attrs(
                    "orbit is stable", "1", "both multipliers inside the unit circle")),
                "ptp": ("case", np.array([c[6] for c in cases], float), var_attrs(
                    "peak-to-peak displacement", "1", "max q - min q of the orbit"))})
    out.attrs = source_attrs(ds, "time histories of F_exp (numerical counterpart of Fig. 14-15)")
    out.attrs.update({"sigma": float(ds["sigma"]), "zeta": float(ds["zeta"])})
    if rig is not None and nc:
        out = out.assign_coords(t_s=(("case", "time"), cyc[None, :] * 2 * np.pi
                                     / out["omega"].values[:, None] / rig.Omega, var_attrs(
                                         "time", "s", "tau / Omega (paper Eq. 6)")))
        out["force_N"] = (rig.N * (1.0 + out["F_exp"])).assign_attrs(var_attrs(
            "contact force", "N", "N (1 + F_exp)"))
        out = out.assign_coords(frequency_hz=("case", np.asarray(rig.omega_to_frequency(
            out["omega"].values), float), var_attrs("excitation frequency", "Hz", "omega f0")))
        out.attrs.update({"rig_f0_hz": rig.f0, "rig_N": rig.N})
    return out

