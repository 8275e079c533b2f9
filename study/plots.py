"""PNG figures from a study's store (and the paper's analytic figures), matplotlib Agg.

Entry points:

* :func:`plot_results` - the figures of a study's products, into a folder: a loop over the
  registry (``study.products.catalog``), each product drawing its figures. ``hertzmap plot
  STORE [--out DIR] [--which ...]`` computes the products, stores them and calls it with the
  stored groups.
* :func:`plot_paper` - the paper's analytic figures that need no store (Fig. 2, 3, 4, 5):
  ``hertzmap plot --paper fig02 fig03 fig04 fig05``.
* One function per figure (``plot_loss_of_contact_map``, ``plot_map_measures``,
  ``plot_lyapunov_map``, ``plot_bifurcation_set``, ``plot_frequency_response``,
  ``plot_force_harmonics``, ``plot_bifurcation_diagram``, ``plot_time_histories``,
  ``paper_fig02`` ... ``paper_fig05``), each taking products and a path; the registry names
  them (``Figure.plot``) and :data:`_DRAW` says which PNGs of a store each draws.

No product of a store is computed here: a store's figure draws the products it is given
(the paper's analytic figures compute their multiple-scales curves).

No Dask, no scheduler, no store writes. Figures are small (about 100 dpi) so that they can be
committed.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from hertzmap.kernels.model import TAYLOR_CONTACT_LOSS  # noqa: E402
from hertzmap.study import products as P  # noqa: E402
from hertzmap.study.products.catalog import NAMED_FREQUENCIES, WHICH, check_which  # noqa: E402
from hertzmap.study.analytic import multiple_scales as mms  # noqa: E402
from hertzmap.study.analytic.rig import restoring_force  # noqa: E402
from hertzmap.study.orbit_rules import CLASS_LABELS  # noqa: E402

__all__ = [
    "WHICH",
    "PAPER_FIGURES",
    "plot_results",
    "plot_paper",
    "plot_loss_of_contact_map",
    "plot_map_measures",
    "plot_bifurcation_set",
    "plot_frequency_response",
    "plot_force_harmonics",
    "plot_time_histories",
    "plot_thresholds",
    "plot_zeta_maps",
    "plot_impact_onset",
    "plot_lyapunov_map",
    "plot_bifurcation_diagram",
    "plot_basin_map",
    "paper_fig02",
    "paper_fig03",
    "paper_fig04",
    "paper_fig05",
]

DPI = 100

#: Colour and legend label of each orbit class (study.orbit_rules codes 1..8).
_CLASS_COLORS = {1: "tab:blue", 2: "tab:green", 3: "tab:red", 4: "#9ecae1", 5: "#fcae91",
                 6: "tab:purple", 7: "#c6c6c6", 8: "#dadaeb", 9: "#e7298a", 10: "#fbb4d9"}
CLASS_STYLE = {code: (color, CLASS_LABELS[code]) for code, color in _CLASS_COLORS.items()}

#: Labels and colours of the loss-of-contact map's classes (``map_class``, study.products.maps:
#: 0-15 the stable_set combinations, 16-19 longer periods and the census's attractors).
SET_LABELS = {
    0: "no stable response",
    1: "1T in contact",
    2: "1T, contact loss",
    3: "1T contact / 1T contact loss",
    4: "2T in contact",
    5: "1T / 2T in contact",
    6: "1T loss / 2T contact",
    7: "1T / 1T loss / 2T",
    8: "2T, contact loss",
    9: "1T contact / 2T loss",
    10: "1T loss / 2T loss",
    11: "1T / 1T loss / 2T loss",
    12: "2T contact / 2T loss",
    13: "1T / 2T / 2T loss",
    14: "1T loss / 2T / 2T loss",
    15: "all four",
    16: "stable period m >= 3",
    17: "non-periodic (chaotic)",
    18: "unsettled transients",
    19: "chaotic beside stable orbits",
}
SET_COLORS = {
    0: "#ffffff", 1: "#deebf7", 2: "#6a51a3", 3: "#9e9ac8", 4: "#a1d99b", 5: "#41ab5d",
    6: "#807dba", 7: "#54278f", 8: "#de2d26", 9: "#fcbba1", 10: "#a50f15", 11: "#fb6a4a",
    12: "#fd8d3c", 13: "#fdae6b", 14: "#7f2704", 15: "#000000",
    16: "#e7298a", 17: "#ffd92f", 18: "#b3b3b3", 19: "#a6761d",
}

_CURVE_STYLE = {
    "flip_1T": dict(color="k", lw=1.6, ls="-", label="flip of 1T (numerical)"),
    "grazing_1T": dict(color="tab:purple", lw=1.2, ls="--", label="grazing of 1T"),
    "grazing_2T": dict(color="tab:red", lw=1.2, ls="--", label="grazing of stable 2T"),
    "boundary_2T": dict(color="tab:orange", lw=1.0, ls="-", label="2T existence boundary"),
    "isola": dict(color="magenta", lw=1.6, ls=":", label="isola (heuristic)"),
    "coexistence_1T": dict(color="tab:cyan", lw=1.0, ls="-.", label="1T coexistence (folds)"),
}


def _save(fig, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def _zlabel(z: float) -> str:
    return f"zeta = {z:g}"


def _draw_curves(ax, curves, zeta, names, labelled=None):
    """Grid contours of ``names``: names, or (name, label suffix) pairs."""
    labelled = set() if labelled is None else labelled
    for name in names:
        name, suffix = (name, "") if isinstance(name, str) else name
        st = dict(_CURVE_STYLE[name])
        label = st.pop("label") + suffix
        for seg in P.curve_segments(curves, name, zeta):
            ax.plot(seg[:, 0], seg[:, 1], **st, label=None if name in labelled else label)
            labelled.add(name)
    return labelled


def _draw_mms(ax, mms, zeta, sigma1=True):
    if mms is None:
        return
    m = mms.sel(zeta=zeta, method="nearest")
    ax.plot(m["omega"], m["sigma2"], color="tab:blue", lw=1.0, label="MMS sigma2 (flip)")
    if sigma1:
        ax.plot(m["omega"], m["sigma1"], color="tab:blue", lw=1.0, ls=":", label="MMS sigma1")


# ---------------------------------------------------------------------------------------------
# traced curves (products/traced_curves): drawn instead of the grid's contours where present
# ---------------------------------------------------------------------------------------------

#: Style of each traced curve (kind, period).
_TRACED_STYLE = {
    ("flip", 1): dict(color="k", lw=1.6, ls="-", label="flip of 1T (traced)"),
    ("flip", 2): dict(color="0.35", lw=1.2, ls="--", label="flip of 2T, 2T -> 4T (traced)"),
    ("fold", 1): dict(color="tab:cyan", lw=1.4, ls="-", label="fold of 1T (traced)"),
    ("fold", 2): dict(color="tab:orange", lw=1.8, ls="-",
                      label="fold of 2T (traced; the isola boundary)"),
    ("grazing", 1): dict(color="tab:purple", lw=1.2, ls="--", label="grazing of 1T (traced)"),
    ("grazing", 2): dict(color="tab:red", lw=1.2, ls="--", label="grazing of 2T (traced)"),
}
#: Traced curves of the census's orbits of longer periods (m >= 3), one style per kind.
_TRACED_LONGER_STYLE = {
    "fold": dict(color="tab:green", lw=1.3, ls="-.",
                 label="fold of mT, m >= 3 (traced; where stable mT orbits end)"),
    "flip": dict(color="tab:olive", lw=1.0, ls=":", label="flip of mT, m >= 3 (traced)"),
}
#: The grid contour each traced (kind, period) replaces (study.products.bifurcation_curves CURVES names).
_GRID_FOR_TRACED = {"flip_1T": ("flip", 1), "grazing_1T": ("grazing", 1),
                    "grazing_2T": ("grazing", 2), "boundary_2T": ("fold", 2),
                    "isola": ("fold", 2), "coexistence_1T": ("fold", 1)}
_CODIM2_STYLE = {1: ("v", "cusp"), 2: ("*", "fold meets flip (isola joins)"),
                 3: ("D", "grazing meets fold"), 4: ("s", "grazing meets flip")}


def _draw_traced(ax, traced, zeta, isola=None) -> None:
    """The traced curves of the (omega, sigma) plane at ``zeta``, their codimension-2 points
    and sigma** of the isola (``isola``: the isola_boundary product)."""
    if traced is None or not traced.sizes.get("vertex", 0):
        return
    longer = sorted({int(m) for m in np.unique(traced["curve_period"].values) if m >= 3})
    # (kind, period, style, legend entry): one entry per style, the mT curves of every m under one
    entries = [(kind, period, style, (kind, period))
               for (kind, period), style in _TRACED_STYLE.items()]
    entries += [(kind, m, style, (kind, "m>=3"))
                for kind, style in _TRACED_LONGER_STYLE.items() for m in longer]
    drawn = set()
    for kind, period, style, key in entries:
        st = dict(style)
        label = st.pop("label")
        for seg in P.traced_segments(traced, kind=kind, period=period, zeta=zeta):
            ax.plot(seg[:, 0], seg[:, 1], **st, label=None if key in drawn else label)
            drawn.add(key)
    c2 = traced.sizes.get("codim2", 0)
    if c2:
        z = np.isclose(traced["codim2_zeta"].values, zeta)
        plane = traced["curve_plane"].values[traced["codim2_curve"].values] == 1
        for code, (marker, label) in _CODIM2_STYLE.items():
            sel = z & plane & (traced["codim2_kind"].values == code)
            if sel.any():
                ax.plot(traced["codim2_omega"].values[sel], traced["codim2_sigma"].values[sel],
                        marker, ms=8, mfc="gold", mec="k", ls="none", zorder=5,
                        label=f"{label} (codim 2)")
    if ("fold", 2) in drawn and isola is not None:
        if isola.sizes["zeta"] and np.isclose(isola["zeta"].values, zeta).any():
            row = isola.sel(zeta=zeta, method="nearest")
            if np.isfinite(float(row["sigma_isola"])):
                ax.plot(float(row["omega_isola"]), float(row["sigma_isola"]), "X", ms=9,
                        mfc="tab:orange", mec="k", ls="none", zorder=5,
                        label=f"sigma** = {float(row['sigma_isola']):.6f} (isola)")


def _grid_fallback(traced, zeta, names):
    """The grid contours to draw when curves were asked for but some are missing: (name,
    label suffix with the reason) for each grid curve whose traced counterpart is absent."""
    if traced is None:
        return [(n, "") for n in names]
    present = set()
    for kind_period in set(_GRID_FOR_TRACED.values()):
        if P.traced_segments(traced, kind=kind_period[0], period=kind_period[1], zeta=zeta):
            present.add(kind_period)
    failed = {}
    for f in P.failed_traces(traced, zeta):
        kind = {1: "fold", 2: "flip", 3: "grazing"}[f["kind"]]
        failed.setdefault((kind, f["period"]), f["status"])
    out = []
    for n in names:
        kp = _GRID_FOR_TRACED.get(n)
        if kp is None or kp in present:
            continue
        reason = (f"trace failed: {failed[kp]}" if kp in failed
                  else "no grid cell with a sign change to trace from")
        out.append((n, f" (grid; not traced: {reason})"))
    return out


# ---------------------------------------------------------------------------------------------
# maps
# ---------------------------------------------------------------------------------------------

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
    _draw_traced(ax, traced, zeta, isola)
    _draw_curves(ax, curves, zeta, _grid_fallback(traced, zeta, ("flip_1T", "grazing_1T",
                                                                   "grazing_2T", "isola")))
    _draw_mms(ax, mms, zeta, sigma1=False)
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
    ax.set_title(title or f"Stable responses and contact loss, {_zlabel(zeta)}")
    h2, l2 = ax.get_legend_handles_labels()
    ax.legend(handles=handles + h2, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
              title="stable responses / curves", title_fontsize=7, frameon=False)
    return _save(fig, path)


#: the side-by-side maps of a study of several zeta values: at most this many, evenly spread
#: from the first zeta to the last
ZETA_MAPS = 4


def plot_zeta_maps(lcm, curves, path, *, zetas, mms=None, traced=None, isola=None) -> Path:
    """The maps of stable responses (plot_loss_of_contact_map) at the ``zetas`` side by side,
    on one sigma axis: how damping moves the flip curve and the isola."""
    fig, axes = plt.subplots(1, len(zetas), figsize=(3.6 * len(zetas) + 2.2, 4.4),
                             layout="constrained", sharey=True, squeeze=False)
    handles = {}
    for ax, z in zip(axes[0], zetas):
        for h in _map_panel(ax, lcm, curves, float(z), mms, traced, isola):
            handles[h.get_label()] = h
        ax.set_title(_zlabel(float(z)), fontsize=9)
        ax.set_xlabel("omega")
    axes[0, 0].set_ylabel("sigma")
    h2, l2 = axes[0, -1].get_legend_handles_labels()
    axes[0, -1].legend(handles=list(handles.values()) + h2, fontsize=6, loc="upper left",
                       bbox_to_anchor=(1.01, 1.0), frameon=False)
    fig.suptitle("Stable responses and contact loss as damping grows", fontsize=10)
    return _save(fig, path)


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
    return _save(fig, path)


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
            _draw_curves(ax, curves, zeta, ("flip_1T",))
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("omega")
    axes[0].set_ylabel("sigma")
    fig.suptitle(f"Multistability and contact loss of the stable responses, {_zlabel(zeta)}",
                 fontsize=10)
    return _save(fig, path)


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
    ax.set_title(title or f"Largest Lyapunov exponent of the attractors, {_zlabel(zeta)} "
                 "(black: chaos)", fontsize=10)
    return _save(fig, path)


def plot_bifurcation_diagram(diag, path, *, title=None) -> Path:
    """The brute-force bifurcation diagram (study.products.stroboscopic_diagram): stroboscopic q
    of every attractor against omega, with the stored orbits' start points over it."""
    fig, ax = plt.subplots(figsize=(8.2, 4.6), layout="constrained")
    kind = diag["strobe_kind"].values
    st = diag["orbit_stable"].values
    # the unstable orbits first, faint: on the vibro-impact lines the census's close returns
    # find many orbits embedded in the chaotic set
    if (~st).any():
        ax.scatter(diag["orbit_omega"].values[~st], diag["orbit_q0"].values[~st], s=2,
                   color="0.6", alpha=0.5, lw=0, label="stored orbit, unstable")
    styles = {1: ("k", "periodic attractor"), 2: ("tab:red", "non-periodic (chaotic)"),
              3: ("tab:orange", "unsettled transient")}
    for k, (color, label) in styles.items():
        sel = kind == k
        if sel.any():
            ax.scatter(diag["strobe_omega"].values[sel], diag["strobe_q"].values[sel], s=3,
                       color=color, lw=0, alpha=0.8, label=label)
    if st.any():
        ax.scatter(diag["orbit_omega"].values[st], diag["orbit_q0"].values[st], s=12,
                   facecolors="none", edgecolors="tab:blue", lw=0.8, label="stored orbit, stable")
    q = np.concatenate([diag["strobe_q"].values, diag["orbit_q0"].values])
    if q.size and np.nanmin(q) < -20:
        # flights reach q ~ -600 at low omega while the orbits in contact sit near 0
        ax.set_yscale("symlog", linthresh=2.0)
    ax.set_xlabel("omega")
    ax.set_ylabel("q at tau = 0 mod T")
    ax.set_title(title or f"Stroboscopic bifurcation diagram, sigma = {diag.attrs['sigma']:g}, "
                 f"zeta = {diag.attrs['zeta']:g}", fontsize=10)
    ax.legend(fontsize=7, loc="lower right", markerscale=2.5)
    return _save(fig, path)


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
    return _save(fig, path)


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
        _draw_mms(ax, mms, zeta)
        _draw_traced(ax, traced, zeta, isola)
        fallback = _grid_fallback(traced, zeta, ("flip_1T", "boundary_2T", "isola"))
        if any(n == "isola" for n, _ in fallback):
            _shade_isola_cells(ax, lcm, zeta)
        _draw_curves(ax, curves, zeta, fallback)
        return _finish_bifurcation_set(fig, ax, path, omega_range, sigma_range,
                                       title or f"Bifurcation set (traced curves), {_zlabel(zeta)}",
                                       legend_size=6.5)
    _shade_isola_cells(ax, lcm, zeta)
    _draw_mms(ax, mms, zeta)
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
        _draw_curves(ax, curves, zeta, ("isola",))
    else:
        for seg in P.curve_segments(curves, "flip_1T", zeta):
            step = max(1, len(seg) // 40)
            ax.plot(seg[::step, 0], seg[::step, 1], "s", mfc="none", mec="k", ms=4)
        ax.plot([], [], "s", mfc="none", mec="k", ms=4, label="flip of 1T (shooting, contoured)")
        _draw_curves(ax, curves, zeta, ("boundary_2T", "isola"))
    return _finish_bifurcation_set(fig, ax, path, omega_range, sigma_range,
                                   title or f"Bifurcation set, {_zlabel(zeta)}", legend_size=7)


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
    return _save(fig, path)


# ---------------------------------------------------------------------------------------------
# lines
# ---------------------------------------------------------------------------------------------

def plot_frequency_response(fr, path, *, sigma=None, zeta=None, zoom=None, mms=None,
                            title=None) -> Path:
    """Peak-to-peak q against omega, every orbit coloured by its class (paper Fig. 6, 8, 10).
    ``zoom`` = (omega_min, omega_max) adds a detail panel (Fig. 6b)."""
    line = fr.sel(sigma=fr["sigma"].values[0] if sigma is None else sigma, method="nearest")
    line = line.sel(zeta=line["zeta"].values[0] if zeta is None else zeta, method="nearest")
    ncols = 2 if zoom else 1
    fig, axes = plt.subplots(1, ncols, figsize=(6.2 * ncols, 4.3), layout="constrained",
                             squeeze=False)
    cls = line["orbit_class"].values
    om = np.broadcast_to(line["omega"].values[:, None], cls.shape)
    ptp = line["ptp"].values
    for ax in axes[0]:
        for c, (color, label) in CLASS_STYLE.items():
            sel = cls == c
            if not sel.any():
                continue
            stable = c in (1, 2, 3, 6)
            ax.plot(om[sel], ptp[sel], "o" if stable else ".", ms=3 if stable else 2.5,
                    color=color, label=label, ls="none", zorder=3 if stable else 2)
        if mms is not None:
            mm = mms.sel(sigma=float(line["sigma"]), zeta=float(line["zeta"]), method="nearest")
            # MMS ptp of the 2T response is about 2 A plus the 1T part; show 2A for reference
            ax.plot(mm["omega"], 2 * mm["A_upper"], color="k", lw=0.8, label="MMS 2A (upper)")
            ax.plot(mm["omega"], 2 * mm["A_lower"], color="k", lw=0.8, ls="--",
                    label="MMS 2A (lower)")
        ax.set_xlabel("omega")
        ax.set_ylabel("peak-to-peak q")
    if zoom:
        ax = axes[0][1]
        ax.set_xlim(*zoom)
        inside = (om >= zoom[0]) & (om <= zoom[1]) & np.isfinite(ptp)
        if inside.any():
            ax.set_ylim(0, 1.08 * float(np.nanmax(ptp[inside])))
        ax.set_title("detail", fontsize=9)
    axes[0][0].legend(fontsize=7, loc="upper left")
    fig.suptitle(title or f"Frequency response, sigma = {float(line['sigma']):g}, "
                 f"{_zlabel(float(line['zeta']))}", fontsize=10)
    if "frequency_hz" in line.coords:
        f0 = float(line.attrs.get("rig_f0_hz", np.nan))
        sec = axes[0][0].secondary_xaxis("top", functions=(lambda w: w * f0, lambda f: f / f0))
        sec.set_xlabel("excitation frequency [Hz]", fontsize=8)
    return _save(fig, path)


def plot_force_harmonics(fh, path, *, sigma=None, zeta=None, title=None) -> Path:
    """Contact-force harmonics of the stable responses against omega (Fig. 12-13 counterpart):
    H1 (at omega), H2 (at 2 omega) and the subharmonic H1/2 (at omega/2)."""
    line = fh.sel(sigma=fh["sigma"].values[0] if sigma is None else sigma, method="nearest")
    line = line.sel(zeta=line["zeta"].values[0] if zeta is None else zeta, method="nearest")
    rig = "force_amplitude_N" in line
    amp = line["force_amplitude_N" if rig else "force_amplitude"]
    unit = "N" if rig else "F/N"
    xname = "frequency_hz" if "frequency_hz" in line.coords else "omega"
    x = line[xname].values
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), layout="constrained")
    cls = line["orbit_class"].values
    for ax, r, name in zip(axes, (1.0, 2.0, 0.5), ("H1 (excitation frequency)",
                                                   "H2 (twice the excitation frequency)",
                                                   "H1/2 (subharmonic)")):
        a = amp.sel(ratio=r).values
        for c, (color, label) in CLASS_STYLE.items():
            sel = cls == c
            if not sel.any():
                continue
            xx = np.broadcast_to(x[:, None], cls.shape)[sel]
            stable = c in (1, 2, 3, 6)
            ax.plot(xx, a[sel], "o" if stable else ".", ms=3 if stable else 2, color=color,
                    label=label, ls="none")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("excitation frequency [Hz]" if xname == "frequency_hz" else "omega")
        ax.set_ylabel(f"amplitude [{unit}]")
    axes[0].legend(fontsize=7)
    fig.suptitle(title or f"Contact-force harmonics, sigma = {float(line['sigma']):g}, "
                 f"{_zlabel(float(line['zeta']))}", fontsize=10)
    return _save(fig, path)


