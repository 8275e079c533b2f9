"""Recognition: a census transient stops as soon as it is recognised on an attractor its point
already knows, instead of running its whole budget (the idea of Attractors.jl's recurrences
mapper, on the stroboscopic map of paper Eq. 7).

What is known at a grid point is what its earlier transients found, in their order (the census
runs them one after another, so the result does not depend on the machine):

* **a periodic attractor** (a stable orbit of period m a transient settled on, confirmed by
  shooting): its m stroboscopic points, each with the tolerance CYCLE_TOL (1 + |x|) of the
  census's period detection. A transient is on it once its points stayed that near them for
  (CYCLE_REPEATS + 1) m consecutive periods: the detection's own evidence, without its Newton
  confirmation and its measures pass.
* **an open set** (a transient that did not settle within its first budget), only where the
  point has no stable orbit and only in the census's longer passes: its record window's
  points, each with the tolerance OPEN_QUANTILE of the set's own spacing (the distance from
  each point of the window's second half to the nearest of its first half: a point of the same
  set lands that near a known point with about that probability), at most OPEN_TOL_CAP
  (1 + |x|). A transient is on it once it stayed that near for OPEN_VISITS consecutive
  periods; it then leaves the longer passes and shares the fate of the set's transient.

Why open sets only in the longer passes, and why the first OPEN_LEADERS open transients (whose
sets are known once there are that many) are never recognised on one: a set that looks
chaotic can be a long chaotic transient, and the census learns so only when a transient
escapes from it; every transient that runs samples that escape. On the vibro-impact scene (zeta 0.01), at (1.175, 2.65) one
of 16 first-pass transients leaves the chaotic-looking set for a stable 7T orbit after about
100 periods, and at (0.70, 3.25) 6 of 16 escape to a stable 6T orbit after 1,000-9,000
periods: recognising first-pass transients on an open set lost the 7T orbit, and letting one
transient run for all lost the 6T orbit. Beside a stable orbit the census needs each
transient's own evidence that it does not escape to the orbit (study.solve.census,
"Unsettled"): open sets are not recognised there, and once a transient of the longer passes
reaches a stable orbit, those recognised on an open set go on, each first running the periods
the others ran meanwhile.

Labels: an open set is labelled by its transient's index (>= 0), a periodic attractor by
-1 - (its index among the point's periodic attractors).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from hertzmap.kernels.attractors import NO_LABEL, known_attractors

#: an open set's tolerance: this quantile of its own spacing ...
OPEN_QUANTILE = 0.9
#: ... at most this share of (1 + |x|)
OPEN_TOL_CAP = 0.05
#: consecutive periods near an open set's points that recognise a transient on it
OPEN_VISITS = 8
#: open transients that keep their own evidence before later ones may be recognised on their
#: sets (module docstring)
OPEN_LEADERS = 4


def periodic_label(index: int) -> int:
    """The label of the point's periodic attractor number ``index``."""
    return -1 - int(index)


def periodic_index(label: int) -> int:
    """The index of the periodic attractor a (negative) label names."""
    return -1 - int(label)


def open_tolerance(points: np.ndarray) -> float:
    """The tolerance of an open set's points (module docstring): OPEN_QUANTILE of the distances
    from its second half to the nearest point of its first half, at most OPEN_TOL_CAP
    (1 + the median |x|)."""
    half = points.shape[0] // 2
    cap = OPEN_TOL_CAP * (1.0 + float(np.median(np.hypot(points[:, 0], points[:, 1]))))
    if half < 1:
        return cap
    d, _ = cKDTree(points[:half]).query(points[half:])
    return float(min(np.quantile(d, OPEN_QUANTILE), cap))


class KnownAttractors:
    """The attractors a point's transients may be recognised on: labelled sets of
    stroboscopic points with their tolerance and visits (kernels.attractors.known_near), and
    the kernel's arrays of them (rebuilt when a set is added or removed)."""

    def __init__(self):
        # label -> (points, tolerance per point (None: an open set's, not computed yet), visits)
        self._sets: dict[int, tuple] = {}
        # label -> a certified stable orbit's row (kernels.attractors C_* columns)
        self._certified: dict[int, np.ndarray] = {}
        self._arrays: dict[bool, tuple] = {}

    def add_certified(self, label: int, row: np.ndarray) -> None:
        """A stable orbit with its certified neighbourhood (study.solve.certificate): a
        transient is on it once inside and contracting there (kernels.attractors)."""
        self._certified[int(label)] = np.asarray(row, float)
        self._arrays.clear()

    def certified(self, label: int) -> bool:
        return int(label) in self._certified

    def add_periodic(self, label: int, points: np.ndarray, cycle_tol: float,
                     visits: int) -> None:
        """A stable orbit's m stroboscopic points, each within cycle_tol (1 + |x|)."""
        points = np.asarray(points, float).reshape(-1, 2)
        self._sets[int(label)] = (points, cycle_tol * (1.0 + np.hypot(points[:, 0], points[:, 1])),
                                  int(visits))
        self._arrays.clear()

    def add_open(self, label: int, points: np.ndarray) -> None:
        """A transient's record window that did not settle (module docstring). Its tolerance
        is computed when a transient may first be recognised on it (arrays(open_sets=True)):
        a point whose census ends with its first pass never needs it."""
        points = np.asarray(points, float).reshape(-1, 2)
        points = points[np.all(np.isfinite(points), axis=1)]
        if points.shape[0] >= 2:
            self._sets[int(label)] = (points, None, OPEN_VISITS)
            self._arrays.pop(True, None)

    def remove(self, label: int) -> None:
        if self._sets.pop(label, None) is None:
            return
        if label >= 0:
            self._arrays.pop(True, None)    # the periodic-only arrays hold no open set
        else:
            self._arrays.clear()

    def remove_open(self) -> None:
        """Forget every open set (the point turned out to have a stable orbit)."""
        for label in [lab for lab in self._sets if lab >= 0]:
            self.remove(label)

    def arrays(self, open_sets: bool = True) -> tuple:
        """(known, known_label, cell_start, grid, cert, cert_label) for
        kernels.attractors.attractor_batch_into: every known attractor, or (``open_sets``
        False) the periodic ones only; the certified stable orbits always."""
        if open_sets not in self._arrays:
            sets = []
            for lab, (p, tol, visits) in self._sets.items():
                if lab < 0 or open_sets:
                    if tol is None:
                        tol = np.full(p.shape[0], open_tolerance(p))
                        self._sets[lab] = (p, tol, visits)
                    sets.append((p, np.full(p.shape[0], lab, np.int64), tol,
                                 np.full(p.shape[0], float(visits))))
            certs = sorted(self._certified.items())
            cert = (np.array([r for _, r in certs]), [lab for lab, _ in certs]) if certs \
                else ((), ())
            self._arrays[open_sets] = known_attractors(
                *(np.concatenate(column) for column in zip(*sets)), *cert) if sets else \
                known_attractors((), (), (), (), *cert)
        return self._arrays[open_sets]


#: nothing to recognise (a transient that runs its whole budget)
NOTHING_KNOWN = KnownAttractors()
__all__ = ["KnownAttractors", "NOTHING_KNOWN", "NO_LABEL", "OPEN_LEADERS", "OPEN_QUANTILE",
           "OPEN_TOL_CAP", "OPEN_VISITS", "open_tolerance", "periodic_index", "periodic_label"]
