"""The data behind ``hertzmap explore`` (the page lives in scheduler/doors/explore/): plain functions
of xarray Datasets, no server and no plotting library, so that every number the page shows can
be tested without a browser.

* :func:`units_of` - the page's units: Hz, N, um, mm/s, ms where the study has a ``[rig]``,
  dimensionless otherwise (:class:`Units`, linear scales of the dimensionless quantities).
* :func:`map_columns`, :func:`map_legend`, :func:`map_curves` - the loss-of-contact map of one
  zeta as cells (one per grid point, edges half-way to the neighbours), with a one-line
  summary of the point's orbits for the hover, and the curves drawn over it.
* :func:`nearest_point` - the grid point of a click.
* :func:`point_orbits`, :func:`orbit_history`, :func:`force_spectrum`,
  :func:`stroboscopic_points` - the orbits of a point from the store's start points, integrated
  again with ``kernels.simulate``.
* :func:`response_slice` - ptp against omega by class along the clicked sigma (paper Fig. 6).
* :func:`refine_study`, :func:`refine_store_name` - the study file of a finer grid over a
  window of the map, derived from the store's recorded study.
* :func:`task_progress` - tasks done / total of a store.
* the stepped-sine sweeps through the clicked point: study.explore_sweeps.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from hertzmap.kernels.model import DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL, Model
from hertzmap.kernels.records import ORBIT
from hertzmap.study import products as P
from hertzmap.study.orbit_rules import CLASS_LABELS
from hertzmap.study.schema import ATTRACTOR_KINDS

__all__ = [
    "MAX_REFINE_POINTS",
    "MAX_HOVER_POINTS",
    "Scale",
    "Units",
    "units_of",
    "class_colors",
    "map_columns",
    "map_legend",
    "map_curves",
    "MAP_CURVES",
    "MMS_CURVE",
    "nearest_point",
    "point_orbits",
    "orbit_history",
    "force_spectrum",
    "stroboscopic_points",
    "stored_attractors",
    "response_slice",
    "refine_study",
    "refine_store_name",
    "task_progress",
]

#: Most grid points one refine may ask for. At the block solver's 0.7-1.2 ms per point a refine
#: of this size takes 10-25 s on 2 cores (a lab machine answering while the user waits), and
#: the page draws a map of that many cells without lag; larger windows are a study for
#: ``hertzmap run`` (the page shows the study text).
MAX_REFINE_POINTS = 20_000

#: Above this many points per zeta the hover carries the point's class but not the per-orbit
#: summary (about 150 bytes per point sent to the browser).
MAX_HOVER_POINTS = 40_000


# ---------------------------------------------------------------------------------------------
# units
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Scale:
    """A page quantity = ``factor`` x the dimensionless one; ``label`` names it with its unit."""

    factor: float
    unit: str
    label: str

    def __call__(self, x):
        return np.asarray(x, float) * self.factor

    def inverse(self, x):
        return np.asarray(x, float) / self.factor


@dataclass(frozen=True)
class Units:
    """The scales of the page: excitation frequency, amplitude, displacement, velocity, time,
    force. ``physical`` is True where the study has a ``[rig]`` (paper Eq. 1-8)."""

    physical: bool
    freq: Scale
    amp: Scale
    disp: Scale
    vel: Scale
    time: Scale
    force: Scale
    f0_hz: float = float("nan")
    preload_n: float = float("nan")


def units_of(ds: xr.Dataset, rig: Any = None) -> Units:
    """Units of the page for a store: with its rig (``products.rig_of``), omega -> Hz (omega f0),
    sigma -> N (force amplitude sigma N), q -> um (z - z_s = q z_s / n), q' -> mm/s,
    tau -> ms (tau / Omega), F/N -> N; dimensionless otherwise."""
    rig = P.rig_of(ds) if rig is None else rig
    if rig is None:
        return Units(
            physical=False,
            freq=Scale(1.0, "1", "omega (excitation / natural frequency)"),
            amp=Scale(1.0, "1", "sigma (excitation amplitude / preload)"),
            disp=Scale(1.0, "1", "q = n (z - z_s) / z_s"),
            vel=Scale(1.0, "1", "dq/dtau"),
            time=Scale(1.0, "1", "tau = Omega t"),
            force=Scale(1.0, "1", "contact force F / N"),
        )
    to_m = rig.z_s / rig.n          # paper Eq. 5: z - z_s = q z_s / n
    return Units(
        physical=True,
        freq=Scale(rig.f0, "Hz", "excitation frequency [Hz]"),
        amp=Scale(rig.N, "N", "excitation force amplitude [N]"),
        disp=Scale(to_m * 1e6, "um", "displacement z - z_s [um]"),
        vel=Scale(to_m * rig.Omega * 1e3, "mm/s", "velocity [mm/s]"),
        time=Scale(1e3 / rig.Omega, "ms", "time [ms]"),
        force=Scale(rig.N, "N", "contact force [N]"),
        f0_hz=rig.f0,
        preload_n=rig.N,
    )


# ---------------------------------------------------------------------------------------------
# colours (the PNG figures' own, study/plots/style.py, as hex for a browser)
# ---------------------------------------------------------------------------------------------

def _hex(color: str) -> str:
    from matplotlib.colors import to_hex
    return to_hex(color)


def class_colors() -> dict[int, tuple[str, str]]:
    """{orbit class code: (hex colour, label)}: the colours of the PNG figures."""
    from hertzmap.study.plots import style
    return {c: (_hex(col), label) for c, (col, label) in style.CLASS_STYLE.items()}


def _set_styles() -> tuple[dict[int, str], dict[int, str]]:
    from hertzmap.study.plots import style
    # the loss-of-contact map's colours and labels of its classes (map_class)
    return ({c: _hex(v) for c, v in style.SET_COLORS.items()}, dict(style.SET_LABELS))


_CLASS_SHORT = CLASS_LABELS      # study.orbit_rules: one label per class


# ---------------------------------------------------------------------------------------------
# the map
# ---------------------------------------------------------------------------------------------

def _edges(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cell edges of sorted axis values: half-way to the neighbours (non-uniform grids too)."""
    v = np.asarray(values, float)
    if v.size == 1:
        h = 0.025 * abs(v[0]) if v[0] else 0.01
        return v - h, v + h
    mid = 0.5 * (v[1:] + v[:-1])
    lo = np.concatenate([[v[0] - (mid[0] - v[0])], mid])
    hi = np.concatenate([mid, [v[-1] + (v[-1] - mid[-1])]])
    return lo, hi


