"""How complete is a hertzmap store? An independent brute-force census of the stable periodic
attractors at random grid points, compared with the orbits the store holds.

    .venv/bin/python benchmarks/completeness.py STORE.zarr [STORE2.zarr ...] --points 12 --states 400 --seed 20261128 [--wide 2.0] [--periods 3000] [--json out.json]
    .venv/bin/python benchmarks/completeness.py [STORE.zarr ...] --point OMEGA SIGMA ZETA [--states 400] [--json out.json]

The model is paper Eq. 7, dimensionless (tau = omega_0 t, q the displacement from the static
preload in units of 2 z_s / 3):

    q'' + 2 zeta q' + F(q) = 1 + sigma cos(omega tau),   F(q) = (1 + q/n)^n for q >= -n, else 0,

n = the store's ``exponent`` (1.5, Hertz); contact is lost at q = -n. Forcing period
T = 2 pi / omega; the store's orbits are given by their state (q0, v0) at tau = 0.

For each store (opened read-only with ``xr.open_zarr(path, chunks=None)``; stores whose model
is not "hertz" are skipped), ``--points`` grid points are drawn with numpy's default_rng(seed)
among the points of finished blocks (``task_done``; without it, the points whose ``status`` is
not all -1). At each point ``--states`` initial states (q, q'): half in the census box
(-6, 4) x (-5, 5) (study.solve.seeds.TRANSIENT_BOX), half in the wide box (the census box
scaled by ``--wide`` about its centre (-1, 0); it contains the census box), both from one
scrambled Halton sequence (scipy.stats.qmc, seeded by the seed and the point).

Each state's transient is integrated by this file's own fixed-step RK4 (numba; the force law
written here, no code of hertzmap.kernels or hertzmap.study.solve), an integer number of
steps per forcing period, so the stroboscopic samples land on tau = k T exactly. A state
stops once its samples repeat with a period m <= 16: |x_k - x_{k-m}| <= tol (1 + |x_k|) for
the 3 m latest k (three returns of every phase of the cycle); one that does not within
``--periods`` periods is "non-periodic" (chaotic, or a transient longer than the budget:
the distance to an orbit decays like |mu|^k, at best exp(-zeta tau)). The settled states
are grouped into distinct cycles (same m, one of the same m points within 1e-5, any phase),
each refined by the scipy oracle (benchmarks/oracle.py: ``shoot`` at rtol 1e-10, the other
phases by its ``period_map``) and called stable when its Floquet multipliers are inside the
unit circle.

The store holds a brute-force attractor when one of the point's slots has status 0, stable
True, the same period, and (q0, v0) within 1e-6 (1 + |x|) of one of the oracle cycle's m
points. Printed per point: each attractor (period, basin share in the census box and in the
wide box, held or not, and for a missed one the store's nearest slot), the store's stable
orbits no state reached (basins below 1/states: not an error), the non-periodic share. The
headline counts, over all points of all stores, the stable attractors with a basin >= 1 %
(in the census box; and in either box) that the store holds, and lists the missed ones.
``--json`` writes every point's results.

``--point OMEGA SIGMA ZETA``: that one point (on each store's grid, nearest node within 1e-9;
without a store, the attractors and their basins only, n = ``--exponent``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from dataclasses import dataclass, field

import numpy as np
from numba import njit

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))     # the repo: the benchmarks are not installed

from benchmarks import oracle  # noqa: E402  (scipy reference, shares no code with kernels/)

CENSUS_BOX = ((-6.0, 4.0), (-5.0, 5.0))
MAX_PERIOD = 16         # the longest cycle the repeat test looks for (the store's periods: <= 16)
RETURNS = 3             # a cycle is settled after this many returns of every phase within tol
SETTLE_TOL = 1e-9       # relative repeat tolerance of the stroboscopic samples
GROUP_TOL = 1e-5        # two settled states on one cycle (before the oracle refines it)
MATCH_TOL = 1e-6        # an oracle cycle and a store slot (q0, v0): the same orbit
SAME_TOL = 1e-7         # two oracle cycles: the same orbit
SLOW_TOL = 1e-3         # a non-periodic state this close to a stable cycle at the end: "slow"
MIN_BASIN = 0.01        # the headline's threshold
H_MAX = 0.025           # RK4 step bound (tau units); at least MIN_STEPS steps per period
MIN_STEPS = 200
SUBSTEPS = 16           # substeps of a step near or across the contact surface (_one_period)
BAND = 1.0              # "near": a stage within BAND h (|v| + |v_next| + 1) of q = -n
ORACLE_RTOL = 1e-10


# ---- the independent integrator ---------------------------------------------------------------

@njit(cache=True, inline="always")
def _force(q, n):
    # F(q) = (1 + q/n)^n in contact, 0 in flight; for n = 1.5 by a square root (several times
    # cheaper than pow, and the force dominates the step's cost)
    s = 1.0 + q / n
    if s <= 0.0:
        return 0.0
    if n == 1.5:
        return s * np.sqrt(s)
    return s ** n


@njit(cache=True, inline="always")
def _rk4(q, v, h, g0, g1, g2, tz, n):
    """One classical RK4 step of Eq. 7; g0, g1, g2 = 1 + sigma cos(omega tau) at the step's
    start, middle and end. Returns (q, v, whether the step is near the contact surface: one
    stage in contact and one in flight or within BAND h (|v| + |v_next| + 1) of q = -n, i.e.
    within about a step of crossing it)."""
    a1 = g0 - tz * v - _force(q, n)
    q2 = q + 0.5 * h * v
    v2 = v + 0.5 * h * a1
    a2 = g1 - tz * v2 - _force(q2, n)
    q3 = q + 0.5 * h * v2
    v3 = v + 0.5 * h * a2
    a3 = g1 - tz * v3 - _force(q3, n)
    q4 = q + h * v3
    v4 = v + h * a3
    a4 = g2 - tz * v4 - _force(q4, n)
    qn = q + h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
    vn = v + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    lo = min(min(q, q2), min(min(q3, q4), qn))
    hi = max(max(q, q2), max(max(q3, q4), qn))
    near = BAND * h * (abs(v) + abs(vn) + 1.0)
    return qn, vn, lo < -n + near and hi > -n


@njit(cache=True)
def _one_period(q, v, g, h, tz, n, omega, sigma, sub):
    """RK4 over one forcing period; g[2j], g[2j+1], g[2j+2] = 1 + sigma cos(omega tau) at the
    start, middle and end of step j (tabulated once per point: every period has the same
    steps, as each starts on tau = k T).

    A step in contact near the surface q = -n (or across it) is redone in ``sub`` substeps:
    F is C^1 there (F = F' = 0 at q = -n for n = 1.5) but F'' ~ (q + n)^(-1/2) is unbounded,
    so a step that crosses or ends near the surface loses RK4's order (local error about
    h^3.5, times a power of the impact velocity). Those few steps, two or three per contact
    loss and recontact, would otherwise dominate the period map's error: measured against
    oracle.period_map over one period at omega 0.5..2.5, they took it from 1e-9 (in contact)
    to 1e-6..1e-4 (hard impacts); with the substeps it is 1e-8..2e-7 at the default steps
    and converges again like h^4."""
    steps = (g.size - 1) // 2
    hs = h / sub
    for j in range(steps):
        qn, vn, near = _rk4(q, v, h, g[2 * j], g[2 * j + 1], g[2 * j + 2], tz, n)
        if near and sub > 1:
            t = j * h
            for i in range(sub):
                t0 = t + i * hs
                q, v, _ = _rk4(q, v, hs, 1.0 + sigma * np.cos(omega * t0),
                               1.0 + sigma * np.cos(omega * (t0 + 0.5 * hs)),
                               1.0 + sigma * np.cos(omega * (t0 + hs)), tz, n)
        else:
            q, v = qn, vn
    return q, v


def steps_per_period(omega: float) -> int:
    """Steps of the RK4 per forcing period: step <= H_MAX, and at least MIN_STEPS."""
    return max(MIN_STEPS, int(np.ceil(2.0 * np.pi / omega / H_MAX)))


def _forcing_table(omega: float, sigma: float, steps: int) -> tuple[np.ndarray, float]:
    T = 2.0 * np.pi / omega
    h = T / steps
    tau = np.arange(2 * steps + 1) * (0.5 * h)
    return 1.0 + sigma * np.cos(omega * tau), h


@njit(cache=True)
def _strobe_all(x0, g, h, tz, n, omega, sigma, sub, periods):
    out = np.empty((x0.shape[0], periods + 1, 2))
    for s in range(x0.shape[0]):
        q, v = x0[s, 0], x0[s, 1]
        out[s, 0, 0] = q
        out[s, 0, 1] = v
        for k in range(periods):
            q, v = _one_period(q, v, g, h, tz, n, omega, sigma, sub)
            out[s, k + 1, 0] = q
            out[s, k + 1, 1] = v
    return out


def strobe(x0, omega, sigma, zeta, periods, n=1.5, steps=None, sub=SUBSTEPS):
    """The stroboscopic samples x(k T), k = 0..periods, of every state of ``x0`` (shape (S, 2),
    at tau = 0): shape (S, periods + 1, 2). The RK4 of this file; ``steps`` per period
    (default :func:`steps_per_period`)."""
    steps = steps_per_period(omega) if steps is None else int(steps)
    g, h = _forcing_table(omega, sigma, steps)
    return _strobe_all(np.ascontiguousarray(x0, dtype=np.float64), g, h, 2.0 * zeta, float(n),
                       float(omega), float(sigma), int(sub), int(periods))


@njit(cache=True)
def _settled_period(buf, k, L, max_m, returns, tol):
    # the smallest m with |x_j - x_{j-m}| <= tol (1 + |x_j|) for the returns * m latest j
    # (buf is a ring of the L latest samples, sample j at j % L); 0 when none
    for m in range(1, max_m + 1):
        need = returns * m
        if k - need - m + 1 < 0:
            return 0        # too few samples for this m, and for every longer one
        ok = True
        for i in range(need):
            a = (k - i) % L
            b = (k - i - m) % L
            qa = buf[a, 0]
            va = buf[a, 1]
            scale = tol * (1.0 + max(abs(qa), abs(va)))
            if abs(qa - buf[b, 0]) > scale or abs(va - buf[b, 1]) > scale:
                ok = False
                break
        if ok:
            return m
    return 0


@njit(cache=True)
def _transients(x0, g, h, tz, n, omega, sigma, sub, max_periods, max_m, returns, tol):
    S = x0.shape[0]
    L = (returns + 1) * max_m
    period = np.zeros(S, np.int64)          # settled period m; 0 not settled; -1 not finite
    ran = np.zeros(S, np.int64)             # periods integrated
    tail = np.full((S, L, 2), np.nan)       # the L latest samples, oldest first
    buf = np.empty((L, 2))
    for s in range(S):
        q, v = x0[s, 0], x0[s, 1]
        buf[0, 0] = q
        buf[0, 1] = v
        k = 0
        m = 0
        while k < max_periods:
            q, v = _one_period(q, v, g, h, tz, n, omega, sigma, sub)
            k += 1
            buf[k % L, 0] = q
            buf[k % L, 1] = v
            if not (np.isfinite(q) and np.isfinite(v)):
                m = -1
                break
            m = _settled_period(buf, k, L, max_m, returns, tol)
            if m > 0:
                break
        period[s] = m
        ran[s] = k
        for i in range(min(L, k + 1)):
            j = k - min(L, k + 1) + 1 + i
            tail[s, L - min(L, k + 1) + i, 0] = buf[j % L, 0]
            tail[s, L - min(L, k + 1) + i, 1] = buf[j % L, 1]
    return period, ran, tail


def transients(x0, omega, sigma, zeta, max_periods, n=1.5, steps=None, max_m=MAX_PERIOD,
               returns=RETURNS, tol=SETTLE_TOL, sub=SUBSTEPS):
    """Run each state of ``x0`` (S, 2) until its stroboscopic samples repeat (period m <= max_m,
    ``returns`` returns within ``tol``) or for ``max_periods`` periods. Returns (m per state,
    0 if it never repeated and -1 if it left the floats; periods run; the (returns + 1) max_m
    latest samples, oldest first, the last one at tau = ran T)."""
    steps = steps_per_period(omega) if steps is None else int(steps)
    g, h = _forcing_table(omega, sigma, steps)
    return _transients(np.ascontiguousarray(x0, dtype=np.float64), g, h, 2.0 * zeta, float(n),
                       float(omega), float(sigma), int(sub), int(max_periods), int(max_m),
                       int(returns), float(tol))


# ---- initial states ----------------------------------------------------------------------------

def wide_box(wide: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """The census box scaled by ``wide`` about its centre."""
    out = []
    for lo, hi in CENSUS_BOX:
        c, r = 0.5 * (lo + hi), 0.5 * (hi - lo) * wide
        out.append((c - r, c + r))
    return tuple(out)


def initial_states(count: int, wide: float, seed) -> tuple[np.ndarray, np.ndarray]:
    """``count`` states: the first half in the census box, the rest in the wide box, from one
    scrambled Halton sequence (scipy.stats.qmc.Halton, d = 2, ``seed``). Returns (states (S, 2),
    box per state: 0 census, 1 wide)."""
    from scipy.stats import qmc

    half = count // 2
    u = qmc.Halton(d=2, scramble=True, rng=np.random.default_rng(seed)).random(count)
    box = np.where(np.arange(count) < half, 0, 1)
    x = np.empty((count, 2))
    for b, (qb, vb) in enumerate((CENSUS_BOX, wide_box(wide))):
        sel = box == b
        x[sel, 0] = qb[0] + (qb[1] - qb[0]) * u[sel, 0]
        x[sel, 1] = vb[0] + (vb[1] - vb[0]) * u[sel, 1]
    return x, box


# ---- cycles: grouping and matching -------------------------------------------------------------

def _close(a, b, tol):
    """Max-norm distance of a and b within tol (1 + |a|)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return bool(np.abs(a - b).max() <= tol * (1.0 + np.abs(a).max()))


