"""The figures' shared look: colours and labels of the orbit classes and of the map's kinds of
response, the styles of the curves drawn over a plane, how a figure is saved.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")       # files only, never a window: before pyplot is imported
import matplotlib.pyplot as plt
from matplotlib.patches import Patch
import numpy as np
from hertzmap.study import products as P
from hertzmap.study.orbit_rules import CLASS_LABELS

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


#: a map's legend with more entries than this takes two columns, the figure this much wider
LEGEND_ROWS = 16
LEGEND_COLUMN_INCHES = 3.0


def curves_legend(fig, kinds, curves, fontsize=7) -> None:
    """A map's legend beside its axes, outside them (constrained layout keeps room for it):
    the kinds of response (patches), then the curves drawn over them; a long one in two
    columns, the kinds in the first and the curves in the second."""
    handles = list(kinds) + list(curves)
    ncols = 1
    if len(handles) > LEGEND_ROWS and kinds and curves:
        rows = max(len(kinds), len(curves))
        blank = lambda: Patch(visible=False, label=" ")
        handles = (list(kinds) + [blank() for _ in range(rows - len(kinds))]
                   + list(curves) + [blank() for _ in range(rows - len(curves))])
        ncols = 2
        w, h = fig.get_size_inches()
        fig.set_size_inches(w + LEGEND_COLUMN_INCHES, h)   # room for the second column
    fig.legend(handles=handles, fontsize=fontsize, loc="outside right upper", ncols=ncols,
               title="stable responses" + (" / curves" if curves else ""),
               title_fontsize=fontsize, frameon=False)


def fit(fig, rounds: int = 3) -> None:
    """Grow the figure until every artist it draws lies on its canvas (a legend or a label
    that constrained layout could not fit is never cut off): the canvas is enlarged by what
    the drawn artists overflow, then laid out again."""
    for _ in range(rounds):
        # the layout and the artists' extents without rasterising them (savefig rasterises
        # once, at the end)
        fig.draw_without_rendering()
        tight = fig.get_tightbbox(fig.canvas.get_renderer())
        w, h = fig.get_size_inches()
        over = (max(0.0, -tight.x0) + max(0.0, tight.x1 - w),
                max(0.0, -tight.y0) + max(0.0, tight.y1 - h))
        if max(over) <= 0.01:
            return
        fig.set_size_inches(w + over[0] + 0.05, h + over[1] + 0.05)


def save(fig, path: Path) -> Path:
    """Save a figure as PNG (DPI), every artist on its canvas (fit), and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fit(fig)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def zeta_label(z: float) -> str:
    return f"zeta = {z:g}"


def draw_curves(ax, curves, zeta, names, labelled=None):
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


def draw_mms(ax, mms, zeta, sigma1=True):
    if mms is None:
        return
    m = mms.sel(zeta=zeta, method="nearest")
    ax.plot(m[P.MMS_OMEGA], m["sigma2"], color="tab:blue", lw=1.0, label="MMS sigma2 (flip)")
    if sigma1:
        ax.plot(m[P.MMS_OMEGA], m["sigma1"], color="tab:blue", lw=1.0, ls=":", label="MMS sigma1")


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


def draw_traced(ax, traced, zeta, isola=None) -> None:
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


def grid_fallback(traced, zeta, names):
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


_CODIM2_STYLE = {1: ("v", "cusp"), 2: ("*", "fold meets flip (isola joins)"),
                 3: ("D", "grazing meets fold"), 4: ("s", "grazing meets flip")}