def _fmt(x: float, digits: int = 4) -> str:
    return "-" if not np.isfinite(x) else f"{x:.{digits}g}"


def _orbit_summaries(ds: xr.Dataset, classes: np.ndarray, units: Units) -> np.ndarray:
    """(omega, sigma) array of one HTML line per orbit: period, stability, min q, flight
    fraction, impact velocity."""
    n_o, n_s, n_slot = classes.shape
    out = np.empty((n_o, n_s), dtype=object)
    get = {v: (ds[v].transpose("omega", "sigma", "solution").values if v in ds else None)
           for v in ("min_q", "flight_fraction", "max_impact_velocity")}
    du, vu = units.disp, units.vel
    for i in range(n_o):
        for j in range(n_s):
            lines = []
            for s in range(n_slot):
                c = int(classes[i, j, s])
                if c == 0:
                    continue
                parts = [f"#{s} {_CLASS_SHORT[c]}"]
                if get["min_q"] is not None:
                    parts.append(f"min q {_fmt(du(get['min_q'][i, j, s]))}"
                                 + (f" {du.unit}" if units.physical else ""))
                    ff = get["flight_fraction"][i, j, s]
                    parts.append(f"flight {_fmt(100 * ff, 3)} %")
                    iv = get["max_impact_velocity"][i, j, s]
                    if np.isfinite(iv) and iv > 0:
                        parts.append(f"impact {_fmt(vu(iv))}"
                                     + (f" {vu.unit}" if units.physical else ""))
                lines.append(", ".join(parts))
            out[i, j] = "<br>".join(lines) if lines else "no periodic orbit found"
    return out