def on_cycle(x, cycle, tol) -> bool:
    """x within tol (relative to 1 + |x|) of one of the points of ``cycle`` (m, 2)."""
    return any(_close(x, p, tol) for p in np.asarray(cycle))


def same_cycle(a, b, tol) -> bool:
    """Two cycles (m, 2) of the same period are one orbit when b, shifted by some phase k,
    is a point for point within tol (the stroboscopic points of a cycle are its states at
    tau = 0 mod T, so the phase a sample list starts on is arbitrary). One shared point
    would do in exact arithmetic (the period map is a map); all m are checked so that two
    cycles passing within tol of each other once are not merged."""
    a, b = np.asarray(a), np.asarray(b)
    m = len(a)
    if len(b) != m:
        return False
    return any(all(_close(a[i], b[(i + k) % m], tol) for i in range(m)) for k in range(m))


def minimal_period(cycle, tol) -> int:
    """The smallest d dividing m = len(cycle) with cycle[i] = cycle[i + d] within tol for all i.
    Near a flip (a multiplier close to -1) a 1T orbit is approached with alternating
    deviations: x_k - x_{k-2} shrinks by 1 - mu^2 against x_k - x_{k-1}, so the repeat test
    passes for m = 2 long before m = 1; the cycle then holds the same point twice."""
    cycle = np.asarray(cycle)
    m = len(cycle)
    for d in range(1, m):
        if m % d == 0 and all(_close(cycle[i], cycle[i + d], tol) for i in range(m - d)):
            return d
    return m


