"""Figures over the (omega, sigma) plane at one zeta: the loss-of-contact map (what the contact
does), the same side by side over zeta, the map's measures, the Lyapunov map, the bifurcation
set (the grid's contours, the located and traced curves).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from hertzmap.study import products as P
from hertzmap.study.plots.style import (curves_legend, 
    SET_COLORS,
    SET_LABELS,
    draw_curves,
    draw_mms,
    draw_traced,
    grid_fallback,
    save,
    zeta_label,
)
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.patches import Patch


def _map_panel(ax, lcm, curves, zeta, mms, traced, isola) -> list:
    """One map of stable responses at ``zeta`` into ``ax`` (see plot_loss_of_contact_map);
    returns the legend's patches of the response kinds present."""
    m = lcm.sel(zeta=zeta, method="nearest")
    field = "map_class" if "map_class" in m else "stable_set"
    codes = m[field].transpose("sigma", "omega").values.astype(int)
    codes = np.where(m["computed"].transpose("sigma", "omega").values, codes, 0)
    present = sorted(set(np.unique(codes).tolist()))
    n = len(SET_COLORS)
    cmap = ListedColormap([SET_COLORS[c] for c in range(n)])
    norm = BoundaryNorm(np.arange(-0.5, n + 0.5), n)
    ax.pcolormesh(m["omega"], m["sigma"], codes, cmap=cmap, norm=norm, shading="nearest",
                  rasterized=True)
    handles = [Patch(facecolor=SET_COLORS[c], edgecolor="0.6", label=SET_LABELS[c]) for c in present]
    if "stable_longer" in m and field == "map_class":
        beside = (m["stable_longer"].transpose("sigma", "omega").values > 0) \
            & (codes > 0) & (codes < 16)
        if beside.any():
            ax.contourf(m["omega"], m["sigma"], beside.astype(float), levels=[0.5, 1.5],
                        colors="none", hatches=["////"])
            handles.append(Patch(facecolor="none", edgecolor="0.3", hatch="////",
                                 label="and a stable orbit of period m >= 3"))
    draw_traced(ax, traced, zeta, isola)
    draw_curves(ax, curves, zeta, grid_fallback(traced, zeta, ("flip_1T", "grazing_1T",
                                                                   "grazing_2T", "isola")))
    draw_mms(ax, mms, zeta, sigma1=False)
    ax.set_xlim(float(m["omega"].min()), float(m["omega"].max()))
    ax.set_ylim(float(m["sigma"].min()), float(m["sigma"].max()))
    return handles


def plot_loss_of_contact_map(lcm, curves, path, *, zeta=None, mms=None, title=None,
                             traced=None, isola=None) -> Path:
    """Kinds of stable response over (omega, sigma) with the flip, grazing and isola curves
    (traced ones where the study has them, ``traced``: products/traced_curves, with sigma**
    from ``isola``, products/isola_boundary; else the grid's contours) and the MMS flip
    curve."""
    zeta = float(lcm["zeta"].values[0] if zeta is None else zeta)
    fig, ax = plt.subplots(figsize=(8.2, 4.8), layout="constrained")
    handles = _map_panel(ax, lcm, curves, zeta, mms, traced, isola)
    ax.set_xlabel("omega (excitation frequency / natural frequency)")
    ax.set_ylabel("sigma (excitation amplitude / preload)")
    ax.set_title(title or f"Stable responses and contact loss, {zeta_label(zeta)}")
    curves_legend(fig, handles, ax.get_legend_handles_labels()[0], fontsize=7)
    return save(fig, path)


def plot_zeta_maps(lcm, curves, path, *, zetas, mms=None, traced=None, isola=None) -> Path:
    """The maps of stable responses (plot_loss_of_contact_map) at the ``zetas`` side by side,
    on one sigma axis: how damping moves the flip curve and the isola."""
    fig, axes = plt.subplots(1, len(zetas), figsize=(3.6 * len(zetas) + 2.2, 4.4),
                             layout="constrained", sharey=True, squeeze=False)
    handles = {}
    for ax, z in zip(axes[0], zetas):
        for h in _map_panel(ax, lcm, curves, float(z), mms, traced, isola):
            handles[h.get_label()] = h
        ax.set_title(zeta_label(float(z)), fontsize=9)
        ax.set_xlabel("omega")
    axes[0, 0].set_ylabel("sigma")
    curves_legend(fig, list(handles.values()), axes[0, -1].get_legend_handles_labels()[0],
                  fontsize=6)
    fig.suptitle("Stable responses and contact loss as damping grows", fontsize=10)
    return save(fig, path)


