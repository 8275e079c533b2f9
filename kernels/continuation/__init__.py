"""Continuation of periodic orbits and of their bifurcation curves (paper section 3.2, Fig.
6-10), one module per algorithm, on one predictor-corrector:

* ``core``: the problem (System, period_map_into, the fold / flip test functions), the
  parameter derivatives' finite-difference conventions, the Newton corrector on the
  pseudo-arclength hyperplane, the tangent, the step and its adaptation (adapt_step), the
  natural-parameter predictor (natural_prediction); the status codes a branch or curve ends
  with (BRANCH_STATUS).
* ``branch``: one-parameter branches (continue_orbit), the fold, flip and grazing points
  located on them, the switch onto the 2T branch at a flip (switch_at_flip).
* ``path``: the lean seed path in omega of the line search's fold turning (arc_path).
* ``extended_system``: the compiled extended system of a fold / flip / grazing curve and its
  chord corrector.
* ``extremum``: the extremum of a curve's parameter along a one-dimensional search (Brent's
  bounded search, recentred off the window's edge: bounded_extremum) and its continuation in
  a third parameter (continue_extremum: the core's natural-parameter predictor and step
  adaptation, landing on asked values); used by codim2 and by the thresholds
  (study.solve.thresholds).
* ``codim2``: points located on a traced curve (codimension-2 points, parameter extrema, the
  end of a 2T curve on the 1T orbit).
* ``curve``: fold, flip and grazing curves in any two of (omega, sigma, zeta) (trace_curve).

Pure: numpy over the numba shooting kernels (no I/O, no Dask, no xarray).
"""
from hertzmap.kernels.continuation.branch import (POINT_FIELDS, Branch, SpecialPoint,
                                                  continue_orbit, flip_eigenvector,
                                                  switch_at_flip)
from hertzmap.kernels.continuation.codim2 import CODIM2_KINDS, Codim2Point
from hertzmap.kernels.continuation.core import (BOUNDARY, BRANCH_POINT, BRANCH_STATUS, CLOSED,
                                                MAX_POINTS, START_FAIL, STEP_FAIL, System,
                                                flip_function, fold_function, period_map_into)
from hertzmap.kernels.continuation.curve import (VERTEX_CODIM2, VERTEX_EDGE, VERTEX_END,
                                                 VERTEX_EXTREMUM, VERTEX_FIELDS, VERTEX_FLAGS,
                                                 VERTEX_SEED, Curve, trace_curve)
from hertzmap.kernels.continuation.extended_system import (CURVE_KINDS, CURVE_PARAMS,
                                                           curve_system_into)
from hertzmap.kernels.continuation.extremum import (Extremum, ExtremumPath, bounded_extremum,
                                                    continue_extremum)
from hertzmap.kernels.continuation.path import arc_path

__all__ = ["BOUNDARY", "BRANCH_POINT", "BRANCH_STATUS", "CLOSED", "CODIM2_KINDS",
           "CURVE_KINDS", "CURVE_PARAMS", "MAX_POINTS", "POINT_FIELDS", "START_FAIL",
           "STEP_FAIL", "VERTEX_CODIM2", "VERTEX_EDGE", "VERTEX_END", "VERTEX_EXTREMUM",
           "VERTEX_FIELDS", "VERTEX_FLAGS", "VERTEX_SEED", "Branch", "Codim2Point", "Curve",
           "Extremum", "ExtremumPath", "SpecialPoint", "System", "arc_path",
           "bounded_extremum", "continue_extremum", "continue_orbit", "curve_system_into",
           "flip_eigenvector", "flip_function", "fold_function", "period_map_into",
           "switch_at_flip", "trace_curve"]