def group_cycles(period, tail, tol=GROUP_TOL) -> tuple[list[np.ndarray], np.ndarray]:
    """Distinct cycles among the settled states: (cycles, each an (m, 2) array of a
    representative's m latest samples, m its minimal period; per state the index of its cycle,
    -1 if not settled)."""
    cycles: list[np.ndarray] = []
    label = np.full(len(period), -1)
    for s, m in enumerate(period):
        if m <= 0:
            continue
        m = minimal_period(tail[s, -m:], tol)
        pts = tail[s, -m:]
        for c, cyc in enumerate(cycles):
            if same_cycle(pts, cyc, tol):
                label[s] = c
                break
        else:
            label[s] = len(cycles)
            cycles.append(pts.copy())
    return cycles, label


def match_slot(cycle, slots, tol=MATCH_TOL, stable_only=True) -> int:
    """The index of the first slot (a dict with period, status, stable, q0, v0) that holds
    ``cycle`` (m, 2): status 0, the same period, (q0, v0) on the cycle within tol, and stable
    (unless ``stable_only`` is False); -1 if none."""
    m = len(cycle)
    for i, s in enumerate(slots):
        if s["status"] != 0 or s["period"] != m or (stable_only and not s["stable"]):
            continue
        if on_cycle((s["q0"], s["v0"]), cycle, tol):
            return i
    return -1


