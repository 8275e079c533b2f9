"""The figures of a store, declared once: which exist (their ``hertzmap plot --which`` names),
the products each draws from, when a store gets it and how many PNGs (its limits), and the
function that draws them. Importing it imports no matplotlib (the command line builds its help
from it): each draw function imports its figure's module when it draws.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np


@dataclass(frozen=True)
class Sheet:
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
        from hertzmap.study.products.catalog import NAMED_FREQUENCIES

        return self.omega.size <= NAMED_FREQUENCIES

    def path(self, which: str, tag: str = "") -> Path:
        return self.out / f"{self.name}_{which}{tag}.png"

    def zeta_tag(self, z) -> str:
        return f"_zeta{z:g}" if self.several_zeta or self.zeta.size > 1 else ""

    def line_tag(self, s, z, *, always: bool = False) -> str:
        """The files' tag of line (s, z): none for a study of one line, unless ``always``."""
        return (f"_sigma{s:g}" + self.zeta_tag(z) if always or self.lines > 1 or self.several_zeta
                else "")


def _map_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.plane_figures import plot_loss_of_contact_map

    if not sheet.is_map:
        return []
    return [plot_loss_of_contact_map(prods["loss_of_contact_map"], prods["bifurcation_curves"],
                                     sheet.path("map", sheet.zeta_tag(z)), zeta=z,
                                     mms=prods["mms_curves"], traced=prods.get("traced_curves"),
                                     isola=prods.get("isola_boundary"))
            for z in sheet.zeta]


def _measures_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.plane_figures import plot_map_measures

    if not sheet.is_map:
        return []
    return [plot_map_measures(prods["loss_of_contact_map"],
                              sheet.path("measures", sheet.zeta_tag(z)), zeta=z,
                              curves=prods["bifurcation_curves"])
            for z in sheet.zeta]


def _lyapunov_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.plane_figures import plot_lyapunov_map

    lcm = prods["loss_of_contact_map"]
    if not (sheet.is_map and "lyapunov_exponent" in lcm
            and np.isfinite(lcm["lyapunov_exponent"].values).any()):
        return []
    return [plot_lyapunov_map(lcm, sheet.path("lyapunov", sheet.zeta_tag(z)), zeta=z)
            for z in sheet.zeta]


def _bifurcation_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.plane_figures import plot_bifurcation_set

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


def _response_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.line_figures import plot_frequency_response, zoom_for

    if not (asked or sheet.lines <= figure.lines and not sheet.named_frequencies) \
            or sheet.omega.size < 2:
        return []
    fr = prods["frequency_response"]
    return [plot_frequency_response(fr, sheet.path("response", sheet.line_tag(s, z)), sigma=s,
                                    zeta=z, zoom=zoom_for(fr, s, z), mms=prods.get("mms_response"))
            for s in sheet.sigma for z in sheet.zeta]


def _harmonics_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.line_figures import plot_force_harmonics

    if not (asked or not sheet.named_frequencies) or sheet.omega.size < 2:
        return []
    ns, nz = figure.first
    return [plot_force_harmonics(prods["force_harmonics"],
                                 sheet.path("harmonics", sheet.line_tag(s, z)), sigma=s, zeta=z)
            for s in sheet.sigma[:ns] for z in sheet.zeta[:nz]]


def _strobe_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.line_figures import plot_bifurcation_diagram
    from hertzmap.study.products import diagram_line

    diagrams = prods["stroboscopic_diagram"]
    paths = []
    for i in range(diagrams.sizes["line"]):
        diag = diagram_line(diagrams, i)
        if diag.sizes["point"] and np.isclose(sheet.zeta, diag.attrs["zeta"]).any():
            paths.append(plot_bifurcation_diagram(diag, sheet.path("strobe", sheet.line_tag(
                diag.attrs["sigma"], diag.attrs["zeta"], always=True))))
    return paths


