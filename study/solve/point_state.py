"""What one grid point holds, and where each piece goes in the store: the one place that says
which orbit and which attractor takes which slot.

A point's state (:class:`PointState`) is

* its **orbits**: every distinct converged orbit found at the point (any period, stable or
  not: the grid's search, the census, the atlas), stored in the ``solution`` slots in the order
  (period, ptp) (:func:`slot_order`), so that slot 0 holds the 1T orbit of smallest ptp; where
  the study searches 1T orbits and none converged there, slot 0 holds instead why the best 1T
  solve failed (``status_record``: its status code, or ``time_limit`` for a point its block did
  not reach);
* its census's **attractors** (None where the census did not run): every one it told apart,
  largest basin first, in the ``attractor`` slots; a periodic attractor's
  ``attractor_solution`` is the slot its orbit is stored in, so the link follows the orbit
  wherever the order puts it;
* its count, ``orbits_found`` (every converged orbit: all of them are stored).

No cap: the arrays a set of points is written into have as many slots as the point that holds
most (study.schema.chunked_length: whole chunks), and the scheduler grows a store's slot dims
when a block needs more. The block solver (study.solve.block), the atlas's continuation and
census rounds (study.solve.atlas) all write points through :func:`write_states` and read them
back through :func:`stored_states`.

Pure: numpy, no I/O.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from hertzmap.kernels import status as st
from hertzmap.kernels.attractors import A
from hertzmap.kernels.records import ATTRACTOR
from hertzmap.study.schema import (ATTRACTOR_KINDS, ORBIT_VARIABLES, STROBE_POINTS, VARIABLES,
                                   chunked_length, empty_arrays, slot_counts)
from hertzmap.study.solve.census import Attractor, census_basin_entropy

#: what the identity and continuity rules, the slot order and the crossings read of a stored
#: orbit (the atlas reads them over its tiles' halos)
RULE_FIELDS = ("period", "status", "stable", "atlas_round", "min_q", "max_q", "ptp",
               "multipliers")
#: the stored attractor variables with one value per attractor slot (study.schema)
ATTRACTOR_SLOT_VARIABLES = tuple(n for n, v in VARIABLES.items() if v.layout == "attractor")
#: the per-point variables of the census (count and basin entropies)
CENSUS_POINT_VARIABLES = ("attractor_count", "basin_entropy", "boundary_basin_entropy")


def slot_order(orbits: list[dict]) -> list[dict]:
    """A point's converged orbits in slot order: by (period, ptp), ties in the order found."""
    return sorted(orbits, key=lambda o: (o["period"], o["ptp"]))


@dataclass
class StoredAttractor:
    """A census attractor read back from the store: the cell its variables are copied from
    (``source``: (i, j, k, slot) of the arrays it was read from) and the orbit it is (a
    periodic one), followed to that orbit's new slot when the point is written again."""

    source: tuple
    orbit: dict | None = None


@dataclass
class PointState:
    """One grid point: its orbits, the record of a failed 1T solve, its census (module
    docstring)."""

    orbits: list[dict] = field(default_factory=list)
    #: a non-converged solve stored in slot 0 where no 1T orbit converged (the best 1T try,
    #: or the time-limit mark of a point its block did not reach); None: nothing to say
    status_record: dict | None = None
    #: the census's attractors, largest basin first (census.Attractor as the census found
    #: them, StoredAttractor as read back); None: the census did not run here
    attractors: list | None = None
    #: the initial states the census ran (basin fractions are shares of them)
    n_states: int = 0
    #: whether the grid's search reached the point (False: its block's time budget ran out)
    visited: bool = True
    #: a stored point's cell in the arrays it was read from (its census's per-point values
    #: are copied from there while its attractors are not recomputed)
    source: tuple | None = None
    #: the point's omega (a periodic attractor's exponent is per unit tau: log|mu| / (m T))
    omega: float = math.nan

    def slots(self, periods: tuple[int, ...] = (1, 2)) -> list[dict]:
        """What the ``solution`` slots hold, in order (module docstring)."""
        ordered = slot_order(self.orbits)
        if self.status_record is not None and not (
                1 in periods and any(o["period"] == 1 for o in ordered)) \
                and (1 in periods or not self.visited):
            ordered = [self.status_record] + ordered
        return ordered

    @property
    def found(self) -> int:
        """``orbits_found``: the converged orbits (-1: the point was not computed)."""
        return len(self.orbits) if self.visited or self.orbits else -1