def plot_time_histories(th, path, *, title=None, max_cases=6, largest_only=True) -> Path:
    """F_exp against forcing cycles omega tau / 2 pi (paper Fig. 14-15), one panel per orbit.

    ``largest_only``: one panel per omega, the orbit of largest ptp (the resonant response,
    reached sweeping omega down as in the experiment); else every orbit of the product."""
    if largest_only and th.sizes["case"] and "ptp" in th.coords:
        keep = []
        for w in np.unique(th["omega"].values)[::-1]:
            idx = np.flatnonzero(th["omega"].values == w)
            keep.append(int(idx[np.nanargmax(np.nan_to_num(th["ptp"].values[idx], nan=-1.0))]))
        th = th.isel(case=keep)
    n = min(int(th.sizes["case"]), max_cases)
    fig, axes = plt.subplots(n, 1, figsize=(6.5, 1.6 * n + 0.7), layout="constrained",
                             squeeze=False, sharex=True)
    for i in range(n):
        ax = axes[i][0]
        c = th.isel(case=i)
        ax.plot(c["time"], c["F_exp"], color="k", lw=1.0)
        ax.axhline(-1.0, color="tab:red", lw=0.6, ls=":")
        ax.set_ylabel("F_exp")
        ax.text(0.01, 0.95, f"omega = {float(c['omega']):.4g}, {int(c['period'])}T"
                + ("" if bool(c["stable"]) else " (unstable)"), transform=ax.transAxes,
                va="top", fontsize=8)
    axes[-1][0].set_xlabel("omega tau / 2 pi (forcing cycles)")
    fig.suptitle(title or f"Normal force F_exp = F/N - 1, sigma = {th.attrs.get('sigma', '')}, "
                 f"zeta = {th.attrs.get('zeta', '')}", fontsize=10)
    return _save(fig, path)