def plot_map_measures(lcm, path, *, zeta=None, curves=None) -> Path:
    """Coexistence (number of stable responses), largest flight fraction and largest impact
    velocity of the stable responses over (omega, sigma)."""
    zeta = float(lcm["zeta"].values[0] if zeta is None else zeta)
    m = lcm.sel(zeta=zeta, method="nearest")
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.8), layout="constrained", sharey=True)
    panels = [("n_stable", "coexisting stable responses", "viridis"),
              ("flight_fraction", "largest flight fraction (stable)", "magma_r"),
              ("max_impact_velocity", "largest impact velocity |dq/dtau| (stable)", "magma_r")]
    for ax, (var, title, cmap) in zip(axes, panels):
        if var not in m:
            ax.set_visible(False)
            continue
        z = m[var].transpose("sigma", "omega").values.astype(float)
        z = np.where(m["computed"].transpose("sigma", "omega").values, z, np.nan)
        if var == "n_stable":
            nmax = int(np.nanmax(z)) if np.isfinite(z).any() else 1
            cm = plt.get_cmap(cmap, nmax + 1)
            pc = ax.pcolormesh(m["omega"], m["sigma"], z, cmap=cm, vmin=-0.5, vmax=nmax + 0.5,
                               shading="nearest", rasterized=True)
            fig.colorbar(pc, ax=ax, ticks=range(nmax + 1))
        else:
            pc = ax.pcolormesh(m["omega"], m["sigma"], z, cmap=cmap, shading="nearest",
                               rasterized=True)
            fig.colorbar(pc, ax=ax)
        if curves is not None:
            draw_curves(ax, curves, zeta, ("flip_1T",))
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("omega")
    axes[0].set_ylabel("sigma")
    fig.suptitle(f"Multistability and contact loss of the stable responses, {zeta_label(zeta)}",
                 fontsize=10)
    return save(fig, path)


def plot_lyapunov_map(lcm, path, *, zeta=None, title=None) -> Path:
    """The largest Lyapunov exponent of each point's attractors over (omega, sigma): negative
    where a stable orbit attracts (its decay rate), positive where the motion is chaotic."""
    zeta = float(lcm["zeta"].values[0] if zeta is None else zeta)
    m = lcm.sel(zeta=zeta, method="nearest")
    lam = m["lyapunov_exponent"].transpose("sigma", "omega").values.astype(float)
    lam = np.where(m["computed"].transpose("sigma", "omega").values, lam, np.nan)
    fig, ax = plt.subplots(figsize=(8.2, 4.8), layout="constrained")
    finite = lam[np.isfinite(lam)]
    # one scale both ways: the stable orbits' exponents (about -zeta) and the chaotic ones
    # (0.01-0.2) are of one order; a few strongly damped orbits would flatten the rest
    top = float(np.percentile(np.abs(finite), 99)) if finite.size else 1.0
    top = max(top, 1e-6)
    pc = ax.pcolormesh(m["omega"], m["sigma"], np.clip(lam, -top, top), cmap="RdBu_r",
                       vmin=-top, vmax=top, shading="nearest", rasterized=True)
    fig.colorbar(pc, ax=ax, label="largest Lyapunov exponent (per unit tau)")
    chaotic = np.isfinite(lam) & (lam > 0)
    if chaotic.any():
        ax.contour(m["omega"], m["sigma"], chaotic.astype(float), levels=[0.5], colors="k",
                   linewidths=0.6)
    ax.set_xlabel("omega")
    ax.set_ylabel("sigma")
    ax.set_title(title or f"Largest Lyapunov exponent of the attractors, {zeta_label(zeta)} "
                 "(black: chaos)", fontsize=10)
    return save(fig, path)


def _located_segments(located, zeta, kind, period):
    if located is None or not located.sizes.get("vertex", 0):
        return []
    sel = ((located["kind"].values == kind) & (located["period"].values == period)
           & np.isclose(located["zeta"].values, zeta))
    segs = located["segment"].values[sel]
    om, sg = located["omega"].values[sel], located["sigma"].values[sel]
    return [np.column_stack([om[segs == s], sg[segs == s]]) for s in np.unique(segs)]