def map_columns(ds: xr.Dataset, lcm: xr.Dataset, zeta: float, units: Units,
                *, summaries: bool | None = None) -> dict[str, np.ndarray]:
    """Columns of the map's cells at the nearest ``zeta``: one per grid point (omega-major),
    ``left right bottom top`` (page units), ``omega sigma`` (dimensionless), ``x y`` (page
    units), ``code`` (map_class, 0 where not computed), ``color``, ``label``, ``n_orbits``,
    ``n_stable``, ``computed`` and ``summary`` (HTML, one line per orbit; omitted beyond
    :data:`MAX_HOVER_POINTS` unless ``summaries`` says otherwise). ``ds`` and ``lcm`` come from
    ``products.open_store`` and ``products.loss_of_contact_map``."""
    m = lcm.sel(zeta=zeta, method="nearest")
    om = m["omega"].values
    sg = m["sigma"].values
    olo, ohi = _edges(om)
    slo, shi = _edges(sg)
    W, S = np.meshgrid(om, sg, indexing="ij")
    computed = m["computed"].transpose("omega", "sigma").values.astype(bool)
    field = "map_class" if "map_class" in m else "stable_set"
    code = np.where(computed, m[field].transpose("omega", "sigma").values.astype(int), 0)
    set_color, set_label = _set_styles()
    label = np.array([set_label[c] for c in code.ravel()], dtype=object).reshape(code.shape)
    label = np.where(computed, label, "not computed yet")
    cols = {
        "left": units.freq(np.broadcast_to(olo[:, None], W.shape)).ravel(),
        "right": units.freq(np.broadcast_to(ohi[:, None], W.shape)).ravel(),
        "bottom": units.amp(np.broadcast_to(slo[None, :], W.shape)).ravel(),
        "top": units.amp(np.broadcast_to(shi[None, :], W.shape)).ravel(),
        "omega": W.ravel(), "sigma": S.ravel(),
        "x": units.freq(W).ravel(), "y": units.amp(S).ravel(),
        "code": code.ravel(),
        "color": np.array([set_color[c] if ok else "#f4f4f4"
                           for c, ok in zip(code.ravel(), computed.ravel())], dtype=object),
        "label": label.ravel(),
        "n_orbits": m["n_orbits"].transpose("omega", "sigma").values.ravel().astype(int),
        "n_stable": m["n_stable"].transpose("omega", "sigma").values.ravel().astype(int),
        "computed": computed.ravel(),
    }
    if summaries is None:
        summaries = W.size <= MAX_HOVER_POINTS
    if summaries:
        d = ds.sel(zeta=[zeta], method="nearest")
        classes = P.orbit_classes(d).isel(zeta=0).transpose("omega", "sigma", "solution").values
        summ = _orbit_summaries(d.isel(zeta=0), classes, units)
        summ = np.where(computed, summ, "")
        cols["summary"] = summ.ravel()
    else:
        cols["summary"] = np.full(W.size, "(hover summaries off above "
                                  f"{MAX_HOVER_POINTS} points: click the point)", dtype=object)
    return cols


def map_legend(codes) -> list[tuple[int, str, str]]:
    """(code, hex colour, label) of the map classes present in ``codes``."""
    set_color, set_label = _set_styles()
    return [(int(c), set_color[int(c)], set_label[int(c)]) for c in sorted(set(np.asarray(codes)
                                                                                .ravel().tolist()))]


#: Curves drawn over the map (as the PNG map): (name, colour, dash, label).
MAP_CURVES = (
    ("flip_1T", "#000000", "solid", "flip of 1T"),
    ("grazing_1T", "#9467bd", "dashed", "grazing of 1T"),
    ("grazing_2T", "#d62728", "dashed", "grazing of stable 2T"),
    ("isola", "#ff00ff", "dotted", "isola (heuristic)"),
)
#: The multiple-scales flip curve over the map, same form.
MMS_CURVE = ("mms_sigma2", "#1f77b4", "solid", "MMS sigma2 (flip)")