# ---- refinement by the oracle ------------------------------------------------------------------

@dataclass
class Attractor:
    period: int
    cycle: np.ndarray                   # (m, 2): the oracle's m points (brute force's if it failed)
    mu: float = np.nan                  # largest |multiplier| (oracle)
    refined: bool = False
    deviation: float = np.nan           # RK4 settled sample vs oracle cycle (max norm)
    states: np.ndarray = field(default_factory=lambda: np.zeros(2, int))   # per box
    note: str = ""

    @property
    def stable(self) -> bool:
        return self.refined and self.mu < 1.0


def refine(cycle, omega, sigma, zeta, n, rtol=ORACLE_RTOL) -> Attractor:
    """The oracle's orbit of period m = len(cycle) from the brute force's last sample: its fixed
    point of the m-period map (oracle.shoot), the other m - 1 phases by its one-period map, the
    largest |multiplier| of its monodromy."""
    m = len(cycle)
    guess = cycle[-1]
    note = ""
    while True:         # m decreases on every pass that does not break
        try:
            x, M, _ = oracle.shoot(guess, omega, sigma, zeta, m, n=n, rtol=rtol)
        except (ArithmeticError, RuntimeError) as e:
            return Attractor(m, cycle.copy(), note=f"oracle failed: {e}")
        pts = [np.asarray(x, float)]
        for _k in range(m - 1):
            # one period at a time, tighter than the shooting, so that the last phase is
            # still within SAME_TOL of the orbit after m - 1 maps
            pts.append(np.asarray(oracle.period_map(pts[-1], omega, sigma, zeta, 1, n=n,
                                                    rtol=rtol * 1e-2, atol=rtol * 1e-2), float))
        pts = np.array(pts)
        d = minimal_period(pts, SAME_TOL)
        if d == m:
            break
        # the brute force's cycle was a shorter orbit still converging: shoot that one
        note = f"{len(cycle)}T cycle refined to a {d}T orbit"
        m, guess = d, pts[0]
    dev = min(np.abs(cycle[-1] - p).max() for p in pts)
    a = Attractor(m, pts, mu=float(np.abs(np.linalg.eigvals(M)).max()), refined=True,
                  deviation=float(dev), note=note)
    if dev > 1e-4 * (1.0 + np.abs(cycle[-1]).max()):
        a.note = "; ".join(filter(None, (note, f"oracle orbit {dev:.1e} from the brute force's")))
    return a


