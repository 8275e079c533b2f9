"""Figures of the studies over damping: sigma*, sigma** and the join against zeta, where
vibro-impacts start over (omega, zeta).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from hertzmap.study.plots.style import save


def plot_impact_onset(onset, path) -> Path:
    """Where vibro-impacts start: the lowest sigma at which a stable response loses contact,
    over (omega, zeta), from products/impact_onset; in the rig's units (Hz, N) when it has
    them. A design chart: below the surface every stable response stays in contact."""
    rig = "frequency_hz" in onset.coords
    x = onset["frequency_hz"].values if rig else onset["omega"].values
    value = onset["force_amplitude_N"] if rig else onset["sigma_impact_onset"]
    z = value.transpose("zeta", "omega").values
    fig, ax = plt.subplots(figsize=(7.6, 4.6), layout="constrained")
    pc = ax.pcolormesh(x, onset["zeta"].values, z, cmap="viridis", shading="nearest",
                       rasterized=True)
    cb = fig.colorbar(pc, ax=ax)
    cb.set_label("excitation force amplitude at the onset (N)" if rig else
                 "sigma at the onset (excitation amplitude / preload)")
    if np.isfinite(z).sum() > 3 and np.nanmax(z) > np.nanmin(z):
        cs = ax.contour(x, onset["zeta"].values, z, levels=8, colors="k", linewidths=0.6)
        ax.clabel(cs, fontsize=6, fmt="%.3g")
    ax.set_xlabel("excitation frequency (Hz)" if rig else "omega")
    ax.set_ylabel("damping ratio zeta")
    ax.set_title("Vibro-impact onset: the lowest excitation at which a stable response loses "
                 "contact (white: none in the window)", fontsize=9)
    return save(fig, path)


def plot_thresholds(th, path, *, measured=(None, None)) -> Path:
    """The subharmonic thresholds against damping (issue 33), from products/thresholds: left,
    sigma*/zeta and sigma**/zeta against zeta (the continued curves, the study's zeta values as
    points), the multiple-scales 36 / (1 + 16 zeta^2 / 9) (paper Eq. 26) and the rig's measured
    (sigma*/zeta)_exp (``measured`` = (zeta, ratio): paper section 4, ~40 at zeta = 0.005);
    right, sigma*, sigma** and the isola's join against zeta."""
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    for name, label, color in (("star", "sigma* (1T flip curve's lowest point)", "C0"),
                               ("double_star", "sigma** (isola's lowest point)", "C1")):
        z, s = th[f"{name}_zeta"].values, th[f"{name}_sigma"].values
        if z.size:
            ax.plot(z, s / z, "-", color=color, lw=1.4, label=label + " / zeta")
            bx.plot(z, s, "-", color=color, lw=1.4, label=label)
        zg, sg = th["zeta"].values, th[f"sigma_{name}"].values
        ax.plot(zg, sg / zg, "o", color=color, ms=4)
        bx.plot(zg, sg, "o", color=color, ms=4)
    if th["star_zeta"].size:
        z = th["star_zeta"].values
        ax.plot(z, th["star_sigma_mms"].values / z, "--", color="0.3", lw=1.0,
                label="multiple scales: 36 / (1 + 16 zeta^2 / 9) (Eq. 26)")
        bx.plot(z, th["star_sigma_mms"].values, "--", color="0.3", lw=1.0,
                label="sigma* by multiple scales (Eq. 26)")
    if th["join_zeta"].size:
        bx.plot(th["join_zeta"].values, th["join_sigma"].values, "-", color="C2", lw=1.0)
    bx.plot(th["zeta"].values, th["sigma_join"].values, "s", color="C2", ms=4, mfc="none",
            label="the isola joins the flip-born branch")
    z_exp, r_exp = measured
    if z_exp is not None:
        ax.plot([z_exp], [r_exp], "*", color="C3", ms=12,
                label=f"measured on the rig: ~{r_exp:g} at zeta = {z_exp:g} (paper)")
    ax.set_xlabel("damping ratio zeta")
    ax.set_ylabel("threshold / zeta")
    ax.set_title("thresholds over damping")
    ax.legend(fontsize=7, loc="best")
    bx.set_xlabel("damping ratio zeta")
    bx.set_ylabel("sigma")
    bx.set_title("sigma*, sigma** and the join")
    bx.legend(fontsize=7, loc="upper left")
    return save(fig, path)