def _zeta_maps_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.plane_figures import plot_zeta_maps

    if not sheet.is_map or sheet.zeta.size < 2:
        return []
    pick = np.unique(np.linspace(0, sheet.zeta.size - 1, min(figure.lines, sheet.zeta.size))
                     .round().astype(int))
    return [plot_zeta_maps(prods["loss_of_contact_map"], prods["bifurcation_curves"],
                           sheet.path("zeta_maps"), zetas=sheet.zeta[pick],
                           mms=prods["mms_curves"], traced=prods.get("traced_curves"),
                           isola=prods.get("isola_boundary"))]


def _impact_onset_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.damping_figures import plot_impact_onset

    return [plot_impact_onset(prods["impact_onset"], sheet.path("impact_onset"))]


def _thresholds_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.damping_figures import plot_thresholds
    from hertzmap.study.products import MEASURED_STAR_RATIO, MEASURED_ZETA

    return [plot_thresholds(prods["thresholds"], sheet.path("thresholds"),
                            measured=(MEASURED_ZETA, MEASURED_STAR_RATIO))]


def _histories_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.line_figures import plot_time_histories

    th = prods["time_histories"]
    return [plot_time_histories(th, sheet.path("histories"))] if th.sizes["case"] else []


def _sweeps_figure(sheet, prods, asked, figure) -> list[Path]:
    from hertzmap.study.plots.line_figures import plot_sweeps
    from hertzmap.study.products.stepped_sweeps import sweep_line

    sweeps = prods["sweeps"]
    n = sweeps.sizes["line"]
    paths = []
    for i in range(n if asked else min(n, figure.lines)):
        line = sweep_line(sweeps, i)
        if sheet.zeta.size == 1 and not np.isclose(sheet.zeta, line.attrs["zeta"]).any():
            continue
        tag = "".join(f"_{k}{line.attrs[k]:g}" for k in ("omega", "sigma") if k in line.attrs)
        tag += sheet.zeta_tag(line.attrs["zeta"])
        paths.append(plot_sweeps(line, sheet.path("sweeps", tag if n > 1 else "")))
    return paths


@dataclass(frozen=True)
class Figure:
    """One figure of a store: ``which``, its name for ``hertzmap plot --which`` and in its
    files' names (``<study>_<which>[_...].png``) and ``help``, what it shows (the command
    line's help); ``products``, the products it draws from (the first must be at hand: the
    store gets the figure when it has that product); ``draw(sheet, prods, asked, figure)``,
    its PNGs for a store (``asked``: named in --which, not only "auto"); and its limits:
    ``lines``, at most this many (sigma, zeta) lines unless asked for (a figure drawn per
    line), or maps side by side; ``first``, the first this many sigma and zeta values."""
    which: str
    help: str
    products: tuple[str, ...]
    draw: Callable[..., list[Path]]
    lines: int | None = None
    first: tuple[int, int] | None = None


