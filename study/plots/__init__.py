"""PNG figures from a study's store (and the paper's analytic figures), matplotlib Agg, by topic:

* ``figure_catalog`` - the figures of a store, declared once (:data:`FIGURES`: each its
  ``--which`` name, help, the products it draws from, its limits and draw function) and
  :func:`plot_results`, the loop over them. ``hertzmap plot STORE [--out DIR] [--which ...]``
  computes the products the figures need, stores them and calls it with the stored groups.
* ``plane_figures`` (the (omega, sigma) plane: maps, measures, Lyapunov, bifurcation set),
  ``line_figures`` (along a line: response, harmonics, stroboscopic diagram, histories,
  stepped sweeps),
  ``damping_figures`` (over zeta), ``basin_figures`` (a point's basin map), ``fit_figures``
  (a fit of measured sweeps: ``hertzmap fit``),
  ``paper_figures`` (the paper's analytic figures: ``hertzmap plot --paper fig02 ...``), and
  ``style`` (colours, labels, curve styles, saving), each figure a function of products and a
  path.

No product of a store is computed here: a store's figure draws the products it is given (the
paper's analytic figures compute their multiple-scales curves). No Dask, no scheduler, no store
writes. Figures are small (about 100 dpi) so that they can be committed.
"""
from hertzmap.study.plots.figure_catalog import (
    FIGURES,
    WHICH,
    Figure,
    Sheet,
    check_which,
    chosen_zeta,
    plot_results,
    products_for,
    which_help,
)

#: the figure functions, by the module of their topic: imported when first asked for
#: (``plots.plot_basin_map``), so that importing the package imports no matplotlib
_LAZY = {
    "plot_basin_map": "basin_figures", "plot_impact_onset": "damping_figures",
    "plot_thresholds": "damping_figures", "plot_bifurcation_diagram": "line_figures",
    "plot_force_harmonics": "line_figures", "plot_frequency_response": "line_figures",
    "plot_time_histories": "line_figures", "plot_sweeps": "line_figures",
    "PAPER_FIGURES": "paper_figures",
    "plot_paper": "paper_figures", "plot_bifurcation_set": "plane_figures",
    "plot_loss_of_contact_map": "plane_figures", "plot_lyapunov_map": "plane_figures",
    "plot_map_measures": "plane_figures", "plot_zeta_maps": "plane_figures",
    "plot_fit": "fit_figures",
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["FIGURES", "WHICH", "Figure", "Sheet", "check_which", "chosen_zeta", "products_for",
           "which_help", "plot_results", *_LAZY]