def brute_force(omega, sigma, zeta, n, x0, box, max_periods, steps=None) -> dict:
    """Everything at one point: the transients, their distinct cycles refined by the oracle
    (cycles that refine to the same orbit merged), the states per box of each, the non-periodic
    states."""
    t0 = time.perf_counter()
    period, ran, tail = transients(x0, omega, sigma, zeta, max_periods, n=n, steps=steps)
    t_rk4 = time.perf_counter() - t0
    cycles, label = group_cycles(period, tail)
    attractors: list[Attractor] = []
    for c, cyc in enumerate(cycles):
        a = refine(cyc, omega, sigma, zeta, n)
        counts = np.array([np.sum((label == c) & (box == b)) for b in (0, 1)])
        for b in attractors:
            if b.refined and a.refined and b.period == a.period and same_cycle(a.cycle, b.cycle,
                                                                                SAME_TOL):
                b.states += counts
                break
        else:
            a.states = counts
            attractors.append(a)
    attractors.sort(key=lambda a: (-a.states.sum(), a.period))
    per_box = np.array([np.sum(box == b) for b in (0, 1)])
    settled = ran[period > 0]
    # a state that did not repeat but ends close to a stable cycle found here is most likely
    # a long transient to it (multiplier near the unit circle), not a chaotic response
    slow = np.array([period[s] == 0 and any(
        a.stable and on_cycle(tail[s, -1], a.cycle, SLOW_TOL) for a in attractors)
        for s in range(len(period))], bool)
    return {"attractors": attractors, "per_box": per_box,
            "non_periodic": np.array([np.sum((period == 0) & (box == b)) for b in (0, 1)]),
            "slow": np.array([np.sum(slow & (box == b)) for b in (0, 1)]),
            "not_finite": int(np.sum(period < 0)),
            "settled_periods": (int(np.median(settled)) if settled.size else 0,
                                int(settled.max()) if settled.size else 0),
            "time_rk4": t_rk4, "time": time.perf_counter() - t0}


# ---- the store ---------------------------------------------------------------------------------

def open_store(path: str):
    import xarray as xr

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return xr.open_zarr(path, chunks=None)


def done_points(ds) -> np.ndarray:
    """Grid indices (i, j, k) of the points whose block is written: ``task_done`` with the
    chunk shape of the attrs; without it, the points with a status other than -1 (a finished
    point with no orbit at all would be missed there: the flag is the better witness)."""
    shape = tuple(ds.sizes[d] for d in ("omega", "sigma", "zeta"))
    chunk = ds.attrs.get("hertzmap_chunk_shape")
    if chunk is None and "task_done" in ds:
        chunk = ds["task_done"].attrs.get("chunk_shape")
    if "task_done" in ds and chunk is not None:
        flag = ds["task_done"].transpose("omega_chunk", "sigma_chunk", "zeta_chunk").values
        idx = np.indices(shape).reshape(3, -1).T
        blocks = idx // np.asarray(chunk, int)
        return idx[flag[blocks[:, 0], blocks[:, 1], blocks[:, 2]]]
    status = ds["status"].transpose("omega", "sigma", "zeta", "solution").values
    return np.argwhere((status != -1).any(axis=-1))


def store_point(ds, i, j, k) -> dict:
    """The slots at grid point (i, j, k) (every slot along ``solution``, however many) and, if
    stored, the census's attractors there."""
    pt = ds.isel(omega=i, sigma=j, zeta=k)
    names = [v for v in ("period", "status", "stable", "q0", "v0", "multipliers",
                         "orbits_dropped", "attractor_kind", "attractor_period",
                         "basin_fraction") if v in pt]
    pt = pt[names].load()
    slots = []
    for s in range(pt.sizes["solution"]):
        one = pt.isel(solution=s)
        mu = np.nan
        if "multipliers" in one:
            mu = float(np.abs(one["multipliers"].values).max())
        slots.append({"slot": s, "period": int(one["period"]), "status": int(one["status"]),
                      "stable": bool(one["stable"]), "q0": float(one["q0"]),
                      "v0": float(one["v0"]), "mu": mu})
    out = {"omega": float(pt["omega"]), "sigma": float(pt["sigma"]), "zeta": float(pt["zeta"]),
           "index": [int(i), int(j), int(k)], "slots": slots,
           "dropped": int(pt["orbits_dropped"]) if "orbits_dropped" in pt else None}
    if "attractor_kind" in pt:
        kinds = {1: "periodic", 2: "non_periodic", 3: "unsettled", 4: "failed"}
        census = []
        for a in range(pt.sizes.get("attractor", 0)):
            kind = int(pt["attractor_kind"].values[a])
            if kind == 0:
                continue
            m = int(pt["attractor_period"].values[a]) if "attractor_period" in pt else 0
            share = float(pt["basin_fraction"].values[a]) if "basin_fraction" in pt else np.nan
            census.append({"kind": kinds.get(kind, str(kind)), "period": m, "basin": share})
        out["census"] = census
    return out