def map_curves(curves: xr.Dataset, mms: xr.Dataset | None, zeta: float, units: Units,
               omega_range: tuple[float, float] | None = None
               ) -> list[dict[str, Any]]:
    """The curves over the map at ``zeta`` in page units: [{name, label, color, dash, xs, ys}]
    (xs, ys: one list per connected line). MMS sigma2 only on ``omega_range``."""
    out = []
    for name, color, dash, label in MAP_CURVES:
        segs = P.curve_segments(curves, name, zeta) if curves.sizes.get("vertex", 0) else []
        if segs:
            out.append({"name": name, "label": label, "color": color, "dash": dash,
                        "xs": [units.freq(s[:, 0]).tolist() for s in segs],
                        "ys": [units.amp(s[:, 1]).tolist() for s in segs]})
    if mms is not None:
        m = mms.sel(zeta=zeta, method="nearest")
        w = m[P.MMS_OMEGA].values
        s2 = m["sigma2"].values
        keep = np.isfinite(s2)
        if omega_range is not None:
            keep &= (w >= omega_range[0]) & (w <= omega_range[1])
        if keep.any():
            name, color, dash, label = MMS_CURVE
            out.append({"name": name, "label": label, "color": color,
                        "dash": dash, "xs": [units.freq(w[keep]).tolist()],
                        "ys": [units.amp(s2[keep]).tolist()]})
    return out


def nearest_point(ds: xr.Dataset, x: float, y: float, units: Units
                  ) -> tuple[float, float] | None:
    """(omega, sigma) of the grid point whose cell holds the page point (x, y), None outside."""
    om = ds["omega"].values
    sg = ds["sigma"].values
    w = float(units.freq.inverse(x))
    s = float(units.amp.inverse(y))
    olo, ohi = _edges(om)
    slo, shi = _edges(sg)
    if not (olo[0] <= w <= ohi[-1] and slo[0] <= s <= shi[-1]):
        return None
    return float(om[np.argmin(np.abs(om - w))]), float(sg[np.argmin(np.abs(sg - s))])


# ---------------------------------------------------------------------------------------------
# the orbits of a point
# ---------------------------------------------------------------------------------------------

#: the orbit table's rows: the stored scalar fields of the orbit record (kernels.records),
#: but the solver's status (every listed orbit converged) and its diagnostics
ORBIT_TABLE_FIELDS = tuple(f for f in ORBIT.stored() if f.dim is None
                           and f.output != "diagnostics" and f.name != "status")
_ORBIT_VARS = tuple(f.name for f in ORBIT_TABLE_FIELDS)