def plot_bifurcation_set(curves, mms, path, *, zeta=None, lcm=None, omega_range=None,
                         sigma_range=None, title=None, located=None, traced=None,
                         isola=None) -> Path:
    """Bifurcation set in (omega, sigma) (paper Fig. 3, 7, 9): MMS sigma1/sigma2 against the
    numerical flip curve (squares), 2T existence boundary (folds) and isolas. With ``traced``
    (products/traced_curves) the traced fold, flip and grazing curves, their codimension-2
    points and sigma** (``isola``: products/isola_boundary; the grid's curves only where a kind could not be traced, labelled with
    the reason); else with ``located`` (the ``located_bifurcations`` product) the flip curve
    and the 2T folds are the located points (solver accuracy); else the contours of grid
    indicators."""
    if zeta is None:
        zs = np.unique(curves["zeta"].values) if curves.sizes["vertex"] else mms["zeta"].values
        zeta = float(zs[0])
    fig, ax = plt.subplots(figsize=(7.2, 4.8), layout="constrained")
    if traced is not None:
        draw_mms(ax, mms, zeta)
        draw_traced(ax, traced, zeta, isola)
        fallback = grid_fallback(traced, zeta, ("flip_1T", "boundary_2T", "isola"))
        if any(n == "isola" for n, _ in fallback):
            _shade_isola_cells(ax, lcm, zeta)
        draw_curves(ax, curves, zeta, fallback)
        return _finish_bifurcation_set(fig, ax, path, omega_range, sigma_range,
                                       title or f"Bifurcation set (traced curves), {zeta_label(zeta)}",
                                       legend_size=6.5)
    _shade_isola_cells(ax, lcm, zeta)
    draw_mms(ax, mms, zeta)
    flips = _located_segments(located, zeta, 2, 1)
    folds = _located_segments(located, zeta, 1, 2)
    if flips or folds:
        for seg in flips:
            ax.plot(seg[:, 0], seg[:, 1], "s-", mfc="none", mec="k", color="k", lw=0.6, ms=4)
        ax.plot([], [], "s-", mfc="none", mec="k", color="k", lw=0.6, ms=4,
                label="flip of 1T (located)")
        for seg in folds:
            ax.plot(seg[:, 0], seg[:, 1], "o-", mfc="none", mec="C3", color="C3", lw=0.6, ms=3)
        if folds:
            ax.plot([], [], "o-", mfc="none", mec="C3", color="C3", lw=0.6, ms=3,
                    label="fold of 2T (located)")
        draw_curves(ax, curves, zeta, ("isola",))
    else:
        for seg in P.curve_segments(curves, "flip_1T", zeta):
            step = max(1, len(seg) // 40)
            ax.plot(seg[::step, 0], seg[::step, 1], "s", mfc="none", mec="k", ms=4)
        ax.plot([], [], "s", mfc="none", mec="k", ms=4, label="flip of 1T (shooting, contoured)")
        draw_curves(ax, curves, zeta, ("boundary_2T", "isola"))
    return _finish_bifurcation_set(fig, ax, path, omega_range, sigma_range,
                                   title or f"Bifurcation set, {zeta_label(zeta)}", legend_size=7)


def _shade_isola_cells(ax, lcm, zeta) -> None:
    """The grid cells flagged isola_2T (the grid heuristic), shaded: where no curve is traced."""
    if lcm is None:
        return
    m = lcm.sel(zeta=zeta, method="nearest")
    iso = m["isola_2T"].transpose("sigma", "omega").values
    if iso.any():
        ax.pcolormesh(m["omega"], m["sigma"], np.where(iso, 1.0, np.nan), cmap="RdPu",
                      vmin=0, vmax=2, shading="nearest", rasterized=True)


def _finish_bifurcation_set(fig, ax, path, omega_range, sigma_range, title, legend_size):
    if omega_range:
        ax.set_xlim(*omega_range)
    if sigma_range:
        ax.set_ylim(*sigma_range)
    ax.set_xlabel("omega")
    ax.set_ylabel("sigma")
    ax.set_title(title)
    ax.legend(fontsize=legend_size, loc="best")
    return save(fig, path)