def nearest_slot(cycle, slots) -> str:
    """For a missed cycle: the status 0 slot nearest to it (relative max-norm distance), or
    that the point has none."""
    best, where = np.inf, None
    for s in slots:
        if s["status"] != 0:
            continue
        x = np.array([s["q0"], s["v0"]])
        d = min(np.abs(x - p).max() / (1.0 + np.abs(x).max()) for p in cycle)
        if d < best:
            best, where = d, s
    if where is None:
        return "the point has no converged slot"
    kind = "stable" if where["stable"] else "unstable"
    return (f"nearest slot {where['slot']}: {where['period']}T {kind}, "
            f"rel. distance {best:.1e}")


# ---- one point ---------------------------------------------------------------------------------

def check_point(omega, sigma, zeta, n, states, wide, seed, periods, store=None,
                steps=None) -> dict:
    """The brute force at (omega, sigma, zeta), compared with ``store`` (store_point's dict) if
    given. The states' Halton sequence is seeded by ``seed`` and the point (so that a point's
    states do not depend on which other points are drawn)."""
    point_seed = np.random.SeedSequence([abs(int(seed)), *(round(abs(v) * 1e6) for v in
                                                           (omega, sigma, zeta))])
    x0, box = initial_states(states, wide, point_seed)
    bf = brute_force(omega, sigma, zeta, n, x0, box, periods, steps=steps)
    per_box = bf["per_box"]
    slots = store["slots"] if store is not None else []
    reached = set()
    rows = []
    for a in bf["attractors"]:
        held = match_slot(a.cycle, slots) if store is not None else -1
        row = {"period": a.period, "stable": a.stable, "refined": a.refined,
               "mu": a.mu, "deviation": a.deviation,
               "basin_census": float(a.states[0] / max(per_box[0], 1)),
               "basin_wide": float(a.states[1] / max(per_box[1], 1)),
               "q0": [float(v) for v in a.cycle[0]],
               "cycle": [[float(v) for v in p] for p in a.cycle], "note": a.note}
        if store is not None:
            row["held"] = held >= 0
            row["slot"] = held
            if held >= 0:
                x = np.array([slots[held]["q0"], slots[held]["v0"]])
                row["match_distance"] = float(min(np.abs(x - c).max() for c in a.cycle))
            else:
                loose = match_slot(a.cycle, slots, stable_only=False)
                row["store"] = (f"in slot {loose} but stored unstable" if loose >= 0
                                else nearest_slot(a.cycle, slots))
        for s in slots:
            if s["status"] == 0 and s["period"] == a.period and on_cycle(
                    (s["q0"], s["v0"]), a.cycle, MATCH_TOL):
                reached.add(s["slot"])
        rows.append(row)
    unreached = [s for s in slots if s["status"] == 0 and s["stable"]
                 and s["slot"] not in reached]
    out = {"omega": omega, "sigma": sigma, "zeta": zeta, "exponent": n, "states": states,
           "states_per_box": per_box.tolist(), "attractors": rows,
           "non_periodic_census": float(bf["non_periodic"][0] / max(per_box[0], 1)),
           "non_periodic_wide": float(bf["non_periodic"][1] / max(per_box[1], 1)),
           "not_finite": bf["not_finite"],
           "non_periodic_near_attractor": bf["slow"].tolist(),
           "settled_after_periods": {"median": bf["settled_periods"][0],
                                     "max": bf["settled_periods"][1]},
           "seconds": bf["time"], "seconds_rk4": bf["time_rk4"],
           "steps_per_period": steps_per_period(omega) if steps is None else int(steps)}
    if store is not None:
        out["index"] = store["index"]
        out["store_stable_not_reached"] = unreached
        out["orbits_dropped"] = store["dropped"]
        if "census" in store:
            out["store_census"] = store["census"]
    return out