def point_orbits(ds: xr.Dataset, omega: float, sigma: float, zeta: float) -> xr.Dataset:
    """The distinct converged orbits stored at the grid point nearest (omega, sigma, zeta)
    (``products.valid_orbits``: duplicates dropped), over dim ``orbit``: ``slot``,
    ``orbit_class``, the stored fields of :data:`ORBIT_TABLE_FIELDS`, ``multipliers`` (orbit,
    multiplier) and, when stored, ``force_harmonics`` (orbit, harmonic) and the census's
    ``basin_fraction`` of the orbits that are its periodic attractors. Attrs: the grid point's
    omega, sigma, zeta."""
    pt = ds.sel(omega=[omega], sigma=[sigma], zeta=[zeta], method="nearest")
    valid = P.valid_orbits(pt).values[0, 0, 0]
    cls = P.orbit_classes(pt).values[0, 0, 0]
    slots = np.flatnonzero(valid)
    p = pt.isel(omega=0, sigma=0, zeta=0, solution=slots)
    out = xr.Dataset(coords={"orbit": np.arange(slots.size)})
    out["slot"] = ("orbit", slots.astype(int))
    out["orbit_class"] = ("orbit", cls[slots].astype(int))
    for v in _ORBIT_VARS:
        if v in p:
            out[v] = ("orbit", p[v].values)
    out["multipliers"] = (("orbit", "multiplier"),
                          p["multipliers"].transpose("solution", "multiplier").values)
    if "force_harmonics" in p:
        out["force_harmonics"] = (("orbit", "harmonic"),
                                  p["force_harmonics"].transpose("solution", "harmonic").values)
    if "attractor_solution" in pt:
        # the census's basin share of each orbit that is one of its periodic attractors (NaN:
        # not an attractor the census's transients reached, or the census did not run)
        a = pt.isel(omega=0, sigma=0, zeta=0)
        basin = np.full(slots.size, np.nan)
        for link, share, kind in zip(a["attractor_solution"].values, a["basin_fraction"].values,
                                     a["attractor_kind"].values):
            if kind == ATTRACTOR_KINDS["periodic"] and link in slots:
                basin[np.flatnonzero(slots == link)[0]] = share
        out["basin_fraction"] = ("orbit", basin)
    model = Model.of(ds.attrs)
    out.attrs = {"omega": float(pt["omega"].values[0]), "sigma": float(pt["sigma"].values[0]),
                 "zeta": float(pt["zeta"].values[0]),
                 "exponent": model.exponent, "model": model.law, "rtol": model.rtol,
                 "contact_threshold": P.contact_threshold(ds)}
    return out


def _simulate_kwargs(orbits: xr.Dataset) -> dict[str, Any]:
    return {"exponent": float(orbits.attrs["exponent"]), "model": orbits.attrs["model"],
            "rtol": float(orbits.attrs["rtol"])}


def orbit_history(orbits: xr.Dataset, k: int, *, samples_per_period: int = 1024
                  ) -> dict[str, np.ndarray]:
    """Orbit ``k`` of :func:`point_orbits` integrated with ``kernels.simulate`` from its stored
    start point over one period of the orbit (``period`` forcing periods), at the store's rtol:
    {"tau", "q", "v", "force" (F/N), "status"} on ``period x samples_per_period + 1`` uniform
    samples, the last one closing the orbit."""
    from hertzmap.kernels import simulate

    w, s, z = (orbits.attrs[a] for a in ("omega", "sigma", "zeta"))
    per = int(orbits["period"].values[k])
    t_end = per * 2 * np.pi / w
    t = np.linspace(0.0, t_end, per * samples_per_period + 1)
    r = simulate(w, s, z, (float(orbits["q0"].values[k]), float(orbits["v0"].values[k])),
                 t_end=t_end, t_eval=t, **_simulate_kwargs(orbits))
    return {"tau": t, "q": r["q"], "v": r["v"], "force": r["force"], "status": r["status"]}


