"""The page of ``hertzmap explore`` (one Bokeh document per browser tab).

Left: the loss-of-contact map of the shown store (its zeta selected), the frequency-response
slice through the clicked sigma, and "refine this window". Right: the clicked point's orbits,
integrated again from the store's start points: a table, the phase portrait, q and the
contact force over the orbit's period, the Floquet multipliers and the force harmonics; under
them "sweep through this point": stepped-sine sweeps up and down omega or sigma through it
(H1, H2, H1/2 and the amplitude, jumps marked), computed on a thread of the server
(``ExploreState.start_sweep``) while the page says so, or read from the store's
products/sweeps when it holds that line.
Everything the page computes comes from ``study.explore_data``; this module only draws.
"""
from __future__ import annotations

import html
import time
from pathlib import Path

import numpy as np
from bokeh.events import Tap
from bokeh.layouts import column, row
from bokeh.models import (Arrow, Button, ColumnDataSource, Div, HoverTool, InlineStyleSheet,
                          LabelSet, Legend, LegendItem, Range1d, Select, Span, Spinner, VeeHead)
from bokeh.plotting import figure

from hertzmap.kernels.model import LAW_OF_CODE, Model
from hertzmap.study import explore_data as E
from hertzmap.study import explore_sweeps as ES

from hertzmap.scheduler.doors.explore.basin_panel import BasinPanel
from hertzmap.scheduler.doors.explore.state import ExploreState, StoreView, SweepJob
from hertzmap.scheduler.doors.explore.table import orbit_table

POLL_MS = 1000
LEFT_W, RIGHT_W = 860, 730
PANEL_W = RIGHT_W // 2
SMALL_W = RIGHT_W // 3

CSS = """
:host { font-family: system-ui, -apple-system, 'Segoe UI', Roboto, sans-serif; font-size: 13px; }
table.orbits { border-collapse: collapse; width: 100%; }
table.orbits th, table.orbits td { border-bottom: 1px solid #e3e3e3; padding: 1px 8px;
    text-align: right; white-space: nowrap; }
table.orbits th { background: #f3f5f8; }
table.orbits td.q, table.orbits th.q { text-align: left; color: #333; }
table.orbits td.u { text-align: left; color: #888; }
.swatch { display: inline-block; width: 10px; height: 10px; margin-right: 4px;
    border: 1px solid #888; vertical-align: middle; }
.muted { color: #777; } .err { color: #b00020; } .ok { color: #1b7a1b; }
progress { width: 260px; height: 12px; vertical-align: middle; }
pre { font-size: 11px; background: #f6f6f6; padding: 6px; max-height: 160px; overflow: auto; }
h1 { font-size: 18px; margin: 0 0 2px 0; } h2 { font-size: 14px; margin: 0 0 2px 0; }
"""


def _div(text: str = "", width: int | None = None, name: str | None = None) -> Div:
    return Div(text=text, width=width, name=name, stylesheets=[InlineStyleSheet(css=CSS)])


def _secs(x: float) -> str:
    return f"{x:.2f} s" if x < 1 else f"{x:.1f} s"


def _empty(*names) -> dict[str, list]:
    return {n: [] for n in names}