def print_point(r: dict, out=None) -> None:
    """One point's lines of the report."""
    def p(*a):
        print(*a, file=out or sys.stdout)
    for a in r["attractors"]:
        kind = ("stable" if a["stable"] else
                f"UNSTABLE (|mu| {a['mu']:.6f})" if a["refined"] else "not refined")
        held = ""
        if "held" in a:
            held = f"held (slot {a['slot']})" if a["held"] else f"MISSED ({a['store']})"
        p(f"    {a['period']:>2}T {kind:<8} basin census {100 * a['basin_census']:5.1f} %  "
          f"wide {100 * a['basin_wide']:5.1f} %  |mu| {a['mu']:.4f}  "
          f"x0 ({a['q0'][0]:+.6f}, {a['q0'][1]:+.6f})  {held}"
          + (f"  [{a['note']}]" if a["note"] else ""))
    slow = sum(r["non_periodic_near_attractor"])
    settled = r["settled_after_periods"]
    p(f"    non-periodic: census {100 * r['non_periodic_census']:.1f} %, wide "
      f"{100 * r['non_periodic_wide']:.1f} %"
      + (f" ({slow} state(s) of them within {SLOW_TOL:g} of a stable cycle above at the end: "
         "slow transients)" if slow else "")
      + (f"; {r['not_finite']} states left the floats" if r["not_finite"] else "")
      + (f"; settled after {settled['median']} periods (median), {settled['max']} (max)"
         if settled["max"] else "; no state settled"))
    for s in r.get("store_stable_not_reached", []):
        p(f"    store's stable {s['period']}T (slot {s['slot']}, |mu| {s['mu']:.4f}, x0 "
          f"({s['q0']:+.6f}, {s['v0']:+.6f})) reached by no state (basin < 1/{r['states']} "
          "of the boxes)")
    if r.get("store_census"):
        census = ", ".join(f"{c['kind']}" + (f" {c['period']}T" if c["period"] else "")
                           + f" {100 * c['basin']:.0f} %" for c in r["store_census"])
        p(f"    store's census: {census}")
    if r.get("orbits_dropped"):
        p(f"    store: {r['orbits_dropped']} orbit(s) dropped here (slots full)")


# ---- the headline --------------------------------------------------------------------------------

def headline(results: list[dict], min_basin=MIN_BASIN) -> dict:
    """Over every point compared with a store: the stable attractors with a basin >= min_basin
    in the census box ("census"), and in either box ("either"), and how many the store holds;
    the missed ones."""
    out = {}
    for name, big in (("census", lambda a: a["basin_census"] >= min_basin),
                      ("either", lambda a: max(a["basin_census"], a["basin_wide"]) >= min_basin)):
        total, held, missed, uncounted = 0, 0, [], []
        for r in results:
            for a in r["attractors"]:
                if "held" not in a or not big(a):
                    continue
                if not a["stable"]:
                    # the RK4 settled on it but the oracle did not confirm a stable orbit
                    # (refinement failed, or multipliers on/outside the unit circle: a
                    # bifurcation within the RK4's error): neither held nor missed
                    uncounted.append({"store": r.get("store"), "omega": r["omega"],
                                      "sigma": r["sigma"], "zeta": r["zeta"],
                                      "period": a["period"], "mu": a["mu"], "note": a["note"]})
                    continue
                total += 1
                held += a["held"]
                if not a["held"]:
                    missed.append({"store": r.get("store"), "omega": r["omega"],
                                   "sigma": r["sigma"], "zeta": r["zeta"],
                                   "period": a["period"], "basin_census": a["basin_census"],
                                   "basin_wide": a["basin_wide"], "store_says": a["store"]})
        out[name] = {"total": total, "held": held, "missed": missed, "uncounted": uncounted}
    return out


def print_headline(h: dict, min_basin=MIN_BASIN, out=None) -> None:
    out = out or sys.stdout
    for name, label in (("census", "in the census box"), ("either", "in either box")):
        c = h[name]
        share = f"{100 * c['held'] / c['total']:.1f} %" if c["total"] else "n/a"
        print(f"stable attractors with basin >= {100 * min_basin:g} % {label}: "
              f"{c['held']} of {c['total']} held ({share})", file=out)
    for m in h["either"]["missed"]:
        print(f"  missed: {m['store']} omega {m['omega']:.6g} sigma {m['sigma']:.6g} zeta "
              f"{m['zeta']:.6g}: {m['period']}T, basin census "
              f"{100 * m['basin_census']:.1f} %, wide {100 * m['basin_wide']:.1f} % "
              f"({m['store_says']})", file=out)
    for u in h["either"]["uncounted"]:
        print(f"  not counted (oracle did not confirm it stable): {u['store']} omega "
              f"{u['omega']:.6g} sigma {u['sigma']:.6g} zeta {u['zeta']:.6g}: {u['period']}T "
              f"|mu| {u['mu']:.4f} {u['note']}", file=out)


# ---- command line --------------------------------------------------------------------------------