def force_spectrum(history: dict[str, np.ndarray], period: int, kmax: int = 8
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(ratio, amplitude): amplitudes of the contact force F/N of one orbit period of
    :func:`orbit_history` at ratio = k / period times the excitation frequency, k = 1..kmax
    (the store's ``force_harmonics`` are k = 1..4 of the same series, one-sided amplitudes)."""
    f = np.asarray(history["force"], float)[:-1]     # one period, the closing sample dropped
    c = np.fft.rfft(f) / f.size
    k = np.arange(1, kmax + 1)
    return k / period, 2.0 * np.abs(c[k])


def stored_attractors(ds: xr.Dataset, omega: float, sigma: float, zeta: float
                      ) -> list[dict[str, Any]]:
    """The attractor census's results at the nearest grid point (docs/dataset.md): per
    attractor its kind, period, basin fraction, exponent, impact measures and stored
    stroboscopic points; empty where the census did not run (or the store has none)."""
    if "attractor_count" not in ds:
        return []
    pt = ds.sel(omega=omega, sigma=sigma, zeta=zeta, method="nearest")
    n = int(pt["attractor_count"])
    names = {c: k for k, c in ATTRACTOR_KINDS.items()}
    out = []
    for a in range(max(n, 0)):
        kind = int(pt["attractor_kind"][a])
        if kind == 0:
            continue
        q, v = pt["strobe_q"][a].values, pt["strobe_v"][a].values
        keep = np.isfinite(q)
        out.append({"kind": names[kind], "period": int(pt["attractor_period"][a]),
                    "basin": float(pt["basin_fraction"][a]),
                    "lyapunov": float(pt["lyapunov_exponent"][a]),
                    "impact": float(pt["attractor_max_impact_velocity"][a]),
                    "peak_force": float(pt["attractor_peak_force"][a]),
                    "strobe": np.column_stack([q[keep], v[keep]])})
    return out


def stroboscopic_points(omega: float, sigma: float, zeta: float, x0, *, transient: int = 100,
                        periods: int = 200, exponent: float = DEFAULT_EXPONENT,
                        model: str = DEFAULT_LAW, rtol: float = DEFAULT_RTOL) -> np.ndarray:
    """(periods, 2) array of (q, q') at tau = m T, m = transient+1 .. transient+periods, of a
    simulation from ``x0``: the Poincare section of whatever attractor the start point falls
    on (one point for a 1T orbit, two for 2T, a cloud for a non-periodic attractor)."""
    from hertzmap.kernels import simulate

    T = 2 * np.pi / omega
    m = np.arange(transient + 1, transient + periods + 1)
    r = simulate(omega, sigma, zeta, x0, t_end=float(m[-1] * T), t_eval=m * T,
                 exponent=exponent, model=model, rtol=rtol)
    return np.column_stack([r["q"], r["v"]])


# ---------------------------------------------------------------------------------------------
# the frequency-response slice
# ---------------------------------------------------------------------------------------------

def response_slice(ds: xr.Dataset, sigma: float, zeta: float, units: Units
                   ) -> dict[str, np.ndarray]:
    """Every distinct orbit stored on the omega line at the nearest (sigma, zeta), as columns:
    ``omega``, ``x`` (page units), ``ptp`` (dimensionless), ``y`` (ptp in page units),
    ``orbit_class``, ``color``, ``label``, ``stable``. Attrs-like scalars: ``sigma``, ``zeta``
    in the ``line`` entry."""
    fr = P.frequency_response(ds, sigma, zeta)
    cls = fr["orbit_class"].values[:, 0, 0, :]
    ptp = fr["ptp"].values[:, 0, 0, :] if "ptp" in fr else np.full(cls.shape, np.nan)
    om = np.broadcast_to(fr["omega"].values[:, None], cls.shape)
    keep = (cls > 0) & np.isfinite(ptp)
    colors = class_colors()
    c = cls[keep]
    return {"omega": om[keep], "x": units.freq(om[keep]), "ptp": ptp[keep],
            "y": units.disp(ptp[keep]), "orbit_class": c,
            "color": np.array([colors[int(k)][0] for k in c], dtype=object),
            "label": np.array([colors[int(k)][1] for k in c], dtype=object),
            "stable": np.isin(c, (1, 2, 3, 6)),
            "line": np.array([float(fr["sigma"].values[0]), float(fr["zeta"].values[0])])}


# ---------------------------------------------------------------------------------------------
# refining a window
# ---------------------------------------------------------------------------------------------

def _round(x: float, digits: int = 7) -> float:
    """A window end rounded to ``digits`` significant digits (readable study files)."""
    if x == 0 or not math.isfinite(x):
        return float(x)
    return float(f"{x:.{digits}g}")


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"no TOML form for {v!r}")


def _study_toml(d: dict[str, Any], grid: dict[str, Any]) -> str:
    lines = ["[study]", f"name = {_toml_value(d['study']['name'])}",
             f"description = {_toml_value(d['study']['description'])}", "", "[grid]"]
    for ax in ("omega", "sigma", "zeta"):
        g = grid[ax]
        if isinstance(g, dict):
            lines.append(f"{ax} = {{ start = {_toml_value(g['start'])}, stop = "
                         f"{_toml_value(g['stop'])}, num = {int(g['num'])} }}")
        else:
            lines.append(f"{ax} = {_toml_value(g)}")
    model = d["model"]
    lines += ["", "[model]", f"kind = {_toml_value(model['kind'])}"]
    if model["kind"] == "hertz" and model.get("exponent") is not None:
        lines.append(f"exponent = {_toml_value(float(model['exponent']))}")
    lines += ["", "[solver]", f"rtol = {_toml_value(float(d['solver']['rtol']))}", "",
              "[search]"]
    for k, v in d["search"].items():
        lines.append(f"{k} = {_toml_value(v)}")
    lines += ["", "[products]", f"outputs = {_toml_value(list(d['products']['outputs']))}"]
    if d.get("sweep"):
        # the sweeps output's settings (axis, jump_tol, periods): a refine sweeps as the store
        lines += ["", "[sweep]"] + [f"{k} = {_toml_value(v)}" for k, v in d["sweep"].items()]
    if d.get("rig"):
        lines += ["", "[rig]"] + [f"{k} = {_toml_value(v)}" for k, v in sorted(d["rig"].items())]
    return "\n".join(lines) + "\n"


def refine_study(ds: xr.Dataset, omega_range: tuple[float, float],
                 sigma_range: tuple[float, float], num_omega: int, num_sigma: int,
                 zeta: float, *, max_points: int = MAX_REFINE_POINTS):
    """(study file text, validated ``study.spec.Study``) of the store's recorded study on a finer
    grid: ``num_omega`` x ``num_sigma`` points over the window (dimensionless ranges, clipped to
    the store's grid), at the grid's zeta nearest ``zeta``; everything else (model, solver,
    periods, outputs, rig) as recorded. Its name is the store's study name with
    ``.refine-<hash8>`` (hash8: of the refined content, so the same window gives the same
    study and a rerun resumes its store). Raises ValueError naming what is wrong (no recorded
    study, an empty window, too few or too many points)."""
    from hertzmap.study.spec import StudyError, parse_study

    text = ds.attrs.get("hertzmap_study_toml")
    if not text:
        raise ValueError("the store has no recorded study (attr hertzmap_study_toml)")
    try:
        base = parse_study(text, default_name=ds.attrs.get("hertzmap_study_name", "study"))
    except StudyError as exc:
        raise ValueError(f"the store's recorded study is invalid: {exc}") from None
    axes = {}
    for name, rng, num in (("omega", omega_range, num_omega), ("sigma", sigma_range, num_sigma)):
        grid = ds[name].values
        if grid.size == 1:
            # a line study: this axis stays its one value (a finer line along the other)
            axes[name] = (float(grid[0]), 1)
            continue
        lo, hi = sorted(float(x) for x in rng)
        lo, hi = _round(max(lo, float(grid.min()))), _round(min(hi, float(grid.max())))
        if not lo < hi:
            raise ValueError(f"window: {name} {lo:g}..{hi:g} is empty inside the store's grid "
                             f"({grid.min():g}..{grid.max():g})")
        if int(num) != num or num < 2:
            raise ValueError(f"points along {name}: need an integer >= 2, got {num}")
        axes[name] = ({"start": lo, "stop": hi, "num": int(num)}, int(num))
    n_pts = axes["omega"][1] * axes["sigma"][1]
    num_omega, num_sigma = axes["omega"][1], axes["sigma"][1]
    if n_pts > max_points:
        raise ValueError(f"{num_omega} x {num_sigma} = {n_pts} points: more than the "
                         f"{max_points} a refine may compute here; narrow the window, lower "
                         "the points, or run the study text with hertzmap run")
    z = float(ds["zeta"].values[np.argmin(np.abs(ds["zeta"].values - zeta))])
    d = base.to_dict()
    grid = {"omega": axes["omega"][0], "sigma": axes["sigma"][0], "zeta": z}

    def describe(name):
        g = grid[name]
        return f"{name} {g['start']:g}..{g['stop']:g} ({g['num']})" if isinstance(g, dict) \
            else f"{name} {g:g}"
    d["study"]["description"] = (f"refinement of {base.name}: {describe('omega')}, "
                                 f"{describe('sigma')}, zeta {z:g} (hertzmap explore)")
    # the name carries a hash of the rest, so it cannot be part of what is hashed
    probe = parse_study(_study_toml(d, grid), default_name=base.name)
    tag = hashlib.sha256(probe.canonical_json().encode()).hexdigest()[:8]
    suffix = f".refine-{tag}"
    d["study"]["name"] = base.name[: 64 - len(suffix)] + suffix
    text = _study_toml(d, grid)
    try:
        study = parse_study(text)
    except StudyError as exc:
        raise ValueError(f"refined study: {exc}") from None
    return text, study


def refine_store_name(store_name: str, study_name: str) -> str:
    """File name of a refine's store next to the first store ``store_name`` (``X.zarr``):
    ``X.refine-<hash8>.zarr``, hash8 from the refined study's name."""
    stem = store_name[:-5] if store_name.endswith(".zarr") else store_name
    tag = study_name.rsplit(".refine-", 1)[-1]
    return f"{stem}.refine-{tag}.zarr"


def task_progress(ds: xr.Dataset) -> tuple[int, int]:
    """(tasks done, tasks total) of a store (its ``task_done`` flags)."""
    if "task_done" not in ds:
        return (1, 1)
    td = np.asarray(ds["task_done"].values, bool)
    return int(td.sum()), int(td.size)


# -- the basin map of a clicked point ---------------------------------------------------------

#: the page's choices of the basin map's cells per side (the default first: issue 52's
#: resolution, about a minute on 2 cores)
BASIN_SIDES = (1000, 300, 100)
#: colours of the basin map's attractors (index = label; -1, not yet computed: transparent)
BASIN_PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
                 "#7f7f7f", "#bcbd22", "#17becf")


