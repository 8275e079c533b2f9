"""The figure of a fit (``hertzmap fit``, study.identify): the measured points over the model's
up and down sweeps at the estimate (H1, H2, H1/2 in N against Hz, the model's jumps marked,
the parameters and their 95 % intervals in the legend), and below, one profile per parameter
(the profile deviance against the value held, the 95 % threshold, the interval).

Drawn from the fit's Dataset (study.identify.fit_dataset) only; nothing is computed here.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D

from hertzmap.study.plots.line_figures import SWEEP_STYLE
from hertzmap.study.plots.style import save

__all__ = ["plot_fit", "parameter_text"]

_LABELS = {"f0": "f0", "sigma": "sigma", "zeta": "zeta", "exponent": "n"}
_HARMONICS = (("H1", "H1 (excitation frequency) [N]"),
              ("H2", "H2 (twice the excitation frequency) [N]"),
              ("H1_2", "H1/2 (subharmonic) [N]"))


def parameter_text(ds, i: int) -> str:
    """One parameter's estimate and interval as the figure's legend says it."""
    name = str(ds["parameter"].values[i])
    unit = str(ds["parameter_units"].values[i])
    unit = "" if unit == "1" else f" {unit}"
    lo, hi = float(ds["lower"][i]), float(ds["upper"][i])
    lo_c, hi_c = bool(ds["lower_closed"][i]), bool(ds["upper_closed"][i])
    label = _LABELS.get(name, name)
    if not lo_c and not hi_c:
        return f"{label}: not identified (bounds {lo:.4g} .. {hi:.4g}{unit})"
    if not (lo_c and hi_c):
        side = f"<= {hi:.4g}" if hi_c else f">= {lo:.4g}"
        return f"{label} {side}{unit} (95 %; open to the bound)"
    best = float(ds["best"][i])
    return f"{label} = {best:.5g}{unit}  [{lo:.5g}, {hi:.5g}] (95 %)"


def plot_fit(ds, path: Path, *, title: str | None = None) -> Path:
    """The fit's figure (module docstring) as a PNG at ``path``."""
    names = [str(p) for p in ds["parameter"].values]
    ncols = max(3, len(names))
    fig = plt.figure(figsize=(4.2 * ncols, 8.0), layout="constrained")
    grid = fig.add_gridspec(2, 1, height_ratios=(1.25, 1.0))
    top_row, bottom_row = grid[0].subgridspec(1, 3), grid[1].subgridspec(1, ncols)
    top = [fig.add_subplot(top_row[0, k]) for k in range(3)]
    f = ds["frequency_hz"].values
    direction = ds["direction"].values
    dnames = [str(d) for d in ds["direction_name"].values]
    for k, (ax, (harm, ylabel)) in enumerate(zip(top, _HARMONICS)):
        c = list(ds["harmonic"].values).index(harm)
        for di, dname in enumerate(dnames):
            code = 0 if dname == "up" else 1
            color, marker, label = SWEEP_STYLE[code]
            x = ds["sweep_frequency_hz"].values[di]
            y = ds["sweep_harmonic"].values[di, :, c]
            seg = ds["sweep_segment"].values[di]
            ok = np.isfinite(x) & (seg >= 0)
            # one line per branch run: the sweep is broken at each jump
            for s in np.unique(seg[ok]):
                run = ok & (seg == s)
                ax.plot(x[run], y[run], color=color, lw=1.1, alpha=0.85, zorder=2)
            pts = direction == code
            ax.plot(f[pts], ds["measured"].values[pts, c], marker, color=color, ms=3.5,
                    mfc="none", mew=0.8, ls="none", zorder=3)
        for j in range(ds.sizes.get("jump", 0)):
            fj = float(ds["model_jump_hz"][j])
            if np.isfinite(fj):
                color = SWEEP_STYLE[int(ds["jump_direction"][j])][0]
                ax.axvline(fj, color=color, ls=":", lw=0.9, zorder=1)
        ax.set_xlabel("excitation frequency [Hz]")
        ax.set_ylabel(ylabel)
        if harm != "H1":
            ax.set_yscale("log")
            measured = ds["measured"].values[:, c]
            pos = measured[np.isfinite(measured) & (measured > 0)]
            if pos.size:
                ax.set_ylim(bottom=max(np.percentile(pos, 1) / 3.0, 1e-6))
        ax.grid(alpha=0.3)
    handles = [Line2D([], [], color=SWEEP_STYLE[0 if d == "up" else 1][0],
                      marker=SWEEP_STYLE[0 if d == "up" else 1][1], mfc="none", ls="-",
                      label=f"{d}: measured (markers), model (line)") for d in dnames]
    handles.append(Line2D([], [], color="0.3", ls=":", label="model jumps"))
    handles += [Line2D([], [], ls="none", label=parameter_text(ds, i))
                for i in range(len(names))]
    handles.append(Line2D([], [], ls="none",
                          label=f"noise: a = {float(ds['noise_multiplicative']):.3g}, "
                                f"b = {float(ds['noise_floor']):.3g} N"))
    fig.legend(handles=handles, fontsize=8, loc="outside upper center", ncol=3,
               handlelength=1.6, frameon=False,
               title=title or f"hertzmap fit: {ds.attrs.get('measurement_source', '')}",
               title_fontsize=10)
    # the profiles
    thr = 2.0 * float(ds.attrs.get("threshold", 1.920729410347062))
    for i, name in enumerate(names):
        ax = fig.add_subplot(bottom_row[0, i])
        x = ds["profile_value"].values[i]
        dev = ds["profile_deviance"].values[i]
        ok = np.isfinite(x) & np.isfinite(dev)
        # a cliff (a model jump passing a measured point) can drop the profile by 1000s:
        # the axis stops at 5 thresholds, the points beyond drawn on its edge
        top = 5.0 * thr
        shown = np.minimum(dev, top)
        ax.plot(x[ok], shown[ok], "-", color="k", lw=1.0)
        ax.plot(x[ok & (dev <= top)], dev[ok & (dev <= top)], "o", color="k", ms=3.5)
        beyond = ok & (dev > top)
        if beyond.any():
            ax.plot(x[beyond], np.full(beyond.sum(), top), "^", color="k", ms=4.5,
                    label="beyond the axis")
        ax.set_ylim(-0.05 * thr, 1.05 * top)
        ax.axhline(thr, color="tab:red", lw=0.9, ls="--", label="95 % threshold")
        lo, hi = float(ds["lower"][i]), float(ds["upper"][i])
        ax.axvspan(lo, hi, color="tab:green", alpha=0.12, label="95 % interval")
        ax.axvline(float(ds["best"][i]), color="tab:green", lw=0.9)
        unit = str(ds["parameter_units"].values[i])
        ax.set_xlabel(f"{_LABELS.get(name, name)}" + ("" if unit == "1" else f" [{unit}]"))
        ax.set_ylabel("profile deviance 2 (log L max - log L)")
        if not bool(ds["identified"][i]):
            ax.text(0.5, 0.9, "not identified" if not (bool(ds["lower_closed"][i]) or
                                                       bool(ds["upper_closed"][i]))
                    else "open to a bound", transform=ax.transAxes, ha="center",
                    color="tab:red")
        ax.grid(alpha=0.3)
        if i == 0:
            ax.legend(fontsize=7.5)
    return save(fig, path)
