"""The explore page's basin map of the clicked point (drawing only): a button that starts
``hertzmap basins``'s reuse method on the server's cluster (``ExploreState.start_basins``), the
map drawn as its tiles return and once done, and beside it the census's basin shares at the
point against the map's, with the boundary's measures.
"""
from __future__ import annotations

import html
import math
import time

import numpy as np
from bokeh.layouts import column, row
from bokeh.models import Button, ColumnDataSource, Div, LinearColorMapper, Select
from bokeh.plotting import figure

from hertzmap.study import explore_data as E
from hertzmap.study.solve.seeds import TRANSIENT_BOX

#: the image's side in pixels
MAP_PX = 420


def _div(text: str = "", width: int | None = None, name: str | None = None) -> Div:
    return Div(text=text, width=width, name=name)


class BasinPanel:
    """The widgets and their updates; ``set_point`` on a click, ``poll`` every page poll."""

    def __init__(self, state, width: int):
        self.state = state
        self.point: tuple | None = None          # (store path, omega, sigma, zeta)
        self.census: list[dict] = []
        self.shown_version = -1
        self.shown_job = None
        self.side = Select(title="initial states per side", value=str(E.BASIN_SIDES[0]),
                           options=[str(s) for s in E.BASIN_SIDES], width=170,
                           name="basin_side")
        self.button = Button(label="Basin map of this point", button_type="primary", width=220,
                             name="basin_button", disabled=True)
        self.button.on_click(self.on_click)
        self.status = _div("<span class='muted'>click a point, then compute its basin map: "
                           "which attractor each initial state (q, q') at tau = 0 ends on"
                           "</span>", width=width, name="basin_status")
        (q0, q1), (v0, v1) = TRANSIENT_BOX
        self.src = ColumnDataSource({"image": [np.full((2, 2), -1, np.int16)], "x": [q0],
                                     "y": [v0], "dw": [q1 - q0], "dh": [v1 - v0]},
                                    name="basin_image")
        mapper = LinearColorMapper(palette=list(E.BASIN_PALETTE), low=-0.5,
                                   high=len(E.BASIN_PALETTE) - 0.5,
                                   low_color=(0, 0, 0, 0), high_color="#000000")
        self.fig = figure(width=MAP_PX, height=MAP_PX, name="basin_map",
                          title="basins of the clicked point",
                          x_range=(q0, q1), y_range=(v0, v1),
                          x_axis_label="q at tau = 0", y_axis_label="dq/dtau at tau = 0",
                          tools="pan,wheel_zoom,box_zoom,reset,save")
        self.fig.image(image="image", x="x", y="y", dw="dw", dh="dh", source=self.src,
                       color_mapper=mapper)
        self.shares = _div("", width=max(200, width - MAP_PX - 20), name="basin_shares")

    def layout(self):
        return column(row(self.side, column(_div("&nbsp;"), self.button)), self.status,
                      row(self.fig, self.shares))

    def set_point(self, path, omega: float, sigma: float, zeta: float, census) -> None:
        """The clicked grid point and the census's attractors there (explore_data.
        stored_attractors): the button is enabled, the census's shares shown."""
        self.point = (path, omega, sigma, zeta)
        self.census = list(census)
        job = self.state.basin_job
        self.button.disabled = job is not None and job.state == "running"
        if job is None or job.state != "running":
            self.shares.text = self._table(None)

    def on_click(self) -> None:
        if self.point is None:
            self.status.text = ("<span id='basin_state' class='err'>refused</span>: click a "
                                "point of the map first")
            return
        path, omega, sigma, zeta = self.point
        try:
            self.state.start_basins(path, omega, sigma, zeta, int(self.side.value))
        except ValueError as exc:
            self.status.text = (f"<span id='basin_state' class='err'>refused</span>: "
                                f"{html.escape(str(exc))}")
            return
        self.shown_version = -1
        self.poll()

    def poll(self) -> None:
        """Redraw when tiles came back; say what is being done."""
        job = self.state.basin_job
        if job is None:
            return
        w, s, z = job.req.point
        where = f"omega {w:g}, sigma {s:g}, zeta {z:g}, {job.req.grid[0]} x {job.req.grid[1]}"
        if job.version != self.shown_version or job is not self.shown_job:
            self.shown_version, self.shown_job = job.version, job
            (q0, q1), (v0, v1) = job.req.q_range, job.req.v_range
            self.src.data = {"image": [job.labels.copy()], "x": [q0], "y": [v0],
                             "dw": [q1 - q0], "dh": [v1 - v0]}
        if job.state == "running":
            self.button.disabled = True
            self.status.text = (f"<b>Basin map</b> at {where}: <span id='basin_state'>"
                                f"computing...</span> ({time.monotonic() - job.started:.0f} s; "
                                f"{html.escape(job.message)}; tiles drawn as they return)")
            return
        self.button.disabled = self.point is None
        if job.state == "failed":
            self.status.text = (f"<b>Basin map</b> at {where}: <span id='basin_state' "
                                f"class='err'>failed</span>: {html.escape(job.message)}")
            return
        ds = job.dataset
        self.status.text = (
            f"<b>Basin map</b> at {where}: <span id='basin_state' class='ok'>done</span> "
            f"({html.escape(job.message)} on the workers; written into the store as "
            f"products/{html.escape(_group(ds))})")
        self.shares.text = self._table(job)

    def _table(self, job) -> str:
        """The census's basin shares at the point, beside the map's when it is done."""
        rows = (E.basin_shares(job.dataset, self.census) if job is not None
                and job.dataset is not None else
                [{"kind": c["kind"], "period": c["period"], "map": math.nan,
                  "census": c["basin"]} for c in self.census])
        colour = {}
        if job is not None and job.dataset is not None:
            final = job.dataset["basin_label"].values
            for a in range(job.dataset.sizes["basin_attractor"]):
                cells = job.labels[final == a]
                if cells.size:
                    colour[a] = E.BASIN_PALETTE[int(cells[0]) % len(E.BASIN_PALETTE)]
        out = ["<table id='basin_table'><tr><th></th><th>attractor</th><th>map</th>"
               "<th>census</th></tr>"]
        for i, r in enumerate(rows):
            name = f"{r['period']}T" if r["kind"] == "periodic" else r["kind"]
            swatch = (f"<span style='color:{colour[i]}'>&#9632;</span>" if i in colour else "")
            out.append(f"<tr data-attractor='{i}'><td>{swatch}</td><td>{name}</td>"
                       f"<td class='map'>{_pct(r['map'])}</td>"
                       f"<td class='census'>{_pct(r['census'])}</td></tr>")
        out.append("</table>")
        if not self.census:
            out.append("<span class='muted'>the store has no census at this point</span>")
        else:
            out.append("<span class='muted'>census: the share of its initial states "
                       "(a Halton set over the same box) per attractor</span>")
        if job is not None and job.dataset is not None:
            ds = job.dataset
            out.append(
                f"<p id='basin_measures'>S_b = {float(ds.basin_entropy):.3f} +- "
                f"{float(ds.basin_entropy_error):.3f}, S_bb = "
                f"{float(ds.boundary_basin_entropy):.3f} +- "
                f"{float(ds.boundary_basin_entropy_error):.3f} nats<br>uncertainty exponent "
                f"{float(ds.uncertainty_exponent):.3f} +- "
                f"{float(ds.uncertainty_exponent_error):.3f}: boundary dimension "
                f"{float(ds.boundary_dimension):.3f}<br>Wada (merging, r = "
                f"{ds.attrs['wada_dilation']} cells): {'yes' if int(ds.wada) else 'no'}</p>")
        return "".join(out)


def _pct(x: float) -> str:
    return "" if not math.isfinite(x) else f"{100 * x:.1f} %"


def _group(ds) -> str:
    from hertzmap.study.products.basin_map import basin_map_name
    return basin_map_name(ds.attrs["omega"], ds.attrs["sigma"], ds.attrs["zeta"])
