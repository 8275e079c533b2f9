"""The paper's analytic figures that need no store (Fig. 2-5): ``hertzmap plot --paper``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

import matplotlib.pyplot as plt
import numpy as np
from hertzmap.kernels.model import TAYLOR_CONTACT_LOSS
from hertzmap.study import products as P
from hertzmap.study.analytic import multiple_scales as mms
from hertzmap.study.analytic.rig import restoring_force
from hertzmap.study.plots.style import draw_mms, save
from matplotlib.colors import ListedColormap


def paper_fig02(path) -> Path:
    """Fig. 2: Hertz restoring force (1 + 2q/3)^(3/2) and its Taylor approximation (Eq. 10)."""
    q = np.linspace(-2.0, 2.0, 401)
    taylor = 1 + q + q**2 / 6 - q**3 / 54
    fig, ax = plt.subplots(figsize=(5.5, 4), layout="constrained")
    ax.plot(q, restoring_force(q, 1.5), "k", lw=2.2, label="Hertz (1 + 2q/3)^(3/2), Eq. 7")
    ax.plot(q, taylor, "k", lw=0.9, label="Taylor, Eq. 10")
    ax.axvline(-1.5, color="tab:red", lw=0.6, ls=":")
    ax.axvline(TAYLOR_CONTACT_LOSS, color="tab:blue", lw=0.6, ls=":")
    inside = (q >= -1) & (q <= 1)
    err = np.max(np.abs(restoring_force(q[inside], 1.5) - taylor[inside]))
    ax.text(0.02, 0.97, f"max |difference| on -1 < q < 1: {err:.4f}", transform=ax.transAxes,
            va="top", fontsize=8)
    ax.set_xlabel("q")
    ax.set_ylabel("F / N")
    ax.set_title("Fig. 2: restoring force", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    return save(fig, path)


def paper_fig03(path, zeta=0.005) -> Path:
    """Fig. 3: MMS regions I, II, III in (omega, sigma) with sigma1, sigma2 (zeta = 0.005)."""
    om = np.linspace(1.9, 2.1, 401)
    sg = np.linspace(0.0, 1.0, 301)
    W, S = np.meshgrid(om, sg)
    reg = mms.region(W, S, zeta)
    cur = P.mms_curves(om, [zeta])
    fig, ax = plt.subplots(figsize=(6, 4.3), layout="constrained")
    ax.pcolormesh(om, sg, reg, cmap=ListedColormap(["#fcbba1", "#c7e9c0", "#f0f0f0"]),
                  vmin=0.5, vmax=3.5, shading="nearest", rasterized=True)
    draw_mms(ax, cur, zeta)
    for lbl, (x, y) in {"I": (2.0, 0.7), "II": (1.94, 0.42), "III": (2.07, 0.15)}.items():
        ax.text(x, y, lbl, fontsize=12, ha="center")
    ax.set_xlabel("omega")
    ax.set_ylabel("sigma")
    ax.set_title(f"Fig. 3: MMS bifurcation set, zeta = {zeta:g}", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    return save(fig, path)


def paper_fig04(path, sigma=0.5, zeta=0.01) -> Path:
    """Fig. 4: MMS subharmonic amplitude A(omega), softening (sigma = 0.5, zeta = 0.01)."""
    r = P.mms_response(np.linspace(1.5, 2.3, 1601), sigma, zeta)
    fig, ax = plt.subplots(figsize=(5.5, 4), layout="constrained")
    ax.plot(r[P.MMS_OMEGA], r["A_upper"], "k", lw=1.8, label="stable (+ root)")
    ax.plot(r[P.MMS_OMEGA], r["A_lower"], "k", lw=0.8, ls="--", label="unstable (- root)")
    ax.plot([1.5, 2.3], [0, 0], color="0.5", lw=0.8, label="trivial (A = 0)")
    ax.set_xlabel("omega")
    ax.set_ylabel("A")
    ax.set_title(f"Fig. 4: MMS amplitude, sigma = {sigma:g}, zeta = {zeta:g}", fontsize=10)
    ax.legend(fontsize=8)
    return save(fig, path)


def paper_fig05(path, sigma=0.5, zeta=0.01, fr=None) -> Path:
    """Fig. 5: min q of the MMS subharmonic response against omega, with the Taylor contact-loss
    level (kernels.model.TAYLOR_CONTACT_LOSS, Eq. 12); optionally the numerical stable 2T orbits of a store (``fr``)."""
    r = P.mms_response(np.linspace(1.5, 2.3, 1601), sigma, zeta)
    fig, ax = plt.subplots(figsize=(5.5, 4), layout="constrained")
    ax.plot(r[P.MMS_OMEGA], r["min_q_upper"], "k", lw=1.8, label="MMS, stable branch")
    ax.plot(r[P.MMS_OMEGA], r["min_q_lower"], "k", lw=0.8, ls="--", label="MMS, unstable branch")
    ax.axhline(TAYLOR_CONTACT_LOSS, color="tab:blue", lw=0.8, ls=":",
               label=f"Taylor contact loss {TAYLOR_CONTACT_LOSS:.4f} (Eq. 12)")
    ax.axhline(-1.5, color="tab:red", lw=0.8, ls=":", label="Hertz contact loss -1.5")
    if fr is not None:
        line = fr.sel(sigma=sigma, zeta=zeta, method="nearest")
        cls = line["orbit_class"].values
        om = np.broadcast_to(line["omega"].values[:, None], cls.shape)
        sel = np.isin(cls, (2, 3))
        ax.plot(om[sel], line["min_q"].values[sel], "o", ms=2.5, color="tab:red",
                label="shooting, stable 2T (Hertz)")
    ax.set_xlim(1.5, 2.3)
    ax.set_xlabel("omega")
    ax.set_ylabel("min q")
    ax.set_title(f"Fig. 5: min q, sigma = {sigma:g}, zeta = {zeta:g}", fontsize=10)
    ax.legend(fontsize=7, loc="lower right")
    return save(fig, path)


PAPER_FIGURES = {"fig02": paper_fig02, "fig03": paper_fig03, "fig04": paper_fig04,
                 "fig05": paper_fig05}


def plot_paper(figures: Iterable[str], out: str | Path = "results") -> list[Path]:
    """The paper's analytic figures (no store): fig02, fig03, fig04, fig05 -> OUT/paper_figNN.png."""
    paths = []
    for f in figures:
        if f not in PAPER_FIGURES:
            raise ValueError(f"unknown paper figure {f!r}; choose from {', '.join(PAPER_FIGURES)}")
        paths.append(PAPER_FIGURES[f](Path(out) / f"paper_{f}.png"))
    return paths
