"""How exact a dense basin map is (issue 52): random states of a map integrated directly, their
attractor compared with the map's label.

    .venv/bin/python benchmarks/basins_agreement.py --omega 1.35 --sigma 0.7625 \\
        [--zeta 0.01] [--grid 1000] [--states 2000] [--oracle 40] [--seed 1]

The map is study.solve.dense_basins.cell_basin_map (label reuse, in this process). Then
``--states`` cells drawn at random (uniformly, seeded) have their centre integrated directly,
with nothing reused: the census's own transient (study.solve.census.run_transients: the whole
budget of transient_periods + record_periods, period detection, Newton shooting; the brute
force of study.solve.basin_grid) and, for the first ``--oracle`` of them, the scipy oracle
(benchmarks/oracle.py: solve_ivp with the contact switches as events, no code shared with the
kernels) over ORACLE_PERIODS forcing periods, the end point named by the nearest stroboscopic
point of the map's periodic attractors (within ORACLE_TOL).

Printed: the agreement (share of the states whose direct label is the map's), the floor (the
same direct transients at rtol 1e-11 against 1e-8: where they differ, the attractor hangs on the
integration's error, as it does at omega 1.95, sigma 2.0, and the agreement among the states
whose two direct labels agree), each
disagreement's distance to the map's basin boundary (cells to the nearest cell of another
label), the basin fractions of the map against those of the random states (the brute force's
estimate, with its binomial standard error: |z| <= 3 asked), and the oracle's agreement.
"""
from __future__ import annotations

import argparse
import functools
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks import oracle  # noqa: E402
from hertzmap.kernels import status as st  # noqa: E402
from hertzmap.kernels.attractors import A, N_ATTRACTOR_FIELDS  # noqa: E402
from hertzmap.kernels.records import STROBE_POINTS  # noqa: E402
from hertzmap.kernels.shooting import N_FIELDS  # noqa: E402
from hertzmap.kernels.attractors import NO_LABEL, attractor_batch_into  # noqa: E402
from hertzmap.study.solve.census import (CYCLE_REPEATS, CYCLE_TOL, run_transients,  # noqa: E402
                                         transient_settings)
from hertzmap.study.solve.recognition import NOTHING_KNOWN  # noqa: E402
from hertzmap.study.solve.certificate import orbit_points  # noqa: E402
from hertzmap.study.solve.dense_basins import cell_basin_map  # noqa: E402
from hertzmap.study.solve.point import solutions_from_rows  # noqa: E402

print = functools.partial(print, flush=True)  # noqa: A001 (progress in a log)

OPTIONS = {"exponent": 1.5, "model": "hertz", "rtol": 1e-10}
TRANSIENT, RECORD = 500, 128
#: the oracle's transient: exp(-zeta T)^600 < 1e-10 at zeta 0.01 and T > 4
ORACLE_PERIODS = 600
ORACLE_TOL = 1e-3
#: the tighter tolerance of the floor's transients (the census's are at 1e-8)
TIGHT_RTOL = 1e-11