def _grid_index(ds, omega, sigma, zeta):
    idx = []
    for dim, v in (("omega", omega), ("sigma", sigma), ("zeta", zeta)):
        c = ds[dim].values
        i = int(np.argmin(np.abs(c - v)))
        if abs(c[i] - v) > 1e-9 * max(1.0, abs(v)):
            return None
        idx.append(i)
    return tuple(idx)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("stores", nargs="*", help="hertzmap zarr stores")
    ap.add_argument("--points", type=int, default=12, help="random grid points per store")
    ap.add_argument("--states", type=int, default=400, help="initial states per point")
    ap.add_argument("--seed", type=int, default=20261128)
    ap.add_argument("--wide", type=float, default=2.0,
                    help="the wide box: the census box scaled by this about its centre")
    ap.add_argument("--periods", type=int, default=3000, help="transient budget (periods)")
    ap.add_argument("--steps", type=int, default=None,
                    help="RK4 steps per period (default max(200, T / 0.025))")
    ap.add_argument("--point", type=float, nargs=3, metavar=("OMEGA", "SIGMA", "ZETA"))
    ap.add_argument("--exponent", type=float, default=1.5, help="n without a store")
    ap.add_argument("--json", help="write the per-point results here")
    args = ap.parse_args(argv)
    if not args.stores and args.point is None:
        ap.error("give a store, or --point OMEGA SIGMA ZETA")
    if args.states < 2:
        ap.error("--states must be >= 2 (half per box)")

    t_all = time.perf_counter()
    print(f"seed {args.seed}; {args.states} states per point ({args.states // 2} in the census "
          f"box {CENSUS_BOX}, {args.states - args.states // 2} in the wide box "
          f"{wide_box(args.wide)} (x{args.wide:g})), scrambled Halton (scipy.stats.qmc) seeded "
          f"by the seed and the point; up to {args.periods} periods, repeat test m <= "
          f"{MAX_PERIOD} within {SETTLE_TOL:g} over {RETURNS} returns; RK4 of this file, "
          f"oracle rtol {ORACLE_RTOL:g}", flush=True)
    t = time.perf_counter()
    strobe(np.zeros((1, 2)), 1.0, 0.1, 0.05, 1)
    transients(np.zeros((1, 2)), 1.0, 0.1, 0.05, 1)
    print(f"numba ready in {time.perf_counter() - t:.1f} s", flush=True)

    results: list[dict] = []
    compared = 0
    if not args.stores:
        w, s, z = args.point
        print(f"point omega {w:g} sigma {s:g} zeta {z:g} (no store), n = {args.exponent:g}")
        r = check_point(w, s, z, args.exponent, args.states, args.wide, args.seed,
                        args.periods, steps=args.steps)
        print_point(r)
        print(f"    {r['seconds']:.1f} s (RK4 {r['seconds_rk4']:.1f} s)", flush=True)
        results.append(r)
    for path in args.stores:
        ds = open_store(path)
        model = ds.attrs.get("model", "hertz")
        if model != "hertz":
            print(f"{path}: model {model!r}, not 'hertz': skipped")
            continue
        n = float(ds.attrs.get("exponent", 1.5))
        if args.point is not None:
            idx = _grid_index(ds, *args.point)
            if idx is None:
                print(f"{path}: omega {args.point[0]:g} sigma {args.point[1]:g} zeta "
                      f"{args.point[2]:g} is not a node of its grid: skipped")
                continue
            picks = np.array([idx])
        else:
            done = done_points(ds)
            if done.size == 0:
                print(f"{path}: no finished block: skipped")
                continue
            rng = np.random.default_rng(args.seed)
            take = rng.choice(len(done), size=min(args.points, len(done)), replace=False)
            picks = done[np.sort(take)]
        print(f"{path}: n = {n:g}, {ds.sizes['solution']} slots per point, "
              f"{len(picks)} point(s) (seed {args.seed}):")
        for (i, j, k) in picks:
            print(f"  ({i}, {j}, {k}) omega {float(ds.omega[i]):.6g} sigma "
                  f"{float(ds.sigma[j]):.6g} zeta {float(ds.zeta[k]):.6g}")
        for c, (i, j, k) in enumerate(picks):
            sp = store_point(ds, i, j, k)
            print(f"[{c + 1}/{len(picks)}] {os.path.basename(path.rstrip('/'))} ({i}, {j}, {k}) "
                  f"omega {sp['omega']:.6g} sigma {sp['sigma']:.6g} zeta {sp['zeta']:.6g}",
                  flush=True)
            r = check_point(sp["omega"], sp["sigma"], sp["zeta"], n, args.states, args.wide,
                            args.seed, args.periods, store=sp, steps=args.steps)
            r["store"] = path
            print_point(r)
            print(f"    {r['seconds']:.1f} s (RK4 {r['seconds_rk4']:.1f} s)", flush=True)
            results.append(r)
            compared += 1

    wall = time.perf_counter() - t_all
    h = headline(results) if compared else None
    if h is not None:
        stores = list(dict.fromkeys(r["store"] for r in results if r.get("store")))
        if len(stores) > 1:
            # each store on its own (the same points: a before / after comparison)
            for path in stores:
                print(f"\n{path}:")
                print_headline(headline([r for r in results if r.get("store") == path]))
        print("\nall stores:" if len(stores) > 1 else "")
        print_headline(h)
    print(f"{len(results)} point(s) in {wall:.1f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"args": vars(args), "headline": h, "points": results, "wall": wall},
                      f, indent=1, default=_jsonable)
        print(f"wrote {args.json}")
    return 0


def _jsonable(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o))


if __name__ == "__main__":
    sys.exit(main())
