"""Figures along one (sigma, zeta) line: the frequency response, the contact-force harmonics, the
stroboscopic bifurcation diagram, the time histories.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from hertzmap.kernels.model import Model
from hertzmap.study.plots.style import CLASS_STYLE, save, zeta_label
from hertzmap.study.products.mms import MMS_OMEGA


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
    return save(fig, path)


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
            ax.plot(mm[MMS_OMEGA], 2 * mm["A_upper"], color="k", lw=0.8, label="MMS 2A (upper)")
            ax.plot(mm[MMS_OMEGA], 2 * mm["A_lower"], color="k", lw=0.8, ls="--",
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
                 f"{zeta_label(float(line['zeta']))}", fontsize=10)
    if "frequency_hz" in line.coords:
        f0 = float(line.attrs.get("rig_f0_hz", np.nan))
        sec = axes[0][0].secondary_xaxis("top", functions=(lambda w: w * f0, lambda f: f / f0))
        sec.set_xlabel("excitation frequency [Hz]", fontsize=8)
    return save(fig, path)


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
                 f"{zeta_label(float(line['zeta']))}", fontsize=10)
    return save(fig, path)


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
    return save(fig, path)


def zoom_for(fr, sigma, zeta):
    """(1.85, 2.1) when the line is wider and has 2T orbits there (the detail of Fig. 6b)."""
    line = fr.sel(sigma=sigma, zeta=zeta, method="nearest")
    om = line["omega"].values
    if not (om.min() < 1.85 and om.max() > 2.05):
        return None
    near = (om >= 1.85) & (om <= 2.1)
    if not (line["period"].values[near] == 2).any():
        return None
    return (1.85, min(float(om.max()), 2.1))


#: the sweeps' colours and markers, by direction (study.solve.sweep.DIRECTIONS order)
SWEEP_STYLE = {0: ("tab:red", "^", "up sweep"), 1: ("tab:blue", "v", "down sweep")}


def plot_sweeps(line, path, *, title=None) -> Path:
    """Stepped-sine sweeps of one line (study.products.sweep_line of the ``sweeps`` product):
    H1, H2, H1/2 of the contact force and the amplitude (peak-to-peak q) against the swept
    parameter (frequency in Hz, forces in N, amplitude in um with a rig), the up and down
    paths, an arrow at each jump from the level it left to the level it landed on (its kind
    beside it), and the store's orbits along the line in grey behind (linked into branches:
    stable solid, unstable dashed). With swept-sine runs ([sweep] rates), each rate's up and
    down paths drawn thinly beside the stepped ones, in their direction's colour, fainter the
    faster (their jumps later, the later the faster), and a fifth panel below: each jump's
    delay against the rate, log-log (_plot_swept_delays)."""
    from matplotlib.lines import Line2D

    axis = line.attrs.get("sweep_axis", "omega")
    rig = "rig_N" in line.attrs
    f0 = float(line.attrs.get("rig_f0_hz", np.nan))
    n_rig = float(line.attrs.get("rig_N", np.nan))
    if rig and axis == "omega":
        xscale, xlabel = f0, "excitation frequency [Hz]"
    elif rig:
        xscale, xlabel = n_rig, "excitation force amplitude [N]"
    else:
        xscale, xlabel = 1.0, axis
    x = line["value"].values * xscale
    unit = "N" if rig else "F/N"
    panels = (("H1", "branch_H1", f"H1 (excitation frequency) [{unit}]", n_rig if rig else 1.0),
              ("H2", "branch_H2", f"H2 (twice the excitation frequency) [{unit}]",
               n_rig if rig else 1.0),
              ("H1_2", "branch_H1_2", f"H1/2 (subharmonic) [{unit}]", n_rig if rig else 1.0),
              ("ptp", "branch_ptp", "amplitude, peak-to-peak " + ("[um]" if rig else "q"),
               # q = n (z - z_s) / z_s (paper Eq. 5): ptp z_s / n in m, in um
              1e6 * float(line.attrs.get("rig_z_s", np.nan)) / _exponent(line) if rig else 1.0))
    swept = "rate" in line.dims
    if swept:
        # a third row: each swept jump's delay against the rate
        fig = plt.figure(figsize=(11, 9.8), layout="constrained")
        grid = fig.add_gridspec(3, 2, height_ratios=(1.0, 1.0, 0.85))
        first = fig.add_subplot(grid[0, 0])
        axes = np.array([[first, fig.add_subplot(grid[0, 1], sharex=first)],
                         [fig.add_subplot(grid[1, 0], sharex=first),
                          fig.add_subplot(grid[1, 1], sharex=first)]])
        for ax in axes[0]:
            ax.tick_params(labelbottom=False)
        delay_ax = fig.add_subplot(grid[2, :])
    else:
        fig, axes = plt.subplots(2, 2, figsize=(11, 7.2), layout="constrained", sharex=True)
    kinds = {int(v): k for v, k in zip(line["jump_kind"].attrs.get("flag_values", []),
                                        line["jump_kind"].attrs.get("flag_meanings", "").split())}
    bx = line["branch_value"].values * xscale
    bid = line["branch_id"].values
    bst = line["branch_stable"].values.astype(bool)
    for ax, (name, bname, ylabel, scale) in zip(axes.flat, panels):
        # the stored orbits, grey, linked into branches: a segment is solid when both its ends
        # are stable
        by = line[bname].values * scale
        for b in np.unique(bid):
            k = np.flatnonzero(bid == b)
            k = k[np.argsort(bx[k])]
            if k.size == 1:
                ax.plot(bx[k], by[k], ".", color="0.6" if bst[k[0]] else "0.75", ms=2, zorder=1)
                continue
            # runs of segments of one kind drawn as one line (a dash pattern across them)
            solid = bst[k[:-1]] & bst[k[1:]]
            edges = np.flatnonzero(np.diff(solid.astype(int))) + 1
            for run in np.split(np.arange(solid.size), edges):
                pts = k[run[0]:run[-1] + 2]
                ax.plot(bx[pts], by[pts], color="0.6" if solid[run[0]] else "0.75",
                        ls="-" if solid[run[0]] else "--", lw=1.0 if solid[run[0]] else 0.8,
                        zorder=1)
        for d, (color, marker, _) in SWEEP_STYLE.items():
            y = line[name].isel(direction=d).values * scale
            # the path is broken at each jump (the arrow stands for it)
            cut = np.zeros(x.size, bool)
            for j in np.flatnonzero(line["jump_direction"].values == d):
                a, c = int(line["jump_from_step"].values[j]), int(line["jump_to_step"].values[j])
                if a >= 0:
                    cut[max(a, c)] = True
            at = np.flatnonzero(cut)
            ax.plot(np.insert(x, at, np.nan), np.insert(y, at, np.nan), color=color,
                    marker=marker, ms=3, lw=0.9, alpha=0.85, zorder=3)
        if "rate" in line.dims:
            # the swept sines: thin, over the stepped paths (which they follow away from the
            # jumps), one per rate and direction, the fastest faintest
            sx = line["sample_value"].values * xscale
            for k in range(line.sizes["rate"]):
                for d, (color, _, _) in SWEEP_STYLE.items():
                    sy = line[f"swept_{name}"].isel(rate=k, direction=d).values * scale
                    ax.plot(sx, sy, color=color, lw=0.7, alpha=_swept_alpha(k, line),
                            zorder=3.5)
        for j in range(line.sizes["jump"]):
            d = int(line["jump_direction"].values[j])
            a, c = int(line["jump_from_step"].values[j]), int(line["jump_to_step"].values[j])
            y = line[name].isel(direction=d).values * scale
            if a < 0 or not (np.isfinite(y[a]) and np.isfinite(y[c])):
                continue
            xj = float(line["jump_value"].values[j]) * xscale
            color = SWEEP_STYLE[d][0]
            ax.annotate("", xy=(xj, y[c]), xytext=(xj, y[a]), zorder=4,
                        arrowprops=dict(arrowstyle="->", color=color, lw=1.2, ls="--"))
            ax.text(xj, 0.5 * (y[a] + y[c]), " " + kinds.get(int(line["jump_kind"].values[j]),
                                                             "?"),
                    color=color, fontsize=7, va="center", ha="left" if d == 0 else "right",
                    zorder=5)
        ax.set_ylabel(ylabel, fontsize=8)
    for ax in axes[1]:
        ax.set_xlabel(xlabel)
    handles = [Line2D([], [], color=c, marker=m, ms=4, lw=0.9, label=lab)
               for c, m, lab in SWEEP_STYLE.values()]
    handles += [Line2D([], [], color="k", lw=1.2, ls="--", label="jump (fold, flip, loss)"),
                Line2D([], [], color="0.6", lw=1.0, label="stored orbits, stable"),
                Line2D([], [], color="0.75", lw=0.8, ls="--", label="stored orbits, unstable")]
    if swept:
        unit = next(((c, u) for c, u in (("rate_hz_per_s", "Hz/s"), ("rate_N_per_s", "N/s"))
                     if c in line.coords), ("rate", "per unit tau"))
        for k in range(line.sizes["rate"]):
            rate = f"{float(line[unit[0]][k]):.3g} {unit[1]}"
            handles.append(Line2D([], [], color="k", lw=0.6, alpha=_swept_alpha(k, line),
                                  label=f"swept sine, {rate}"))
        _plot_swept_delays(delay_ax, line, unit, xscale, kinds,
                           f"delay of the jump in {axis} [{xlabel.split('[')[-1].rstrip(']')}]"
                           if rig else f"delay of the jump in {axis}")
    fig.legend(handles=handles, loc="outside lower center", ncols=5, fontsize=8)
    fixed = ", ".join(f"{k} = {line.attrs[k]:g}" for k in ("omega", "sigma", "zeta")
                      if k in line.attrs and k != axis)
    fig.suptitle(title or f"Stepped-sine sweeps along {axis}, {fixed}", fontsize=10)
    return save(fig, path)


def _plot_swept_delays(ax, line, unit, xscale, kinds, ylabel) -> None:
    """Each swept jump's delay (how far past the stepped jump the swept run leaves the branch,
    swept_jump_delay, in the swept parameter's units) against the rate, log-log, one line per
    stepped jump that some rate reached, in its direction's colour: the delays tend to 0 with
    the rate (rate^(2/3) at a fold, the slow passage). A rate whose run never left the branch
    there has no point."""
    rates = line[unit[0]].values
    ax.set_xscale("log")
    ax.set_yscale("log")
    drawn = 0
    for j in range(line.sizes["jump"]):
        delay = line["swept_jump_delay"].values[j] * xscale
        ok = np.isfinite(delay) & (delay > 0.0)
        if not ok.any():
            continue
        d = int(line["jump_direction"].values[j])
        color, marker, _ = SWEEP_STYLE[d]
        kind = kinds.get(int(line["jump_kind"].values[j]), "?")
        stepped = float(line["jump_value"].values[j]) * xscale
        ax.plot(rates[ok], delay[ok], color=color, marker=marker, ms=4, lw=0.9,
                  label=f"{('up', 'down')[d]}, {kind} at {stepped:.5g}")
        drawn += 1
    ax.set_xlabel(f"rate of the swept sine [{unit[1]}]")
    ax.set_ylabel(ylabel, fontsize=8)
    if drawn:
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    else:
        ax.text(0.5, 0.5, "no swept run left its branch at a stepped jump", ha="center",
                va="center", transform=ax.transAxes, fontsize=8)


def _swept_alpha(k: int, line) -> float:
    """The opacity of the k-th swept-sine rate's paths (fastest first: the faintest)."""
    n = line.sizes["rate"]
    return 0.35 + 0.55 * (k / (n - 1) if n > 1 else 1.0)


def _exponent(ds) -> float:
    """The contact exponent n of a product (its attrs; 1.5 when not a number)."""
    return Model.of(ds.attrs).exponent