def direct_labels(bm, states: np.ndarray, rtol: float | None = None) -> np.ndarray:
    """The census transient's attractor of each state, as an index into the map's attractors
    (periodic ones by their stroboscopic points, open runs the map's unsettled / non-periodic
    label); -1: an attractor the map does not have. ``rtol``: the transients' integrator
    tolerance (default the census's, TRANSIENT_RTOL; shooting at the study's)."""
    k = len(states)
    rows = np.empty((k, N_ATTRACTOR_FIELDS))
    orbit_rows = np.empty((k, N_FIELDS))
    strobes = np.empty((k, STROBE_POINTS, 2))
    if rtol is None:
        run_transients(bm.omega, bm.sigma, bm.zeta, states[:, 0].copy(), states[:, 1].copy(),
                       dict(OPTIONS, harmonics=False), TRANSIENT, RECORD, rows, orbit_rows,
                       strobes)
    else:
        n, code, _, _ = transient_settings(OPTIONS)
        attractor_batch_into(bm.omega, bm.sigma, bm.zeta, states[:, 0].copy(),
                             states[:, 1].copy(), n, code, TRANSIENT, RECORD, False, 0, 0,
                             CYCLE_TOL, CYCLE_REPEATS, rtol, rtol, OPTIONS["rtol"], 200_000,
                             False, *NOTHING_KNOWN.arrays(), NO_LABEL, rows, orbit_rows,
                             strobes)
    kinds = [a["kind"] for a in bm.attractors]
    out = np.full(k, -1)
    for r in range(k):
        status = int(rows[r, A["status"]])
        if status == st.CONVERGED:
            sol = solutions_from_rows(orbit_rows[r:r + 1], int(rows[r, A["period"]]))[0]
            out[r] = periodic_match(bm, sol["period"], np.asarray(sol["x0"], float))
        elif status in (st.UNSETTLED, st.UNCONFIRMED):
            out[r] = next((i for i, kd in enumerate(kinds)
                           if kd in ("unsettled", "non_periodic")), -1)
        else:
            out[r] = next((i for i, kd in enumerate(kinds) if kd == "failed"), -1)
    return out


def periodic_match(bm, period: int, x0: np.ndarray, tol: float = 1e-4) -> int:
    """The map's periodic attractor of period ``period`` with a stroboscopic point within
    tol (1 + |x0|) of x0, -1 if none."""
    for i, a in enumerate(bm.attractors):
        if a["kind"] == "periodic" and a["period"] == period:
            if np.min(np.hypot(*(phases(bm, i) - x0).T)) <= tol * (1 + np.hypot(*x0)):
                return i
    return -1


@functools.lru_cache(maxsize=None)
def _phases(omega, sigma, zeta, q0, v0, period) -> np.ndarray:
    return orbit_points({"x0": (q0, v0), "period": period}, omega, sigma, zeta, OPTIONS)


def phases(bm, i: int) -> np.ndarray:
    """The m stroboscopic points of the map's periodic attractor i (its refined start point and
    its images)."""
    a = bm.attractors[i]
    return _phases(bm.omega, bm.sigma, bm.zeta, a["q0"], a["v0"], a["period"])


def oracle_label(bm, x0) -> int:
    """The scipy oracle's attractor of the state x0: the map's periodic attractor with a
    stroboscopic point nearest the oracle's point after ORACLE_PERIODS periods (-1: none within
    ORACLE_TOL)."""
    T = 2 * math.pi / bm.omega
    end = oracle.flow(x0, 0.0, ORACLE_PERIODS * T, bm.omega, bm.sigma, bm.zeta, rtol=1e-10,
                      atol=1e-10)
    best, best_d = -1, ORACLE_TOL
    for i, a in enumerate(bm.attractors):
        if a["kind"] != "periodic":
            continue
        pts = phases(bm, i)
        d = float(np.min(np.hypot(*(pts - end).T)))
        if d < best_d:
            best, best_d = i, d
    return best