def keep_colours(final: np.ndarray, provisional: np.ndarray) -> np.ndarray:
    """The final labels of a basin map renumbered as the provisional ones (the tiles') where
    they overlap most, so that an attractor keeps its colour when the map is done; a final
    label with no provisional cell gets the next free number."""
    out = np.full(final.shape, -1, np.int16)
    used: set[int] = set()
    for lab in np.unique(final[final >= 0]):
        mine = final == lab
        prov = provisional[mine & (provisional >= 0)]
        counts = np.bincount(prov) if prov.size else np.zeros(0, int)
        for cand in np.argsort(-counts, kind="stable"):
            if counts[cand] > 0 and int(cand) not in used:
                break
        else:
            cand = next(i for i in range(final.size + 1) if i not in used
                        and not (provisional == i).any())
        used.add(int(cand))
        out[mine] = cand
    return out


def basin_shares(dataset: xr.Dataset, census: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Rows of the page's table beside a basin map: each attractor of the map (kind, period,
    its share of the map's cells) with the census's share of the same attractor at the point
    (stored_attractors: same kind and period, one census attractor per row; NaN where the
    census has none)."""
    names = {c: k for k, c in ATTRACTOR_KINDS.items()}
    rows, taken = [], set()
    for a in range(dataset.sizes["basin_attractor"]):
        kind = names[int(dataset["attractor_kind"][a])]
        period = int(dataset["attractor_period"][a])
        match = next((i for i, c in enumerate(census) if i not in taken
                      and c["kind"] == kind and c["period"] == period), None)
        if match is not None:
            taken.add(match)
        rows.append({"kind": kind, "period": period,
                     "map": float(dataset["basin_fraction"][a]),
                     "census": census[match]["basin"] if match is not None else float("nan")})
    for i, c in enumerate(census):
        if i not in taken:
            rows.append({"kind": c["kind"], "period": c["period"], "map": float("nan"),
                         "census": c["basin"]})
    return rows