#: Every figure of a store, in the order they are drawn.
FIGURES: tuple[Figure, ...] = (
    Figure("map", "what the contact does over (omega, sigma): the kinds of stable response, "
           "chaos, the traced curves", ("loss_of_contact_map", "bifurcation_curves",
                                        "mms_curves", "traced_curves", "isola_boundary"),
           _map_figure),
    Figure("measures", "the map's measures: flight fraction and impact velocity of the stable "
           "responses", ("loss_of_contact_map", "bifurcation_curves"), _measures_figure),
    Figure("lyapunov", "the largest Lyapunov exponent of each point's attractors",
           ("loss_of_contact_map",), _lyapunov_figure),
    Figure("zeta_maps", "the maps at a few zeta values side by side, the first to the last",
           ("loss_of_contact_map", "bifurcation_curves", "mms_curves", "traced_curves",
            "isola_boundary"), _zeta_maps_figure, lines=4),
    Figure("bifurcation", "the bifurcation set: the grid's contours, the located and traced "
           "curves, the multiple-scales thresholds", ("bifurcation_curves", "mms_curves",
                                                      "loss_of_contact_map",
                                                      "located_bifurcations", "traced_curves",
                                                      "isola_boundary"), _bifurcation_figure),
    Figure("response", "the frequency response of each (sigma, zeta) line", (
        "frequency_response", "mms_response"), _response_figure, lines=8),
    Figure("harmonics", "the contact-force harmonics H1, H2, H1/2 along each line",
           ("force_harmonics",), _harmonics_figure, first=(4, 2)),
    Figure("strobe", "the stroboscopic bifurcation diagram of the census along sigma lines",
           ("stroboscopic_diagram",), _strobe_figure),
    Figure("histories", "the contact force over time at a few named frequencies",
           ("time_histories",), _histories_figure),
    Figure("thresholds", "sigma*, sigma** and the isola's join against zeta", ("thresholds",),
           _thresholds_figure),
    Figure("impact_onset", "where vibro-impacts start over (omega, zeta)", ("impact_onset",),
           _impact_onset_figure),
    Figure("sweeps", "stepped-sine sweeps up and down each line: H1, H2, H1/2 and the "
           "amplitude with their jumps, the stored branches behind", ("sweeps",),
           _sweeps_figure, lines=8),
)
#: Every figure's --which name, in the catalog's order.
WHICH = tuple(f.which for f in FIGURES)


def check_which(which: Sequence[str]) -> tuple[str, ...]:
    """``which`` as a tuple; ValueError on a name that is neither "auto" nor a figure's."""
    which = tuple(which)
    bad = [w for w in which if w not in WHICH + ("auto",)]
    if bad:
        raise ValueError(f"--which: unknown figure {bad[0]!r}; allowed: auto, "
                         + ", ".join(WHICH))
    return which


def products_for(which: Sequence[str]) -> tuple[str, ...] | None:
    """The products the figures ``which`` draw from (None: "auto", every product the store
    supports)."""
    which = check_which(which)
    if "auto" in which:
        return None
    return tuple(dict.fromkeys(p for f in FIGURES if f.which in which for p in f.products))


def which_help() -> str:
    """The --which choices and what each draws (the command line's help)."""
    return "auto (default: every figure the store's products support) or: " + "; ".join(
        f"{f.which} ({f.help})" for f in FIGURES)


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

    A loop over :data:`FIGURES`: each figure whose first product is in ``prods`` is drawn. ``ds``: the results (study.products.open_store; its grid and name only).
    ``which``: "auto" (every figure the products support), or names from :data:`WHICH`. Maps
    and bifurcation sets need >= 2 omega and >= 2 sigma; response curves are drawn unless asked
    for only for studies of at most the figure's ``lines`` (sigma, zeta) lines and more than a
    few named frequencies, harmonics only for the latter. ``zeta``: the figures of that
    zeta value only (the store's nearest: :func:`chosen_zeta`); by default every figure drawn
    per zeta is drawn for each of the store's zeta values. The products' axes omega, sigma,
    zeta are sorted first (stored, they are in the store's order: a study may list an axis
    downwards).
    """
    from hertzmap.study.products.results import sorted_axes

    which = check_which(which)
    prods = {name: sorted_axes(prod) for name, prod in prods.items()}
    zetas = np.asarray(ds["zeta"].values, float)
    sheet = Sheet(ds["omega"].values, ds["sigma"].values,
                   zetas if zeta is None else np.array([chosen_zeta(zetas, zeta)]), Path(out),
                   prefix or ds.attrs.get("hertzmap_study_name") or "study",
                   several_zeta=zetas.size > 1)
    paths: list[Path] = []
    for figure in FIGURES:
        if figure.products[0] in prods and ("auto" in which or figure.which in which):
            paths += figure.draw(sheet, prods, figure.which in which, figure)
    return paths
