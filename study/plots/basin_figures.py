"""The basin map of one grid point (``hertzmap basins``): the map, a zoom into its most
tangled window and the share of uncertain states against eps on log-log axes.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from hertzmap.study.plots.style import save
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.patches import Patch, Rectangle
from scipy import ndimage

#: the zoom's side: this share of the map's smaller side, at least ZOOM_MIN cells
ZOOM_SHARE = 0.125
ZOOM_MIN = 12


def zoom_window(labels: np.ndarray) -> tuple[slice, slice]:
    """The square window (rows, columns) of ZOOM_SHARE of the map's side holding the most
    boundary cells (a label differing from a neighbour's): where the structure is finest."""
    side = max(ZOOM_MIN, int(ZOOM_SHARE * min(labels.shape)))
    side = min(side, *labels.shape)
    edge = np.zeros(labels.shape, float)
    edge[1:] += labels[1:] != labels[:-1]
    edge[:, 1:] += labels[:, 1:] != labels[:, :-1]
    density = ndimage.uniform_filter(edge, size=side, mode="constant")
    h = side // 2
    inner = density[h:labels.shape[0] - side + h + 1, h:labels.shape[1] - side + h + 1]
    i, j = np.unravel_index(np.argmax(inner), inner.shape)
    return slice(i, i + side), slice(j, j + side)


def plot_basin_map(basins, path, *, title=None) -> Path:
    """A basin map (study.products.basin_map): each cell of the grid of initial states (q, q') at
    tau = 0 coloured by the attractor its transient ends on (a categorical colour map), the
    periodic attractors' stroboscopic points marked (an m T orbit: m points); S_b and S_bb
    (nats) in the title."""
    labels = basins["basin_label"].values
    kinds = basins["attractor_kind"].values
    periods = basins["attractor_period"].values
    k = kinds.size
    names = {2: "non-periodic", 3: "unsettled", 4: "failed"}
    grey = {2: "tab:red", 3: "0.75", 4: "k"}
    palette = plt.get_cmap("tab10").colors
    colors = [palette[i % 10] if kinds[i] == 1 else grey[int(kinds[i])] for i in range(k)]
    q, v = basins["q"].values, basins["v"].values
    dq = (q[1] - q[0]) / 2 if q.size > 1 else 0.5
    dv = (v[1] - v[0]) / 2 if v.size > 1 else 0.5
    measures = "uncertain_share" in basins
    if measures:
        fig, (ax, zax, fax) = plt.subplots(1, 3, figsize=(16.5, 5.6), layout="constrained",
                                           gridspec_kw={"width_ratios": [1.15, 1, 1]})
    else:
        fig, ax = plt.subplots(figsize=(6.4, 5.6), layout="constrained")
    cmap = ListedColormap(colors or ["w"])
    norm = BoundaryNorm(np.arange(-0.5, max(k, 1) + 0.5), max(k, 1))
    ax.imshow(np.ma.masked_less(labels, 0), origin="lower", aspect="auto",
              interpolation="nearest", cmap=cmap, norm=norm,
              extent=(q[0] - dq, q[-1] + dq, v[0] - dv, v[-1] + dv))
    handles = []
    for i in range(k):
        share = float(basins["basin_fraction"].values[i])
        if kinds[i] == 1:
            label = f"{int(periods[i])}T orbit ({share:.0%})"
            # the transient's last m points: the m-periodic orbit's stroboscopic points (the
            # earlier ones are its approach)
            pts_q = basins["strobe_q"].values[i][-int(periods[i]):]
            pts_v = basins["strobe_v"].values[i][-int(periods[i]):]
            ax.scatter(pts_q, pts_v, s=40, marker="X", color=colors[i], edgecolors="k",
                       lw=0.8, zorder=3)
        else:
            label = f"{names[int(kinds[i])]} ({share:.0%})"
        handles.append(Patch(facecolor=colors[i], edgecolor="k", lw=0.4, label=label))
    ax.set_xlim(q[0] - dq, q[-1] + dq)
    ax.set_ylim(v[0] - dv, v[-1] + dv)
    ax.set_xlabel("q at tau = 0")
    ax.set_ylabel("dq/dtau at tau = 0")
    a = basins.attrs
    ax.set_title(title or (
        f"Basins at omega = {a['omega']:g}, sigma = {a['sigma']:g}, zeta = {a['zeta']:g}\n"
        f"S_b = {float(basins['basin_entropy']):.3f}{_pm(basins, 'basin_entropy')}, S_bb = "
        f"{float(basins['boundary_basin_entropy']):.3f}{_pm(basins, 'boundary_basin_entropy')}"
        f" nats (boxes of "
        f"{a['box_side']} x {a['box_side']} cells; log 2 = 0.693)"), fontsize=9)
    ax.legend(handles=handles, fontsize=7, loc="upper right",
              title="X: stroboscopic points", title_fontsize=7)
    if measures:
        rows, cols = zoom_window(labels)
        zq, zv = q[cols], v[rows]
        zax.imshow(np.ma.masked_less(labels[rows, cols], 0), origin="lower", aspect="auto",
                   interpolation="nearest", cmap=cmap, norm=norm,
                   extent=(zq[0] - dq, zq[-1] + dq, zv[0] - dv, zv[-1] + dv))
        ax.add_patch(Rectangle((zq[0] - dq, zv[0] - dv), zq[-1] - zq[0] + 2 * dq,
                               zv[-1] - zv[0] + 2 * dv, fill=False, ec="k", lw=1.2))
        zax.set_xlabel("q at tau = 0")
        zax.set_ylabel("dq/dtau at tau = 0")
        zax.set_title(f"zoom: the window with the most boundary cells "
                      f"({labels[rows, cols].shape[1]} x {labels[rows, cols].shape[0]} cells)",
                      fontsize=9)
        eps = basins["epsilon"].values
        f = basins["uncertain_share"].values
        alpha = float(basins["uncertainty_exponent"])
        err = float(basins["uncertainty_exponent_error"])
        fax.loglog(eps, f, "o", color="k", label="f(eps), the map's cells")
        ok = np.isfinite(f) & (f > 0)
        if ok.sum() >= 2 and np.isfinite(alpha):
            c = np.exp(np.mean(np.log(f[ok]) - alpha * np.log(eps[ok])))
            fax.loglog(eps, c * eps ** alpha, "-", color="tab:red",
                       label=f"fit: alpha = {alpha:.3f} +- {err:.3f}")
            ref = f[ok][0] * (eps / eps[ok][0])
            fax.loglog(eps[ref <= 1], ref[ref <= 1], ":", color="0.5",
                       label="alpha = 1 (a smooth boundary)")
        fax.set_xlabel("eps (cells)")
        fax.set_ylabel("share of eps-uncertain states f(eps)")
        wada = "Wada" if int(basins["wada"]) else "not Wada"
        fax.set_title(
            f"boundary dimension d = 2 - alpha = {float(basins['boundary_dimension']):.3f} "
            f"+- {err:.3f}\nmerging test: {wada} (largest distance "
            f"{float(basins['wada_hausdorff_max']):.1f} cells, r = {a.get('wada_dilation', 5)};"
            f"\nWada cells {100 * float(basins['wada_share']):.1f} % of the boundary)",
            fontsize=9)
        fax.legend(fontsize=8)
        fax.grid(True, which="both", alpha=0.3)
    return save(fig, path)


def _pm(basins, name: str) -> str:
    err = f"{name}_error"
    return f" +- {float(basins[err]):.3f}" if err in basins else ""
