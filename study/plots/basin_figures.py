"""The basin map of one grid point (``hertzmap basins``).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from hertzmap.study.plots.style import save
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.patches import Patch


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
    fig, ax = plt.subplots(figsize=(6.4, 5.6), layout="constrained")
    ax.imshow(np.ma.masked_less(labels, 0), origin="lower", aspect="auto",
              interpolation="nearest", cmap=ListedColormap(colors or ["w"]),
              norm=BoundaryNorm(np.arange(-0.5, max(k, 1) + 0.5), max(k, 1)),
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
        f"S_b = {float(basins['basin_entropy']):.3f}, S_bb = "
        f"{float(basins['boundary_basin_entropy']):.3f} nats (boxes of "
        f"{a['box_side']} x {a['box_side']} cells; log 2 = 0.693)"), fontsize=9)
    ax.legend(handles=handles, fontsize=7, loc="upper right",
              title="X: stroboscopic points", title_fontsize=7)
    return save(fig, path)