class Page:
    """The widgets of one document and their callbacks."""

    def __init__(self, doc, state: ExploreState):
        self.doc = doc
        self.state = state
        self.path: Path = state.base
        self.view: StoreView = state.view(self.path)
        self.zeta = float(self.view.ds["zeta"].values[0])
        self.point: tuple[float, float] | None = None
        self.seen_job = None
        self.sweep_job: SweepJob | None = None      # the last sweep asked for on this page
        self.sweep_shown: SweepJob | None = None    # the sweep drawn (its job)
        self.sweep_store: Path | None = None        # the store it was asked for on
        self.sweep_point: tuple[float, float] | None = None    # and the point it went through
        self._build()
        self.show_store(self.path)
        doc.add_periodic_callback(self.poll, POLL_MS)
        doc.title = f"hertzmap explore: {self.state.base.name}"

    # -- layout ---------------------------------------------------------------------------
    def _build(self) -> None:
        u = self.view.units
        self.header = _div(width=LEFT_W + RIGHT_W, name="header")
        self.store_select = Select(title="store shown", width=420, name="store_select")
        self.store_select.on_change("value", lambda a, o, n: self.show_store(Path(n)))
        self.zeta_select = Select(title="zeta (damping ratio)", width=200, name="zeta_select")
        self.zeta_select.on_change("value", lambda a, o, n: self.set_zeta(float(n)))

        # the map
        self.map_src = ColumnDataSource(_empty("left", "right", "bottom", "top", "omega", "sigma",
                                               "x", "y", "code", "color", "label", "n_orbits",
                                               "n_stable", "summary"))
        self.xr = Range1d(0, 1)
        self.yr = Range1d(0, 1)
        p = figure(width=LEFT_W, height=520, x_range=self.xr, y_range=self.yr, name="map",
                   tools="pan,box_zoom,wheel_zoom,reset,save", active_drag="box_zoom",
                   x_axis_label=u.freq.label, y_axis_label=u.amp.label, toolbar_location="above")
        # the cells' own colour as outline: no antialiasing seams between neighbours
        self.cells = p.quad(left="left", right="right", bottom="bottom", top="top",
                            fill_color="color", line_color="color", line_width=0.5,
                            source=self.map_src)
        tips = ("<div style='font-size:12px;max-width:460px'><b>@label</b><br>"
                "omega = @omega{0.00000}, sigma = @sigma{0.00000}"
                + ("<br>@x{0.00} Hz, force amplitude @y{0.000} N" if u.physical else "")
                + "<br>@summary{safe}</div>")
        p.add_tools(HoverTool(renderers=[self.cells], tooltips=tips))
        self.curve_srcs = {}
        self.curve_items = {}
        for name, color, dash, label in E.MAP_CURVES + (E.MMS_CURVE,):
            src = ColumnDataSource({"xs": [], "ys": []})
            r = p.multi_line("xs", "ys", source=src, line_color=color, line_dash=dash,
                             line_width=2 if name == "flip_1T" else 1.6)
            self.curve_srcs[name] = src
            self.curve_items[name] = LegendItem(label=label, renderers=[r])
        self.windows_src = ColumnDataSource(_empty("left", "right", "bottom", "top"))
        self.windows_r = p.quad(left="left", right="right", bottom="bottom", top="top",
                                source=self.windows_src, fill_alpha=0, line_color="#333333",
                                line_dash="dashed", line_width=1.2)
        # the line of the last sweep through a clicked point
        self.sweep_line_src = ColumnDataSource(_empty("x", "y"))
        p.line("x", "y", source=self.sweep_line_src, line_color="#333333", line_dash="dashdot",
               line_width=1.5)
        self.mark_src = ColumnDataSource(_empty("x", "y"))
        self.mark_r = p.scatter("x", "y", source=self.mark_src, marker="circle_x", size=16,
                                fill_alpha=0, line_color="black", line_width=2)
        self.map_legend = Legend(items=[], location="top_left", label_text_font_size="8pt",
                                 title="stable responses / curves", title_text_font_size="8pt",
                                 spacing=0, glyph_height=14, glyph_width=18)
        p.add_layout(self.map_legend, "right")
        p.on_event(Tap, self.on_tap)
        p.title.text_font_size = "13px"
        self.map = p

        # the frequency-response slice
        self.resp_src = ColumnDataSource(_empty("x", "y", "color", "label", "size"))
        r = figure(width=LEFT_W, height=280, name="response", tools="pan,box_zoom,wheel_zoom,reset,save",
                   x_axis_label=u.freq.label,
                   y_axis_label="peak-to-peak " + ("z - z_s [um]" if u.physical else "q"),
                   toolbar_location="above")
        r.scatter("x", "y", source=self.resp_src, color="color", size="size",
                  legend_field="label")
        r.legend.label_text_font_size = "8pt"
        r.legend.spacing = 0
        r.add_layout(r.legend[0], "right")
        r.legend.visible = False        # until a point is clicked (an empty box otherwise)
        r.title.text_font_size = "13px"
        r.title.text = "Frequency response along the clicked sigma (click a point of the map)"
        self.resp_span = Span(location=float("nan"), dimension="height", line_color="#444444",
                              line_dash="dotted", line_width=1.2)
        r.add_layout(self.resp_span)
        self.resp = r

        # refine
        self.n_omega = Spinner(title="omega points", low=1, high=2000, step=1, value=20,
                               width=120, name="refine_omega")
        self.n_sigma = Spinner(title="sigma points", low=1, high=2000, step=1, value=20,
                               width=120, name="refine_sigma")
        self.refine_button = Button(label="Refine visible window", button_type="primary",
                                    width=200, name="refine_button")
        self.refine_button.on_click(self.on_refine)
        self.refine_div = _div(width=LEFT_W, name="refine_status")
        self.n_omega.on_change("value", lambda a, o, n: self.show_refine_plan())
        self.n_sigma.on_change("value", lambda a, o, n: self.show_refine_plan())
        for rng in (self.xr, self.yr):
            rng.on_change("start", lambda a, o, n: self.window_changed())
            rng.on_change("end", lambda a, o, n: self.window_changed())

        # the point
        self.point_div = _div("<h2>Click a point of the map</h2><span class='muted'>its orbits "
                              "appear here: the table, the phase portrait, the multipliers, the "
                              "force harmonics, q and the contact force over the period</span>",
                              width=RIGHT_W, name="point")
        self.table_div = _div(width=RIGHT_W, name="orbit_table")
        self.orbit_src = ColumnDataSource(_empty("q", "v", "t", "f", "color", "dash", "label"))
        self.strobe_src = ColumnDataSource(_empty("q", "v"))
        ph = figure(width=SMALL_W, height=270, name="phase", title="phase portrait",
                    x_axis_label=u.disp.label, y_axis_label=u.vel.label, tools="pan,wheel_zoom,box_zoom,reset,save")
        ph.multi_line("q", "v", source=self.orbit_src, line_color="color", line_dash="dash",
                      line_width=2, legend_field="label")
        ph.scatter("q", "v", source=self.strobe_src, size=3, color="#333333")
        self.lost_v = Span(location=float("nan"), dimension="height", line_color="#d62728",
                           line_dash="dotted", line_width=1.5)
        ph.add_layout(self.lost_v)
        ph.legend.visible = False       # the table's header and the harmonics carry it
        self.phase = ph
        mu = figure(width=SMALL_W, height=270, name="multipliers", match_aspect=True,
                    title="Floquet multipliers", x_axis_label="Re mu", y_axis_label="Im mu",
                    tools="pan,wheel_zoom,reset,save", x_range=Range1d(-1.35, 1.35),
                    y_range=Range1d(-1.35, 1.35))
        th = np.linspace(0, 2 * np.pi, 361)
        mu.line(np.cos(th), np.sin(th), line_color="#888888", line_width=1)
        self.mu_src = ColumnDataSource(_empty("re", "im", "color", "label"))
        mu.scatter("re", "im", source=self.mu_src, color="color", size=10, marker="x",
                   line_width=2.5, legend_field="label")
        mu.legend.visible = False
        self.mu = mu
        qt = figure(width=PANEL_W, height=250, name="q_of_t", title="q over the orbit's period",
                    x_axis_label=u.time.label, y_axis_label=u.disp.label,
                    tools="pan,wheel_zoom,box_zoom,reset,save")
        qt.multi_line("t", "q", source=self.orbit_src, line_color="color", line_dash="dash",
                      line_width=2)
        self.lost_h = Span(location=float("nan"), dimension="width", line_color="#d62728",
                           line_dash="dotted", line_width=1.5)
        qt.add_layout(self.lost_h)
        self.qt = qt
        ft = figure(width=PANEL_W, height=250, name="force", title="contact force over the period",
                    x_axis_label=u.time.label, y_axis_label=u.force.label,
                    tools="pan,wheel_zoom,box_zoom,reset,save")
        ft.multi_line("t", "f", source=self.orbit_src, line_color="color", line_dash="dash",
                      line_width=2)
        ft.add_layout(Span(location=float(u.force(1.0)), dimension="width",
                           line_color="#888888", line_dash="dashed", line_width=1))
        self.ft = ft
        self.harm_src = ColumnDataSource(_empty("x", "top", "color", "label", "width"))
        self.harm_store_src = ColumnDataSource(_empty("x", "y"))
        hm = figure(width=SMALL_W, height=270, name="harmonics",
                    title="force harmonics (o: store)", x_range=Range1d(0, 4.3),
                    x_axis_label="frequency / excitation frequency",
                    y_axis_label="force amplitude " + ("[N]" if u.physical else "(F / N)"),
                    tools="pan,wheel_zoom,reset,save")
        hm.vbar(x="x", top="top", width="width", source=self.harm_src, fill_color="color",
                line_color=None, legend_field="label")
        hm.scatter("x", "y", source=self.harm_store_src, marker="circle", size=7,
                   fill_color="white", line_color="black")
        hm.legend.visible = False
        self.hm = hm
        self._build_sweep()
        self.basins = BasinPanel(self.state, RIGHT_W)
        for fig in (self.map, self.resp, self.phase, self.mu, self.qt, self.ft, self.hm,
                    *self.sweep_figs.values()):
            fig.title.text_font_size = "12px"
            fig.toolbar.logo = None
            fig.toolbar.autohide = True

        left = column(row(self.store_select, self.zeta_select), self.map, self.resp,
                      row(self.n_omega, self.n_sigma, column(_div("&nbsp;"), self.refine_button)),
                      self.refine_div)
        f = self.sweep_figs
        right = column(self.point_div, self.table_div, row(self.phase, self.mu, self.hm),
                       row(self.qt, self.ft),
                       row(self.sweep_axis, column(_div("&nbsp;"), self.sweep_button)),
                       self.sweep_div, row(f["H1"], f["H2"]), row(f["H1_2"], f["ptp"]),
                       self.basins.layout())
        self.doc.add_root(column(self.header, row(left, right)))

    def _build_sweep(self) -> None:
        """"Sweep through this point": the axis, the button, the status line and the four
        panels (H1, H2, H1/2, amplitude against the swept parameter, up and down)."""
        u = self.view.units
        self.sweep_axis = Select(title="sweep along", value="omega", width=170, name="sweep_axis",
                                 options=[("omega", "omega (frequency)"),
                                          ("sigma", "sigma (amplitude)")])
        self.sweep_button = Button(label="Sweep through this point", button_type="primary",
                                   width=220, name="sweep_button", disabled=True)
        self.sweep_button.on_click(self.on_sweep)
        self.sweep_div = _div(
            "<span class='muted'>stepped-sine sweeps up and down the chosen axis through the "
            "clicked point, over the map's range, as a lab measures them: click a point, "
            "then sweep</span>", width=RIGHT_W, name="sweep_status")
        names = [n for n, _, _ in ES.SWEEP_QUANTITIES]
        self.sweep_srcs = {d: ColumnDataSource(_empty("x", "value", "period", *names),
                                               name=f"sweep_{d}") for d in ("up", "down")}
        self.sweep_jump_src = ColumnDataSource(
            _empty("x", "kind", "direction", "color", *[f"{n}_{e}" for n in names for e in "01"]),
            name="sweep_jumps")
        self.sweep_figs: dict = {}
        self.sweep_spans: list[Span] = []
        x_range = None
        for name, label, q in ES.SWEEP_QUANTITIES:
            if q == "force":
                ylab = label.split(" (")[0] + (" [N]" if u.physical else " (F / N)")
            else:
                ylab = "peak-to-peak " + ("z - z_s [um]" if u.physical else "q")
            f = figure(width=PANEL_W, height=230, name=f"sweep_{name}", title=label,
                       x_axis_label=u.freq.label, y_axis_label=ylab,
                       tools="pan,wheel_zoom,box_zoom,reset,save",
                       **({"x_range": x_range} if x_range is not None else {}))
            x_range = f.x_range
            for d in ("up", "down"):
                src, color = self.sweep_srcs[d], ES.SWEEP_COLORS[d]
                f.line("x", name, source=src, line_color=color, line_width=1.3, alpha=0.85)
                f.scatter("x", name, source=src, marker=ES.SWEEP_MARKERS[d], size=6,
                          color=color, alpha=0.85)
            f.add_layout(Arrow(end=VeeHead(size=8, fill_color="color", line_color="color"),
                               x_start="x", y_start=f"{name}_0", x_end="x", y_end=f"{name}_1",
                               source=self.sweep_jump_src, line_color="color",
                               line_dash="dashed", line_width=1.5))
            f.add_layout(LabelSet(x="x", y=f"{name}_1", text="kind", source=self.sweep_jump_src,
                                  text_color="color", text_font_size="9px", x_offset=3))
            span = Span(location=float("nan"), dimension="height", line_color="#444444",
                        line_dash="dotted", line_width=1.2)
            f.add_layout(span)
            self.sweep_spans.append(span)
            self.sweep_figs[name] = f

    # -- the store and its map ------------------------------------------------------------
    def refresh_store_options(self) -> None:
        opts = [(str(p), p.name + ("  (first store)" if p == self.state.base else ""))
                for p in self.state.stores()]
        if [o[0] for o in opts] != [o[0] for o in self.store_select.options]:
            self.store_select.options = opts

    def show_store(self, path: Path) -> None:
        """Show the store at ``path``: its map over its whole grid, the clicked point again."""
        self.path = Path(path)
        self.view = self.state.view(self.path)
        self.refresh_store_options()
        if self.store_select.value != str(self.path):
            self.store_select.value = str(self.path)
        zs = [float(z) for z in self.view.ds["zeta"].values]
        self.zeta_select.options = [repr(z) for z in zs]
        self.zeta = min(zs, key=lambda z: abs(z - self.zeta))
        self.zeta_select.value = repr(self.zeta)
        self.zeta_select.disabled = len(zs) == 1
        self.draw_map(reset_window=True)
        if self.point is not None:
            self.show_point(*self.point)

    def set_zeta(self, z: float) -> None:
        if z != self.zeta:
            self.zeta = z
            self.draw_map(reset_window=False)
            if self.point is not None:
                self.show_point(*self.point)

    def draw_map(self, reset_window: bool) -> None:
        v, u = self.view, self.view.units
        cols = v.map_columns(self.zeta)
        self.map_src.data = {k: list(c) if c.dtype == object else c for k, c in cols.items()
                             if k != "computed"}
        om = v.ds["omega"].values
        curves = E.map_curves(v.curves, v.mms, self.zeta, u, (float(om.min()), float(om.max())))
        drawn = {c["name"]: c for c in curves}
        for name, src in self.curve_srcs.items():
            c = drawn.get(name)
            src.data = {"xs": c["xs"], "ys": c["ys"]} if c else {"xs": [], "ys": []}
        self.draw_windows()
        self.draw_sweep_line()
        # legend: one entry per stable-response combination present (the first cell of each),
        # then the curves drawn
        items = []
        for code, _, label in E.map_legend(cols["code"][cols["computed"]]):
            first = int(np.flatnonzero((cols["code"] == code) & cols["computed"])[0])
            items.append(LegendItem(label=label, renderers=[self.cells], index=first))
        if not cols["computed"].all():
            first = int(np.flatnonzero(~cols["computed"])[0])
            items.append(LegendItem(label="not computed yet", renderers=[self.cells], index=first))
        items += [self.curve_items[n] for n in self.curve_srcs if n in drawn]
        if len(self.windows_src.data["left"]):
            items.append(LegendItem(label="refined windows", renderers=[self.windows_r]))
        self.map_legend.items = items
        if reset_window:
            x0, x1 = float(np.min(cols["left"])), float(np.max(cols["right"]))
            y0, y1 = float(np.min(cols["bottom"])), float(np.max(cols["top"]))
            self.xr.update(start=x0, end=x1, reset_start=x0, reset_end=x1)
            self.yr.update(start=y0, end=y1, reset_start=y0, reset_end=y1)
        self.map.title.text = (f"Stable responses and contact loss, zeta = {self.zeta:g}: "
                               "click a point for its orbits")
        self.show_header()
        self.window_changed()

    def draw_windows(self) -> None:
        """Outlines of the refined stores' windows over the shown map."""
        u = self.view.units
        cols = _empty("left", "right", "bottom", "top")
        for p in self.state.stores()[1:]:
            if p == self.path:
                continue
            try:
                ds = self.state.view(p).ds
            except Exception:
                continue
            for k, a, scale in (("left", "omega", u.freq), ("bottom", "sigma", u.amp)):
                cols[k].append(float(scale(ds[a].values.min())))
            for k, a, scale in (("right", "omega", u.freq), ("top", "sigma", u.amp)):
                cols[k].append(float(scale(ds[a].values.max())))
        self.windows_src.data = cols

    def show_header(self) -> None:
        v = self.view
        ds = v.ds
        done, total = v.done
        lock = v.locked_by
        if done == total:
            state = "<span class='ok'>complete</span>"
        elif lock:
            state = (f"<span class='err'>being written</span> by hertzmap run (host "
                     f"{html.escape(str(lock.get('host')))}, pid {html.escape(str(lock.get('pid')))}"
                     "); the map follows it")
        else:
            state = ("<span class='err'>incomplete</span> (no run holds it: rerun hertzmap run "
                     "to finish it); blank cells are not computed")
        u = v.units
        units = (f"physical units from the study's [rig]: f0 = {u.f0_hz:.4g} Hz, preload "
                 f"N = {u.preload_n:.4g} N" if u.physical else
                 "dimensionless (the study has no [rig])")
        sizes = " x ".join(f"{ds.sizes[d]} {d}" for d in ("omega", "sigma", "zeta"))
        model = Model.of(ds.attrs)
        law_exponent = f" n = {model.exponent:g}" if LAW_OF_CODE[model.code].has_exponent else ""
        self.header.text = (
            f"<h1>hertzmap explore</h1><div><b>{html.escape(v.name)}</b>: study "
            f"{html.escape(str(ds.attrs.get('hertzmap_study_name', '')))} "
            f"(hash {str(ds.attrs.get('hertzmap_study_hash', ''))[:8]}), {sizes}, "
            f"{model.law}{law_exponent}; {units}</div>"
            f"<div>tasks <span id='tasks_done'>{done}/{total}</span> done "
            f"<progress value='{done}' max='{total}'></progress> {state}</div>")

    # -- the point ------------------------------------------------------------------------
    def on_tap(self, event) -> None:
        pt = E.nearest_point(self.view.ds, event.x, event.y, self.view.units)
        if pt is not None:
            self.show_point(*pt)

    def show_point(self, omega: float, sigma: float) -> None:
        v, u = self.view, self.view.units
        self.point = (omega, sigma)
        self.sweep_button.disabled = (self.sweep_job is not None
                                      and self.sweep_job.state == "running")
        ds = v.ds
        if not (ds["omega"].min() <= omega <= ds["omega"].max()
                and ds["sigma"].min() <= sigma <= ds["sigma"].max()):
            self.clear_point("the selected point is outside this store's grid: click the map")
            return
        orb = E.point_orbits(ds, omega, sigma, self.zeta)
        w, s, z = orb.attrs["omega"], orb.attrs["sigma"], orb.attrs["zeta"]
        self.mark_src.data = {"x": [float(u.freq(w))], "y": [float(u.amp(s))]}
        where = (f" ({u.freq(w):.5g} Hz, force amplitude {u.amp(s):.5g} N)" if u.physical else "")
        computed = bool(v.lcm["computed"].sel(omega=w, sigma=s, zeta=z).values)
        self.basins.set_point(self.path, w, s, z, E.stored_attractors(ds, w, s, z))
        self.point_div.text = (f"<h2>omega = {w:.6g}, sigma = {s:.6g}, zeta = {z:g}{where}</h2>"
                               f"<span class='muted'>{orb.sizes['orbit']} distinct orbit(s) "
                               "in the store, integrated again from their stored start points "
                               "over one period (kernels.simulate, the store's rtol)</span>")
        if not computed:
            self.clear_point("this point is not computed yet", keep_header=True)
            return
        colors = E.class_colors()
        rows = []
        t_lines, q_lines, v_lines, f_lines, cl, dash, lab = [], [], [], [], [], [], []
        mu_re, mu_im, mu_c, mu_l = [], [], [], []
        hx, htop, hc, hl, hw, sx, sy = [], [], [], [], [], [], []
        n_orb = orb.sizes["orbit"]
        for k in range(n_orb):
            c = int(orb["orbit_class"].values[k])
            color, clabel = colors[c]
            per = int(orb["period"].values[k])
            h = E.orbit_history(orb, k)
            closure = float(np.hypot(h["q"][-1] - h["q"][0], h["v"][-1] - h["v"][0]))
            label = f"#{int(orb['slot'].values[k])} {clabel}"
            t_lines.append(u.time(h["tau"]))
            q_lines.append(u.disp(h["q"]))
            v_lines.append(u.vel(h["v"]))
            f_lines.append(u.force(h["force"]))
            cl.append(color)
            dash.append("solid" if bool(orb["stable"].values[k]) else "dashed")
            lab.append(label)
            m = orb["multipliers"].values[k]
            mu_re += [float(m[0].real), float(m[1].real)]
            mu_im += [float(m[0].imag), float(m[1].imag)]
            mu_c += [color, color]
            mu_l += [label, label]
            # harmonics up to 4 x the excitation frequency (8 of a 2T orbit)
            ratio, amp = E.force_spectrum(h, per, kmax=4 * per)
            width = 0.4 / max(1, n_orb)
            off = (k - (n_orb - 1) / 2) * width
            hx += list(ratio + off)
            htop += list(u.force(amp))
            hc += [color] * ratio.size
            hl += [label] * ratio.size
            hw += [width * 0.95] * ratio.size
            if "force_harmonics" in orb:
                fh = orb["force_harmonics"].values[k]
                sx += list(np.arange(1, fh.size + 1) / per + off)
                sy += list(u.force(fh))
            rows.append((k, orb, h, closure, c, color, clabel))
        self.orbit_src.data = {"t": t_lines, "q": q_lines, "v": v_lines, "f": f_lines,
                               "color": cl, "dash": dash, "label": lab}
        self.mu_src.data = {"re": mu_re, "im": mu_im, "color": mu_c, "label": mu_l}
        big = max([1.0] + [abs(complex(a, b)) for a, b in zip(mu_re, mu_im)])
        self.mu.x_range.update(start=-1.15 * big, end=1.15 * big)
        self.mu.y_range.update(start=-1.15 * big, end=1.15 * big)
        self.harm_src.data = {"x": hx, "top": htop, "color": hc, "label": hl, "width": hw}
        self.harm_store_src.data = {"x": sx, "y": sy}
        q_lost = float(u.disp(orb.attrs["contact_threshold"]))
        self.lost_v.location = q_lost
        self.lost_h.location = q_lost
        # no stable periodic orbit here: show where the motion goes (its stroboscopic points)
        stable_any = bool(orb["stable"].values.any()) if n_orb else False
        census = [a for a in E.stored_attractors(v.ds, w, s, z) if a["kind"] != "periodic"]
        if census:
            # the census's own stroboscopic points of the attractors that are not periodic
            pts = np.vstack([a["strobe"] for a in census])
            self.strobe_src.data = {"q": u.disp(pts[:, 0]), "v": u.vel(pts[:, 1])}
            self.point_div.text += "<br>" + "<br>".join(
                f"<b>{a['kind'].replace('_', '-')}</b> attractor: basin {100 * a['basin']:.0f} %, "
                f"Lyapunov exponent {a['lyapunov']:.3g} per unit tau, largest impact velocity "
                f"{float(u.vel(a['impact'])):.4g} {u.vel.unit}, peak force "
                f"{float(u.force(a['peak_force'])):.4g} {u.force.unit}" for a in census)
        elif not stable_any:
            x0 = ((float(orb["q0"].values[0]), float(orb["v0"].values[0])) if n_orb else (0.0, 0.0))
            pts = E.stroboscopic_points(w, s, z, x0, exponent=orb.attrs["exponent"],
                                        model=orb.attrs["model"], rtol=orb.attrs["rtol"])
            self.strobe_src.data = {"q": u.disp(pts[:, 0]), "v": u.vel(pts[:, 1])}
        else:
            self.strobe_src.data = {"q": [], "v": []}
        self.phase.title.text = "phase portrait" + ("" if stable_any and not census
                                                    else " + stroboscopic")
        if census:
            self.point_div.text += (
                "<br>the grey dots of the phase portrait are the attractor census's last "
                "stroboscopic points (q, q' at tau = m T) of the attractors above")
        elif not stable_any:
            self.point_div.text += (
                "<br><span class='err'>no stable periodic orbit stored here</span>: the grey dots "
                "of the phase portrait are the stroboscopic points (q, q' at tau = m T) of 200 "
                "forcing periods after 100, from " + ("orbit #0's start point" if n_orb else
                                                       "rest (0, 0)") + ": where the motion goes")
        self.qt.title.text = "q over the orbit's period (red: contact loss)"
        self.table_div.text = orbit_table(rows, u)
        self.draw_response(s, w)

    def clear_point(self, message: str, keep_header: bool = False) -> None:
        if not keep_header:
            self.point_div.text = ""
        self.table_div.text = f"<p class='muted'>{html.escape(message)}</p>"
        for src in (self.orbit_src, self.mu_src, self.harm_src, self.harm_store_src,
                    self.strobe_src):
            src.data = {k: [] for k in src.data}
        if not keep_header:
            self.mark_src.data = {"x": [], "y": []}

    def draw_response(self, sigma: float, omega: float) -> None:
        """The omega line through the shown point (omega, sigma) of the store."""
        v, u = self.view, self.view.units
        sl = E.response_slice(v.ds, sigma, self.zeta, u)
        self.resp_src.data = {"x": sl["x"], "y": sl["y"], "color": list(sl["color"]),
                              "label": list(sl["label"]),
                              "size": np.where(sl["stable"], 6.0, 4.0)}
        self.resp.legend.visible = bool(len(sl["x"]))
        s_line = float(sl["line"][0])
        where = f" ({u.amp(s_line):.4g} N)" if u.physical else ""
        self.resp.title.text = (f"Frequency response at sigma = {s_line:.5g}{where}, zeta = "
                                f"{self.zeta:g}: the store's orbits (dotted: the clicked omega)")
        self.resp_span.location = float(u.freq(omega))

    # -- the sweep through the clicked point ---------------------------------------------
    def on_sweep(self) -> None:
        """Start the sweeps through the clicked point along the chosen axis (answered at once:
        the store's or an earlier sweep is drawn now, a computed one when poll sees it done)."""
        if self.point is None:
            self.sweep_div.text = ("<span id='sweep_state' class='err'>refused</span>: click a "
                                   "point of the map first")
            return
        if self.sweep_job is not None and self.sweep_job.state == "running":
            return
        omega, sigma = self.point
        axis = self.sweep_axis.value
        try:
            job = self.state.start_sweep(self.view, axis, omega, sigma, self.zeta)
        except ValueError as exc:
            self.sweep_div.text = (f"<span id='sweep_state' class='err'>refused</span>: "
                                   f"{html.escape(str(exc))}")
            return
        self.sweep_job = job
        self.sweep_store = self.path
        self.sweep_point = self.point
        self.poll_sweep()

    def poll_sweep(self) -> None:
        """The sweep asked for: "computing ..." (with the seconds so far) while it runs, then
        drawn; a failure shows its status and message."""
        job = self.sweep_job
        if job is None or job is self.sweep_shown:
            return
        if job.state == "running":
            self.sweep_button.disabled = True
            self.sweep_div.text = (
                f"<b>Sweep</b> up and down {html.escape(job.what)}: "
                f"<span id='sweep_state'>computing...</span> "
                f"({time.monotonic() - job.started:.0f} s; stepped_sweep on the server, "
                "both directions in turn)")
            return
        self.sweep_shown = job
        self.sweep_button.disabled = self.point is None
        if job.state == "failed":
            self.sweep_div.text = (f"<b>Sweep</b> up and down {html.escape(job.what)}: "
                                   f"<span id='sweep_state' class='err'>failed</span>: "
                                   f"{html.escape(job.message)}")
            return
        self.draw_sweep(job)

    def draw_sweep(self, job: SweepJob) -> None:
        sw, u = job.result, self.view.units
        cols = ES.sweep_columns(sw, u)
        for d, src in self.sweep_srcs.items():
            src.data = dict(cols[d])
        self.sweep_jump_src.data = dict(cols["jumps"])
        axis, fixed = sw["axis"], sw["fixed"]
        scale = u.freq if axis == "omega" else u.amp
        pt = self.sweep_point
        clicked = pt[0 if axis == "omega" else 1] if pt else float("nan")
        for span in self.sweep_spans:
            span.location = float(scale(clicked))
        for f in self.sweep_figs.values():
            f.xaxis.axis_label = cols["xlabel"]
        self.draw_sweep_line()
        n, ng = len(sw["value"]), self.view.ds.sizes[axis]
        where = ", ".join(f"{a} = {v:g}" for a, v in fixed.items())
        if sw["stride"] == 1:
            steps = (f"{n} steps, the store's grid values of {axis} (step {sw['grid_step']:.4g})")
        else:
            steps = (f"{n} steps: one in {sw['stride']} of the store's {ng} grid values of "
                     f"{axis} (more than the {ES.MAX_SWEEP_STEPS} a sweep of the page takes), "
                     "through the clicked value and both ends")
        secs = sw["seconds"]
        if job.origin == "stored":
            origin = ("<span id='sweep_state' class='ok'>from the store</span> (products/sweeps, "
                      "written by hertzmap run: not recomputed; "
                      f"{_secs(secs['up'])} up, {_secs(secs['down'])} down on its worker)")
        elif job.origin == "computed before":
            origin = ("<span id='sweep_state' class='ok'>done</span> (computed before by this "
                      f"server: {_secs(secs['up'])} up, {_secs(secs['down'])} down)")
        else:
            origin = (f"<span id='sweep_state' class='ok'>done</span>: computed here in "
                      f"{_secs(job.seconds)} ({_secs(secs['up'])} up, "
                      f"{_secs(secs['down'])} down)")
        jt = sw["settings"].get("jump_tol")
        jumps = []
        for j in sw["jumps"]:
            at = f"{axis} = {j['value']:.6g}"
            if u.physical:
                at += f" ({float(scale(j['value'])):.5g} {scale.unit})"
            jumps.append(f"{j['direction']}: {html.escape(j['kind'])} at {at}, "
                         f"{j['from_period'] or '-'}T &rarr; {j['to_period'] or '-'}T")
        self.sweep_div.text = (
            f"<b>Stepped-sine sweeps</b> up and down {axis} at {where}: {origin}; {steps}; "
            f"from rest, each step from where the last ended"
            + (f", jumps located to {jt:g}" if jt else "") + ". <span id='sweep_jumps'>"
            + ("jumps: " + "; ".join(jumps) if jumps else "no jump") + "</span>"
            + f"<br><span class='muted'><span style='color:{ES.SWEEP_COLORS['up']}'>&#9650; up "
            f"sweep</span>, <span style='color:{ES.SWEEP_COLORS['down']}'>&#9660; down "
            "sweep</span>; arrows: the jumps, from "
            "the step before to the step after, at the located value; dotted: the clicked "
            "point; dash-dotted on the map: the swept line</span>")

    def draw_sweep_line(self) -> None:
        """The drawn sweep's line over the map (when it is of the shown store and zeta)."""
        job, u = self.sweep_shown, self.view.units
        sw = job.result if job is not None and job.state == "done" else None
        if (sw is None or self.sweep_store != self.path
                or abs(sw["fixed"]["zeta"] - self.zeta) > 1e-12 * max(1.0, self.zeta)):
            self.sweep_line_src.data = {"x": [], "y": []}
            return
        lo, hi = float(np.min(sw["value"])), float(np.max(sw["value"]))
        if sw["axis"] == "omega":
            s = sw["fixed"]["sigma"]
            self.sweep_line_src.data = {"x": [float(u.freq(lo)), float(u.freq(hi))],
                                        "y": [float(u.amp(s))] * 2}
        else:
            w = sw["fixed"]["omega"]
            self.sweep_line_src.data = {"x": [float(u.freq(w))] * 2,
                                        "y": [float(u.amp(lo)), float(u.amp(hi))]}

    # -- refine ---------------------------------------------------------------------------
    def window(self) -> tuple[tuple[float, float], tuple[float, float]]:
        u = self.view.units
        return ((float(u.freq.inverse(self.xr.start)), float(u.freq.inverse(self.xr.end))),
                (float(u.amp.inverse(self.yr.start)), float(u.amp.inverse(self.yr.end))))

    def window_changed(self) -> None:
        """New default points for the visible window: twice the store's density there (at
        least 6 per axis), scaled down to the cap."""
        (o0, o1), (s0, s1) = self.window()
        ds = self.view.ds
        n_o = int(((ds["omega"] >= o0) & (ds["omega"] <= o1)).sum())
        n_s = int(((ds["sigma"] >= s0) & (ds["sigma"] <= s1)).sum())
        a, b = max(6, 2 * n_o - 1), max(6, 2 * n_s - 1)
        # a line study: its single axis stays one value
        if ds.sizes["omega"] == 1:
            a = 1
        if ds.sizes["sigma"] == 1:
            b = 1
        self.n_omega.disabled = ds.sizes["omega"] == 1
        self.n_sigma.disabled = ds.sizes["sigma"] == 1
        cap = self.state.max_refine_points
        if a * b > cap:
            f = (cap / (a * b)) ** 0.5
            a, b = max(2, int(a * f)), max(2, int(b * f))
        self.n_omega.value, self.n_sigma.value = a, b
        self.show_refine_plan()

    def show_refine_plan(self) -> None:
        job = self.state.job
        if job is not None and job.state in ("starting", "running"):
            return
        (o0, o1), (s0, s1) = self.window()
        om, sg = self.view.ds["omega"].values, self.view.ds["sigma"].values
        # as the refine will: the window clipped to the store's grid
        o0, o1 = max(o0, float(om.min())), min(o1, float(om.max()))
        s0, s1 = max(s0, float(sg.min())), min(s1, float(sg.max()))
        n = int(self.n_omega.value or 0) * int(self.n_sigma.value or 0)
        cap = self.state.max_refine_points
        over = n > cap
        u = self.view.units
        phys = (f" ({u.freq(o0):.5g}..{u.freq(o1):.5g} Hz, {u.amp(s0):.4g}..{u.amp(s1):.4g} N)"
                if u.physical else "")
        self.refine_div.text = (
            f"<div id='refine_plan'><b>Refine this window</b>: omega {o0:.5g}..{o1:.5g}, sigma "
            f"{s0:.5g}..{s1:.5g}{phys}, zeta = {self.zeta:g}: {n} points"
            + (f" <span class='err'>(more than the {cap} a refine may compute here)</span>"
               if over else f" (at most {cap})")
            + "</div><span class='muted'>computed by the job queue of this server into a new "
            "store next to the first, then shown here</span>" + self._last_job_text())

    def _last_job_text(self) -> str:
        job = self.state.job
        if job is None:
            return ""
        cls = "ok" if job.state == "done" else "err"
        return (f"<br>last refine: <span class='{cls}'>{html.escape(job.state)}</span>: "
                f"{html.escape(job.store.name)}: {html.escape(job.message)}")

    def on_refine(self) -> None:
        (o0, o1), (s0, s1) = self.window()
        try:
            job = self.state.start_refine(self.view.ds, (o0, o1), (s0, s1),
                                          int(self.n_omega.value), int(self.n_sigma.value),
                                          self.zeta)
        except ValueError as exc:
            msg = f"<span class='err'>refine refused: {html.escape(str(exc))}</span>"
            if "more than the" in str(exc):
                try:
                    text, _ = E.refine_study(self.view.ds, (o0, o1), (s0, s1),
                                             int(self.n_omega.value), int(self.n_sigma.value),
                                             self.zeta, max_points=10**12)
                    msg += ("<br>as a study for <code>hertzmap run STUDY.toml</code>:"
                            f"<pre>{html.escape(text)}</pre>")
                except ValueError:
                    pass
            self.refine_div.text = msg
            return
        self.refine_button.disabled = True
        self.refine_div.text = (f"refine started: {html.escape(job.store.name)} "
                                f"(study file {html.escape(job.study_file.name)})")

    # -- polling --------------------------------------------------------------------------
    def poll(self) -> None:
        self.poll_sweep()
        self.basins.poll()
        # the shown store: redrawn when its flags changed (a run still writing it)
        try:
            v = self.state.view(self.path)
        except Exception:
            v = self.view
        if v is not self.view:
            self.view = v
            self.draw_map(reset_window=False)
            if self.point is not None:
                self.show_point(*self.point)
        else:
            self.show_header()
        self.refresh_store_options()
        job = self.state.job
        if job is None:
            return
        if job.state in ("starting", "running"):
            self.refine_button.disabled = True
            done, total = job.progress()
            bar = (f"<progress value='{done}' max='{total}'></progress> "
                   f"<span id='refine_tasks'>{done}/{total}</span> tasks")
            self.refine_div.text = (f"<b>refine running</b>: {html.escape(job.store.name)}: "
                                    f"{html.escape(job.message)} {bar} "
                                    f"({time.monotonic() - job.started:.0f} s)")
            return
        self.refine_button.disabled = False
        if self.seen_job is not job:
            self.seen_job = job
            if job.state == "done":
                self.show_store(job.store)
                self.refine_div.text = (
                    f"<span class='ok'>refine done</span>: showing "
                    f"<span id='refined_store'>{html.escape(job.store.name)}</span> "
                    f"({html.escape(job.message)}; {job.seconds:.1f} s from the click, workers "
                    "started and warmed up); the first store stays in the selector")
            else:
                self.refine_div.text = (f"<span class='err'>refine failed</span>: "
                                        f"{html.escape(job.message)}")


def make_document(doc, state: ExploreState) -> None:
    Page(doc, state)