# ---------------------------------------------------------------------------------------------
# the paper's analytic figures
# ---------------------------------------------------------------------------------------------

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
    return _save(fig, path)


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
    _draw_mms(ax, cur, zeta)
    for lbl, (x, y) in {"I": (2.0, 0.7), "II": (1.94, 0.42), "III": (2.07, 0.15)}.items():
        ax.text(x, y, lbl, fontsize=12, ha="center")
    ax.set_xlabel("omega")
    ax.set_ylabel("sigma")
    ax.set_title(f"Fig. 3: MMS bifurcation set, zeta = {zeta:g}", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    return _save(fig, path)


def paper_fig04(path, sigma=0.5, zeta=0.01) -> Path:
    """Fig. 4: MMS subharmonic amplitude A(omega), softening (sigma = 0.5, zeta = 0.01)."""
    r = P.mms_response(np.linspace(1.5, 2.3, 1601), sigma, zeta)
    fig, ax = plt.subplots(figsize=(5.5, 4), layout="constrained")
    ax.plot(r["omega"], r["A_upper"], "k", lw=1.8, label="stable (+ root)")
    ax.plot(r["omega"], r["A_lower"], "k", lw=0.8, ls="--", label="unstable (- root)")
    ax.plot([1.5, 2.3], [0, 0], color="0.5", lw=0.8, label="trivial (A = 0)")
    ax.set_xlabel("omega")
    ax.set_ylabel("A")
    ax.set_title(f"Fig. 4: MMS amplitude, sigma = {sigma:g}, zeta = {zeta:g}", fontsize=10)
    ax.legend(fontsize=8)
    return _save(fig, path)


def paper_fig05(path, sigma=0.5, zeta=0.01, fr=None) -> Path:
    """Fig. 5: min q of the MMS subharmonic response against omega, with the Taylor contact-loss
    level (kernels.model.TAYLOR_CONTACT_LOSS, Eq. 12); optionally the numerical stable 2T orbits of a store (``fr``)."""
    r = P.mms_response(np.linspace(1.5, 2.3, 1601), sigma, zeta)
    fig, ax = plt.subplots(figsize=(5.5, 4), layout="constrained")
    ax.plot(r["omega"], r["min_q_upper"], "k", lw=1.8, label="MMS, stable branch")
    ax.plot(r["omega"], r["min_q_lower"], "k", lw=0.8, ls="--", label="MMS, unstable branch")
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
    return _save(fig, path)


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
    return _save(fig, path)


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


# ---------------------------------------------------------------------------------------------
# a whole store
# ---------------------------------------------------------------------------------------------

def _zoom_for(fr, sigma, zeta):
    """(1.85, 2.1) when the line is wider and has 2T orbits there (the detail of Fig. 6b)."""
    line = fr.sel(sigma=sigma, zeta=zeta, method="nearest")
    om = line["omega"].values
    if not (om.min() < 1.85 and om.max() > 2.05):
        return None
    near = (om >= 1.85) & (om <= 2.1)
    if not (line["period"].values[near] == 2).any():
        return None
    return (1.85, min(float(om.max()), 2.1))


@dataclass(frozen=True)
class _Sheet:
    """What the figures of one store share: its grid, the folder and the files' prefix."""
    omega: np.ndarray
    sigma: np.ndarray
    zeta: np.ndarray
    out: Path
    name: str
    #: the store has several zeta values (its files of one zeta are tagged with it, also when
    #: only one is drawn: plot_results' ``zeta``)
    several_zeta: bool = False

    @property
    def is_map(self) -> bool:
        """Maps and bifurcation sets need >= 2 omega and >= 2 sigma."""
        return self.omega.size >= 2 and self.sigma.size >= 2

    @property
    def lines(self) -> int:
        return self.sigma.size * self.zeta.size

    @property
    def named_frequencies(self) -> bool:
        """A scene of a few named frequencies (study.products.catalog): its figure is the time
        histories; response and harmonics only when asked for."""
        return self.omega.size <= NAMED_FREQUENCIES

    def path(self, which: str, tag: str = "") -> Path:
        return self.out / f"{self.name}_{which}{tag}.png"

    def zeta_tag(self, z) -> str:
        return f"_zeta{z:g}" if self.several_zeta or self.zeta.size > 1 else ""

    def line_tag(self, s, z, *, always: bool = False) -> str:
        """The files' tag of line (s, z): none for a study of one line, unless ``always``."""
        return (f"_sigma{s:g}" + self.zeta_tag(z) if always or self.lines > 1 or self.several_zeta
                else "")


def _map_figure(sheet, prods, asked) -> list[Path]:
    if not sheet.is_map:
        return []
    return [plot_loss_of_contact_map(prods["loss_of_contact_map"], prods["bifurcation_curves"],
                                     sheet.path("map", sheet.zeta_tag(z)), zeta=z,
                                     mms=prods["mms_curves"], traced=prods.get("traced_curves"),
                                     isola=prods.get("isola_boundary"))
            for z in sheet.zeta]


def _measures_figure(sheet, prods, asked) -> list[Path]:
    if not sheet.is_map:
        return []
    return [plot_map_measures(prods["loss_of_contact_map"],
                              sheet.path("measures", sheet.zeta_tag(z)), zeta=z,
                              curves=prods["bifurcation_curves"])
            for z in sheet.zeta]


def _lyapunov_figure(sheet, prods, asked) -> list[Path]:
    lcm = prods["loss_of_contact_map"]
    if not (sheet.is_map and "lyapunov_exponent" in lcm
            and np.isfinite(lcm["lyapunov_exponent"].values).any()):
        return []
    return [plot_lyapunov_map(lcm, sheet.path("lyapunov", sheet.zeta_tag(z)), zeta=z)
            for z in sheet.zeta]


def _bifurcation_figure(sheet, prods, asked) -> list[Path]:
    if not sheet.is_map:
        return []
    return [plot_bifurcation_set(prods["bifurcation_curves"], prods["mms_curves"],
                                 sheet.path("bifurcation", sheet.zeta_tag(z)), zeta=z,
                                 lcm=prods["loss_of_contact_map"],
                                 omega_range=(float(sheet.omega.min()), float(sheet.omega.max())),
                                 sigma_range=(float(sheet.sigma.min()), float(sheet.sigma.max())),
                                 located=prods.get("located_bifurcations"),
                                 traced=prods.get("traced_curves"),
                                 isola=prods.get("isola_boundary"))
            for z in sheet.zeta]


#: response figures unless asked for: studies of at most this many (sigma, zeta) lines
RESPONSE_FIGURE_LINES = 8
#: harmonics figures: the first this many sigma and zeta values
HARMONICS_FIGURE_LINES = (4, 2)


def _response_figure(sheet, prods, asked) -> list[Path]:
    if not (asked or sheet.lines <= RESPONSE_FIGURE_LINES and not sheet.named_frequencies) \
            or sheet.omega.size < 2:
        return []
    fr = prods["frequency_response"]
    return [plot_frequency_response(fr, sheet.path("response", sheet.line_tag(s, z)), sigma=s,
                                    zeta=z, zoom=_zoom_for(fr, s, z), mms=prods.get("mms_response"))
            for s in sheet.sigma for z in sheet.zeta]


def _harmonics_figure(sheet, prods, asked) -> list[Path]:
    if not (asked or not sheet.named_frequencies) or sheet.omega.size < 2:
        return []
    ns, nz = HARMONICS_FIGURE_LINES
    return [plot_force_harmonics(prods["force_harmonics"],
                                 sheet.path("harmonics", sheet.line_tag(s, z)), sigma=s, zeta=z)
            for s in sheet.sigma[:ns] for z in sheet.zeta[:nz]]


def _strobe_figure(sheet, prods, asked) -> list[Path]:
    diagrams = prods["stroboscopic_diagram"]
    paths = []
    for i in range(diagrams.sizes["line"]):
        diag = P.diagram_line(diagrams, i)
        if diag.sizes["point"] and np.isclose(sheet.zeta, diag.attrs["zeta"]).any():
            paths.append(plot_bifurcation_diagram(diag, sheet.path("strobe", sheet.line_tag(
                diag.attrs["sigma"], diag.attrs["zeta"], always=True))))
    return paths


def _zeta_maps_figure(sheet, prods, asked) -> list[Path]:
    if not sheet.is_map or sheet.zeta.size < 2:
        return []
    pick = np.unique(np.linspace(0, sheet.zeta.size - 1, min(ZETA_MAPS, sheet.zeta.size))
                     .round().astype(int))
    return [plot_zeta_maps(prods["loss_of_contact_map"], prods["bifurcation_curves"],
                           sheet.path("zeta_maps"), zetas=sheet.zeta[pick],
                           mms=prods["mms_curves"], traced=prods.get("traced_curves"),
                           isola=prods.get("isola_boundary"))]


def _impact_onset_figure(sheet, prods, asked) -> list[Path]:
    return [plot_impact_onset(prods["impact_onset"], sheet.path("impact_onset"))]


def _thresholds_figure(sheet, prods, asked) -> list[Path]:
    return [plot_thresholds(prods["thresholds"], sheet.path("thresholds"),
                            measured=(P.MEASURED_ZETA, P.MEASURED_STAR_RATIO))]


def _histories_figure(sheet, prods, asked) -> list[Path]:
    th = prods["time_histories"]
    return [plot_time_histories(th, sheet.path("histories"))] if th.sizes["case"] else []


#: How each figure of the registry (study.products.catalog, by its --which name) is drawn for a
#: whole store: which PNGs, for which lines; ``asked``: named in --which (not only "auto").
_DRAW = {"map": _map_figure, "measures": _measures_figure, "lyapunov": _lyapunov_figure,
         "bifurcation": _bifurcation_figure, "response": _response_figure,
         "harmonics": _harmonics_figure, "strobe": _strobe_figure,
         "histories": _histories_figure, "thresholds": _thresholds_figure,
         "zeta_maps": _zeta_maps_figure, "impact_onset": _impact_onset_figure}


def chosen_zeta(zetas, zeta: float) -> float:
    """The store's zeta value nearest ``zeta`` (``hertzmap plot --zeta``); ValueError naming
    the option and the store's range when ``zeta`` lies outside it (beyond half a step)."""
    zs = np.sort(np.asarray(zetas, float))
    step = float(np.min(np.diff(zs))) if zs.size > 1 else 0.0
    if not (zs[0] - 0.5 * step - 1e-12 <= zeta <= zs[-1] + 0.5 * step + 1e-12):
        raise ValueError(f"--zeta {zeta:g} is outside the store's zeta values "
                         f"{zs[0]:g} .. {zs[-1]:g} ({zs.size} values)")
    return float(zs[np.argmin(np.abs(zs - zeta))])


def plot_results(ds, prods, out: str | Path = "results", which: Sequence[str] = ("auto",),
                 *, prefix: str | None = None, zeta: float | None = None) -> list[Path]:
    """The figures of the products ``prods`` (by name: ``hertzmap plot`` passes the groups it
    has just stored, read back from the store), into ``out`` as
    ``<study>_<figure>[_...].png``. Returns the paths.

    A loop over the registry (study.products.catalog.PRODUCTS): each product in ``prods``
    draws its figures. ``ds``: the results (study.products.open_store; its grid and name only).
    ``which``: "auto" (every figure the products support), or names from :data:`WHICH`. Maps
    and bifurcation sets need >= 2 omega and >= 2 sigma; response curves are drawn unless asked
    for only for studies of at most :data:`RESPONSE_FIGURE_LINES` (sigma, zeta) lines and more
    than a few named frequencies, harmonics only for the latter. ``zeta``: the figures of that
    zeta value only (the store's nearest: :func:`chosen_zeta`); by default every figure drawn
    per zeta is drawn for each of the store's zeta values.
    """
    which = check_which(which)
    zetas = np.asarray(ds["zeta"].values, float)
    sheet = _Sheet(ds["omega"].values, ds["sigma"].values,
                   zetas if zeta is None else np.array([chosen_zeta(zetas, zeta)]), Path(out),
                   prefix or ds.attrs.get("hertzmap_study_name") or "study",
                   several_zeta=zetas.size > 1)
    paths: list[Path] = []
    for product in P.PRODUCTS:
        if product.name not in prods:
            continue
        for figure in product.figures:
            if "auto" in which or figure.which in which:
                paths += _DRAW[figure.which](sheet, prods, figure.which in which)
    return paths