def boundary_distance(labels: np.ndarray) -> np.ndarray:
    """Per cell, the chessboard distance in cells to the nearest cell of another label (1: a
    neighbour differs)."""
    edge = np.zeros(labels.shape, bool)
    for axis in (0, 1):
        d = np.diff(labels, axis=axis) != 0
        sl = [slice(None)] * 2
        sl[axis] = slice(1, None)
        edge[tuple(sl)] |= d
        sl[axis] = slice(None, -1)
        edge[tuple(sl)] |= d
    return ndimage.distance_transform_cdt(~edge, metric="chessboard") + 1


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--omega", type=float, required=True)
    p.add_argument("--sigma", type=float, required=True)
    p.add_argument("--zeta", type=float, default=0.01)
    p.add_argument("--grid", type=int, default=1000)
    p.add_argument("--states", type=int, default=2000)
    p.add_argument("--oracle", type=int, default=40)
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args(argv)
    t0 = time.perf_counter()
    stats: dict = {}
    bm = cell_basin_map(a.omega, a.sigma, a.zeta, grid=(a.grid, a.grid), options=OPTIONS,
                        transient_periods=TRANSIENT, record_periods=RECORD, stats=stats)
    t_map = time.perf_counter() - t0
    print(f"map {a.grid}x{a.grid} at omega {a.omega:g}, sigma {a.sigma:g}, zeta {a.zeta:g}: "
          f"{t_map:.1f} s in this process, {stats}")
    for i, at in enumerate(bm.attractors):
        print(f"  [{i}] {at['kind']} {at['period']}T  cells {at['count']}")
    rng = np.random.default_rng(a.seed)
    cells = rng.choice(bm.labels.size, size=a.states, replace=False)
    iv, iq = np.unravel_index(cells, bm.labels.shape)
    states = np.stack([bm.q[iq], bm.v[iv]], axis=1)
    t1 = time.perf_counter()
    direct = direct_labels(bm, states)
    t_direct = time.perf_counter() - t1
    mapped = bm.labels[iv, iq]
    agree = mapped == direct
    share = float(agree.mean())
    dist = boundary_distance(bm.labels)[iv, iq]
    print(f"agreement with the census's direct transients: {agree.sum()} / {a.states} = "
          f"{100 * share:.2f} % ({t_direct:.1f} s for the {a.states} transients)")
    bad = np.flatnonzero(~agree)
    print(f"disagreements' distance to the map's boundary (cells): "
          f"{sorted(int(d) for d in dist[bad])}; states within 1 cell of it: "
          f"{int((dist <= 1).sum())}")
    n = a.states
    worst = 0.0
    for i, at in enumerate(bm.attractors):
        p_map = at["count"] / bm.labels.size
        p_bf = float((direct == i).mean())
        se = math.sqrt(max(p_bf * (1 - p_bf), 1.0 / n) / n)
        z = (p_map - p_bf) / se
        worst = max(worst, abs(z))
        print(f"  [{i}] fraction map {p_map:.4f}  brute force {p_bf:.4f} +- {se:.4f}  z {z:+.2f}")
    print(f"largest |z| {worst:.2f} (<= 3 asked); states the map has no attractor for: "
          f"{int((direct < 0).sum())}")
    # the floor: the same transients at a tolerance 1000 times tighter. Where the two direct
    # integrations disagree, the attractor hangs on the integration's error (final-state
    # sensitivity), and no map can agree with either better than they agree with each other
    t3 = time.perf_counter()
    tight = direct_labels(bm, states, rtol=TIGHT_RTOL)
    same = tight == direct
    print(f"the census's transients at rtol 1e-8 against rtol {TIGHT_RTOL:g}: "
          f"{same.sum()} / {a.states} = {100 * same.mean():.2f} % agree "
          f"({time.perf_counter() - t3:.1f} s); the map against rtol {TIGHT_RTOL:g}: "
          f"{100 * (mapped == tight).mean():.2f} %; where the two tolerances agree, the map "
          f"agrees with them in {(agree & same).sum()} / {same.sum()} = "
          f"{100 * (agree & same).sum() / max(same.sum(), 1):.2f} %")
    out = {"agreement": share, "worst_z": worst, "map_seconds": t_map, "stats": stats,
           "tolerance_floor": float(same.mean()),
           "agreement_where_settled": float((agree & same).sum() / max(same.sum(), 1))}
    if a.oracle:
        t2 = time.perf_counter()
        lab = np.array([oracle_label(bm, states[r]) for r in range(a.oracle)])
        ok = lab == mapped[:a.oracle]
        print(f"scipy oracle ({ORACLE_PERIODS} periods, rtol 1e-10) on the first {a.oracle}: "
              f"{ok.sum()} / {a.oracle} agree with the map, {int((lab == direct[:a.oracle]).sum())}"
              f" with the census's transients ({time.perf_counter() - t2:.0f} s)")
        out["oracle_agreement"] = float(ok.mean())
    return out


if __name__ == "__main__":
    main()