def _shape_slots(states: Mapping[tuple, PointState], periods) -> dict[str, int]:
    n_orbits = max((len(s.slots(periods)) for s in states.values()), default=0)
    n_att = max((len(s.attractors) for s in states.values() if s.attractors), default=0)
    return slot_counts(chunked_length(n_orbits), chunked_length(n_att))


def write_states(states: Mapping[tuple, PointState], shape: tuple[int, int, int],
                 names: tuple[str, ...], periods: tuple[int, ...] = (1, 2),
                 source: Mapping[str, np.ndarray] | None = None,
                 base: Mapping[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """The arrays (``names``: slot, point and attractor variables of study.schema) of a block
    of ``shape`` points holding ``states`` ({(i, j, k): PointState}), sized by the data: as
    many slots as the point that holds most, in whole chunks (at least those of ``base``).

    ``base``: arrays the points not in ``states`` are copied from (a tile whose other points
    the atlas did not change); ``source``: the arrays stored orbits and attractors (those with
    a ``source`` cell) are copied from. ``periods``: the periods the study searches (slot 0's
    failed-1T rule)."""
    slots = _shape_slots(states, periods)
    if base is not None:
        for name, a in base.items():
            v = VARIABLES.get(name)
            if v is not None and v.slot_dim is not None:
                slots[v.slot_dim] = max(slots[v.slot_dim], a.shape[3])
    out = empty_arrays(shape, slots, names)
    if base is not None:
        for name in names:
            if name in base:
                a = base[name]
                out[name][(slice(None),) * 3 + tuple(slice(0, n) for n in a.shape[3:])] = a
    for cell, state in states.items():
        write_point(out, cell, state, periods, source)
    return out


def write_point(arrays: dict[str, np.ndarray], cell: tuple, state: PointState,
                periods: tuple[int, ...] = (1, 2),
                source: Mapping[str, np.ndarray] | None = None) -> None:
    """Write one point's state into ``arrays`` at ``cell`` (i, j, k), every slot of it (the
    arrays have room: write_states sizes them)."""
    slots = state.slots(periods)
    for name in ORBIT_VARIABLES:
        if name not in arrays:
            continue
        arr = arrays[name]
        arr[cell] = VARIABLES[name].fill
        fill = VARIABLES[name].fill
        for slot, o in enumerate(slots):
            if "source" in o:
                arr[cell + (slot,)] = source[name][o["source"]]
            elif name in ("q0", "v0"):
                x0 = o.get("x0")
                arr[cell + (slot,)] = fill if x0 is None else x0[0 if name == "q0" else 1]
            else:
                # a status record carries what its failed solve gave (a time-limit mark: its
                # status alone)
                arr[cell + (slot,)] = o.get(name, fill)
    if "orbits_found" in arrays:
        arrays["orbits_found"][cell] = state.found
    if "attractor_solution" not in arrays:
        return
    for name in ATTRACTOR_SLOT_VARIABLES + CENSUS_POINT_VARIABLES:
        if name in arrays:
            arrays[name][cell] = VARIABLES[name].fill
    if state.attractors is None:
        return
    where = {id(o): slot for slot, o in enumerate(slots)}
    slot_of = lambda orbit: where.get(id(orbit), -1) if orbit is not None else -1
    if all(isinstance(a, StoredAttractor) for a in state.attractors):
        # read back and not recomputed: copied (what the arrays hold of them), each periodic
        # one's link following its orbit to the slot it is in now
        copied = [n for n in ATTRACTOR_SLOT_VARIABLES + CENSUS_POINT_VARIABLES
                  if n in arrays and n in source]
        for name in copied:
            if name in CENSUS_POINT_VARIABLES:
                arrays[name][cell] = source[name][state.source]
        for a_slot, a in enumerate(state.attractors):
            for name in copied:
                if name not in CENSUS_POINT_VARIABLES:
                    arrays[name][cell + (a_slot,)] = source[name][a.source]
            if a.orbit is not None:
                arrays["attractor_solution"][cell + (a_slot,)] = slot_of(a.orbit)
        return
    _write_census(arrays, cell, state.attractors, state.n_states, state.omega, slot_of)


#: (stored name, kernel column) of the attractor record's stored fields copied from its row as
#: they are (kernels.records.ATTRACTOR); the exponent and its error are the census's choice
_WINDOW_COLUMNS = tuple((f.name, A[f.kernel_columns[0]]) for f in ATTRACTOR.stored()
                        if f.kernel_columns and f.name not in ("lyapunov_exponent",
                                                                "lyapunov_error"))


def _write_census(arrays, cell, found: list[Attractor], n_states: int, omega: float,
                  slot_of: Callable[[dict | None], int]) -> None:
    """A census's attractors (study.solve.census.census) at ``cell``, every one in its slot."""
    arrays["attractor_count"][cell] = len(found)
    for a_slot, a in enumerate(found):
        at = cell + (a_slot,)
        arrays["attractor_kind"][at] = ATTRACTOR_KINDS[a.kind]
        if "unsettled_reason" in arrays:
            arrays["unsettled_reason"][at] = a.reason
        arrays["attractor_period"][at] = a.period
        arrays["attractor_solution"][at] = slot_of(a.orbit)
        arrays["basin_fraction"][at] = a.count / n_states
        row = a.row
        if a.kind == "periodic":
            # a stable orbit's exponent is that of its largest multiplier, per unit tau
            mu = float(np.abs(a.orbit["multipliers"]).max())
            T = 2.0 * math.pi / omega
            arrays["lyapunov_exponent"][at] = math.log(mu) / (a.period * T) if mu > 0 \
                else -math.inf
        elif row is not None:
            arrays["lyapunov_exponent"][at] = row[A["lyapunov"]]
            arrays["lyapunov_error"][at] = row[A["lyapunov_error"]]
        if row is not None:
            for name, column in _WINDOW_COLUMNS:
                arrays[name][at] = row[column]
        n = min(a.strobe.shape[0], STROBE_POINTS)
        if n:
            arrays["strobe_q"][at + (slice(STROBE_POINTS - n, None),)] = a.strobe[-n:, 0]
            arrays["strobe_v"][at + (slice(STROBE_POINTS - n, None),)] = a.strobe[-n:, 1]
    if "basin_entropy" in arrays:
        e = census_basin_entropy(found)
        arrays["basin_entropy"][cell] = e.basin_entropy
        arrays["boundary_basin_entropy"][cell] = e.boundary_basin_entropy


class _Lazy(dict):
    """A dict whose missing keys are made on first use by ``make(key)`` (a round of the atlas
    after the first touches few of a region's points: the others are never built)."""

    def __init__(self, make):
        super().__init__()
        self.make = make

    def __missing__(self, key):
        value = self[key] = self.make(key)
        return value


def stored_states(arrays: Mapping[str, np.ndarray], periods: tuple[int, ...] = (1, 2)
                  ) -> Mapping[tuple, PointState]:
    """The points of ``arrays`` (stored slot, point and attractor variables over a region,
    dims omega, sigma, zeta, slot) as PointStates, each made when first asked for: their
    orbits as light dicts (RULE_FIELDS, ``x0`` and ``source``: the cell the others are copied
    from when the point is written again), the slot-0 status record, and their census's
    attractors as StoredAttractors linked to those orbits. Read column by column (a dict per
    stored value would cost more than an atlas round's shots)."""
    status = arrays["status"]
    cells = np.argwhere(status != st.EMPTY)
    where = tuple(cells.T)
    names = [n for n in RULE_FIELDS if n in arrays]
    # Python scalars (complex multipliers too): the rules' arithmetic on them is the same
    # IEEE arithmetic as on numpy scalars, at a tenth of the cost
    cols = [arrays[n][where].tolist() for n in names]
    starts = list(zip(arrays["q0"][where].tolist(), arrays["v0"][where].tolist()))
    sources = list(map(tuple, cells.tolist()))
    rows: dict[tuple, list[int]] = {}
    for r, cell in enumerate(sources):
        rows.setdefault(cell[:3], []).append(r)
    found = arrays.get("orbits_found")

    def make(idx) -> PointState:
        state = PointState(visited=found is None or int(found[idx]) >= 0, source=idx)
        by_slot = {}
        for r in rows.get(idx, ()):
            d = dict(zip(names, (c[r] for c in cols)), x0=starts[r], source=sources[r])
            d.setdefault("atlas_round", 0)
            by_slot[sources[r][3]] = d
            if d["status"] == st.CONVERGED and d["period"] > 0:
                state.orbits.append(d)
            elif state.status_record is None:
                state.status_record = d
        if "attractor_solution" in arrays:
            links = arrays["attractor_solution"][idx]
            if "attractor_kind" in arrays:
                used = int((arrays["attractor_kind"][idx] > 0).sum())
                ran = int(arrays["attractor_count"][idx]) >= 0 \
                    if "attractor_count" in arrays else used > 0
            else:
                # the links alone (an atlas continuation round reads no more of the census):
                # every slot is copied back, its link followed where it has one
                used, ran = links.shape[0], True
            if ran:
                state.attractors = [StoredAttractor(idx + (a,), by_slot.get(int(links[a])))
                                    for a in range(used)]
        return state

    return _Lazy(make)
