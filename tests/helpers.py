"""Helpers shared by the tests: Liouville's formula for an orbit, a stand-in block solver with the schema's contract (to test
the scheduler and the store without the physics), subprocess environments, waiting.

``placeholder_solve_block`` returns arrays of exactly the stored schema (study.schema
``empty_arrays``: shapes, dtypes, empty-slot values) with made-up, deterministic values: it lets
the scheduler and the store be tested without the real solver. Workers import it as
``tests.helpers:placeholder_solve_block`` (the repository root is put on their path). Never used
by the CLI unless asked for with the hidden ``--solver`` option.
"""

from __future__ import annotations

from math import exp, pi
import os
import socket
import sys
import time
from pathlib import Path

import numpy as np
import xarray as xr

from hertzmap.study.schema import (ATTRACTOR_VARIABLES, ORBIT_VARIABLES, chunked_length, empty_arrays,
                                   slot_counts, template)
from hertzmap.study.spec import parse_study

REPO = Path(__file__).resolve().parent.parent
TESTS = Path(__file__).resolve().parent

PLACEHOLDER = "tests.helpers:placeholder_solve_block"


def _hold_after_the_first_block(gate: str | None, timeout: float = 600.0) -> None:
    """With a gate path (``$HERTZMAP_PLACEHOLDER_HOLD``): the first task's block to get here goes on
    (it creates ``<gate>.first``), every later one waits until the test creates the gate
    file itself. A run then holds its lock with exactly its first task done, for as long as
    the test needs, whatever the machine's load (an event, not a sleep)."""
    if not gate:
        return
    try:
        os.close(os.open(gate + ".first", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        return
    except FileExistsError:
        pass
    deadline = time.monotonic() + timeout
    while not os.path.exists(gate):
        if time.monotonic() > deadline:
            raise TimeoutError(f"the test never opened the gate {gate}")
        time.sleep(0.01)


def placeholder_solve_block(omega, sigma, zeta, *, periods=(1, 2), exponent=1.5, model="hertz",
                            rtol=1e-10, harmonics=True, **census):
    """Deterministic fake with the solve_block contract (delay: $HERTZMAP_PLACEHOLDER_DELAY
    s/point). $HERTZMAP_PLACEHOLDER_EXTRA = k: the points with omega > 1.5 hold k more
    (unstable) orbits, of periods 3, 4, ...: blocks that hold more slots than others, some more
    than the store's first chunk of them."""
    omega = np.asarray(omega, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    zeta = np.asarray(zeta, dtype=np.float64)
    delay = float(os.environ.get("HERTZMAP_PLACEHOLDER_DELAY", "0"))
    if delay:
        time.sleep(delay * len(omega) * len(sigma) * len(zeta))
    if omega.size * sigma.size * zeta.size > 1:     # a worker's warm-up solves one point
        _hold_after_the_first_block(os.environ.get("HERTZMAP_PLACEHOLDER_HOLD"))
    w, s, z = np.meshgrid(omega, sigma, zeta, indexing="ij")
    extra = int(os.environ.get("HERTZMAP_PLACEHOLDER_EXTRA", "0"))
    shape = (len(omega), len(sigma), len(zeta))
    n_slots = len(periods) + (extra if (omega > 1.5).any() else 0)
    out = empty_arrays(shape, slot_counts(chunked_length(n_slots)),
                       ORBIT_VARIABLES + ("orbits_found",))
    amp = s / np.sqrt((1 - w**2) ** 2 + (2 * z * w) ** 2)
    slots = []
    if 1 in periods:
        slots.append((1, np.ones_like(w, bool)))
    if 2 in periods:
        slots.append((2, (w > 1.8) & (w < 2.2) & (s > 0.2)))
    slots += [(3 + e, w > 1.5) for e in range(extra if (omega > 1.5).any() else 0)]
    for slot, (p, mask) in enumerate(slots):
        a = amp * p
        sl = (slice(None),) * 3 + (slot,)
        out["period"][sl] = np.where(mask, p, 0)
        out["status"][sl] = np.where(mask, np.where(a > 50, 1, 0), -1)
        out["q0"][sl] = np.where(mask, a, np.nan)
        out["v0"][sl] = np.where(mask, -a * w / p, np.nan)
        out["stable"][sl] = mask & (a < 2) & (p <= 2)
        out["min_q"][sl] = np.where(mask, -a, np.nan)
        out["max_q"][sl] = np.where(mask, a, np.nan)
        out["ptp"][sl] = np.where(mask, 2 * a, np.nan)
        out["loses_contact"][sl] = mask & (a > exponent)
        out["flight_fraction"][sl] = np.where(mask, np.clip((a - exponent) / (a + 1), 0, 1), np.nan)
        out["max_impact_velocity"][sl] = np.where(mask, a * w, np.nan)
        out["multipliers"][sl] = np.where(mask[..., None], np.exp(-z * p * np.pi / w)[..., None]
                                          * np.array([1, 1j]), complex(np.nan, np.nan))
        if harmonics:   # as solve_block: NaN unless asked for
            out["force_harmonics"][sl] = np.where(mask[..., None], a[..., None] / np.arange(1, 5),
                                                  np.nan)
        out["newton_iterations"][sl] = np.where(mask, 3, 0)
        out["residual"][sl] = np.where(mask, 1e-12, np.nan)
    # the slots filled from 0: a point's orbits first, its empty slots after them
    order = np.argsort(out["status"] == -1, axis=-1, kind="stable")
    for name in ORBIT_VARIABLES:
        a = out[name]
        idx = order.reshape(order.shape + (1,) * (a.ndim - 4))
        out[name] = np.take_along_axis(a, np.broadcast_to(idx, a.shape), axis=3)
    out["orbits_found"][...] = (out["status"] == 0).sum(axis=-1)
    out["atlas_round"][out["status"] == 0] = 0
    if census.get("attractors", "never") != "never":      # the census found nothing here
        out.update(empty_arrays(shape, names=ATTRACTOR_VARIABLES))
        out["attractor_count"][...] = 0
    return out


def failing_solve_block(omega, sigma, zeta, **kwargs):
    """The placeholder, but raising for blocks with a sigma above 0.85 (a task failing for good)."""
    if np.max(sigma) > 0.85:
        raise FloatingPointError(f"placeholder failure at sigma = {np.max(sigma)}")
    return placeholder_solve_block(omega, sigma, zeta, **kwargs)


# -- independent checks of an orbit ------------------------------------------------------------

def assert_liouville(orbit, tol=1e-6):
    """det M = exp(-2 zeta P) for every converged orbit (P = period * 2 pi / omega), to the
    precision a 2x2 determinant can have: relative to |m11 m22| + |m12 m21| when that is larger
    (heavy damping makes det M ~ 1e-55 from entries ~ 1e-2)."""
    if orbit.converged:
        P = orbit.period * 2 * pi / orbit.omega
        expected = exp(-2 * orbit.zeta * P)
        M = orbit.monodromy
        scale = max(expected, abs(M[0, 0] * M[1, 1]) + abs(M[0, 1] * M[1, 0]))
        assert abs(np.linalg.det(M) - expected) <= tol * scale, (orbit, expected)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def subprocess_env(**extra) -> dict[str, str]:
    """Environment for CLI / dask subprocesses: the repository (and so tests.helpers) importable."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env.update({k: str(v) for k, v in extra.items()})
    return env


def hertzmap_cmd(*args: str) -> list[str]:
    return [sys.executable, "-m", "hertzmap.scheduler.doors.cli", *args]


def done_count(store) -> int:
    """Tasks marked done in a store (0 while it does not exist or cannot be read yet)."""
    from hertzmap.scheduler.store import Store
    try:
        return int(Store(store).done_mask().sum())
    except Exception:
        return 0


def wait_until(pred, timeout: float, what: str) -> None:
    t0 = time.monotonic()
    while not pred():
        if time.monotonic() - t0 > timeout:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


def kill_run_when(cmd, env, pred, what: str, timeout: float = 300) -> None:
    """Start `hertzmap run` (cmd) in its own process group and SIGKILL the whole group
    (client, scheduler, workers) once ``pred(process)`` holds."""
    import signal
    import subprocess
    p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    try:
        wait_until(lambda: pred(p), timeout, what)
        os.killpg(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)


def kill_client_mid_study(cmd, env, store, tasks: int) -> int:
    """kill_run_when ``tasks`` tasks are done (or the run ended); how many were done."""
    kill_run_when(cmd, env, lambda p: done_count(store) >= tasks or p.poll() is not None,
                  f"{tasks} tasks", timeout=90)
    return done_count(store)


# -- a small study run with the placeholder solver --------------------------------------------

#: A 17 x 5 x 2 study for the store and scheduler tests (the placeholder fills it in ms).
STORE_TEST_STUDY = """
[study]
name = "store-test"
[grid]
omega = {start = 0.5, stop = 2.5, num = 17}
sigma = [0.1, 0.3, 0.5, 0.7, 0.9]
zeta = [0.01, 0.1]
[products]
outputs = ["orbits", "measures", "force_harmonics"]
"""
#: The same grid with every output.
ALL_OUTPUTS_STUDY = STORE_TEST_STUDY.replace(
    'outputs = ["orbits", "measures", "force_harmonics"]',
    'outputs = ["orbits", "measures", "force_harmonics", "diagnostics", "bifurcations",'
    ' "curves"]')

#: A [rig] table (the paper's rig, section 4.1).
RIG_TABLE = """
[rig]
E = 2.1e11
nu = 0.29
R = 0.0127
m = 7.1
N = 69.7
"""


def placeholder_study(text: str = STORE_TEST_STUDY):
    return parse_study(text, default_name="x")


def placeholder_run(path, client, text: str = STORE_TEST_STUDY, **kw):
    """Run a study with the placeholder solver on ``client`` into ``path``; the summary."""
    from hertzmap.scheduler.cluster.clusters import ClusterSpec
    from hertzmap.scheduler.run import RunOptions, run_study

    opts = RunOptions(store=path, solver=PLACEHOLDER, cluster=ClusterSpec(kind="address"),
                      error_sample=kw.pop("error_sample", 0), **kw)
    return run_study(placeholder_study(text), opts, client=client)


# -- hand-built results (every value set here) -------------------------------------------------

HAND_STUDY = """
[grid]
omega = [1.0, 1.5, 2.0]
sigma = [0.1, 0.5]
zeta = 0.01
"""


def blank_results(toml: str, name: str = "t") -> xr.Dataset:
    """An in-memory store dataset (template) with writable arrays, every block done."""
    study = parse_study(toml, default_name=name)
    ds = template(study, study.shape, history="test")
    for v in list(ds.data_vars):
        ds[v] = ds[v].copy(data=np.array(ds[v].values))
    ds["task_done"][...] = True
    return ds


def set_orbit(ds, i, j, slot, *, period, stable, loses=False, mult=(0.5, 0.4), min_q=-0.1,
              max_q=0.1, ff=0.0, iv=0.0, k=0):
    """Put a converged orbit with these flags and measures into one slot."""
    idx = dict(omega=i, sigma=j, zeta=k, solution=slot)
    ds["status"][idx] = 0
    ds["period"][idx] = period
    ds["stable"][idx] = stable
    ds["q0"][idx] = 0.0
    ds["v0"][idx] = 0.0
    ds["multipliers"][idx] = np.asarray(mult, complex)
    if "min_q" in ds:
        ds["min_q"][idx] = min_q
        ds["max_q"][idx] = max_q
        ds["ptp"][idx] = max_q - min_q
        ds["loses_contact"][idx] = loses
        ds["flight_fraction"][idx] = ff
        ds["max_impact_velocity"][idx] = iv


def hand_built_results() -> xr.Dataset:
    """3 omega x 2 sigma of hand-set orbits covering the classes, a duplicate and a point whose
    data is there but whose block is not flagged done (see the comments)."""
    ds = blank_results(HAND_STUDY)
    # (0, 0): one stable 1T in contact
    set_orbit(ds, 0, 0, 0, period=1, stable=True)
    # (1, 0): stable 1T in contact + stable 2T with contact loss + unstable 2T with contact loss
    set_orbit(ds, 1, 0, 0, period=1, stable=True)
    set_orbit(ds, 1, 0, 1, period=2, stable=True, loses=True, min_q=-2.0, max_q=3.0, ff=0.3, iv=1.7)
    set_orbit(ds, 1, 0, 2, period=2, stable=False, loses=True, min_q=-1.8, max_q=2.0, ff=0.2, iv=0.9)
    # (2, 0): 1T past its flip (unstable), stable 2T in contact, unstable 2T in contact
    set_orbit(ds, 2, 0, 0, period=1, stable=False, mult=(-1.05, -0.9))
    set_orbit(ds, 2, 0, 1, period=2, stable=True, min_q=-0.8, max_q=0.9)
    set_orbit(ds, 2, 0, 2, period=2, stable=False, min_q=-0.5, max_q=0.6)
    # (0, 1): stable 1T with contact loss, and the same orbit again (its invariants within
    # study.orbit_rules.SAME_ORBIT_TOL): a duplicate, not a second orbit
    mu = np.sqrt(np.exp(-2 * 0.01 * 2 * np.pi / 1.0))      # |mu1 mu2| = exp(-2 zeta T)
    set_orbit(ds, 0, 1, 0, period=1, stable=True, loses=True, mult=(-mu, -mu), min_q=-1.6,
              max_q=2.0, ff=0.1, iv=0.5)
    set_orbit(ds, 0, 1, 1, period=1, stable=True, loses=True, mult=(-mu, -mu),
              min_q=-1.6 + 1e-9, max_q=2.0, ff=0.1, iv=0.5)
    # (1, 1): not computed (its block is not flagged) although a slot holds data
    set_orbit(ds, 1, 1, 0, period=1, stable=True)
    ds["task_done"][...] = True
    return ds


def solved_results(toml: str, path, name: str = "real") -> Path:
    """A small real store: the study's grid solved as one block (study.solve.block, no Dask),
    written with every block flagged done."""
    from hertzmap.study.schema import block_dataset, stored_variables
    from hertzmap.study.solve.block import solve_block

    study = parse_study(toml, default_name=name)
    ds = blank_results(toml, name)
    arrays = solve_block(study.axis("omega"), study.axis("sigma"), study.axis("zeta"),
                         **study.solver_kwargs())
    blk = block_dataset(arrays, stored_variables(study))
    for v in blk.data_vars:
        ds[v] = ds[v].copy(data=blk[v].values)
    return write_results(ds, path)


#: A 2 x 2 grid near omega = 2 with every output the grid's block stores (the census at every
#: point, short transients): it supports every product of the registry but isola_boundary,
#: which takes traced curves (:func:`fake_traced_curves`).
EVERY_OUTPUT_STUDY = """
[grid]
omega = [1.9, 2.05]
sigma = [0.3, 0.5]
zeta = 0.01
[search]
attractors = "always"
initial_states = 2
transient_periods = 50
record_periods = 32
[products]
outputs = ["orbits", "measures", "force_harmonics", "bifurcations", "attractors"]
"""


def fake_trace(index, kind, period, zeta, sigma, codim2=()):
    """One traced curve as study.solve.curve_seeds returns it, every value made up: a curve of
    ``kind`` and ``period`` through the ``sigma`` values (its lowest vertex flagged the
    extremum), omega from 1 to 2."""
    from hertzmap.study.products.traced_curves import VERTEX_EXTREMUM

    n = len(sigma)
    flag = np.zeros(n)
    flag[int(np.argmin(sigma))] = VERTEX_EXTREMUM
    V = {k: np.zeros(n) for k in ("q0", "v0", "min_q", "max_q", "fold", "flip", "grazing", "step",
                                  "arclength", "residual")}
    V.update(omega=np.linspace(1.0, 2.0, n), sigma=np.asarray(sigma, float),
             zeta=np.full(n, zeta), flag=flag, multipliers=np.ones((n, 2), complex))
    seed = dict(index=index, plane=("omega", "sigma"), fixed=zeta, kind=kind, period=period,
                omega=1.5, sigma=float(min(sigma)), zeta=zeta, q0=0.0, v0=0.0)
    return {"seed": seed, "status": ("boundary", "meets_1T_orbit"), "vertices": V,
            "codim2": list(codim2), "maps": 10}


def fake_traced_curves(zeta: float = 0.01) -> xr.Dataset:
    """A traced_curves product of one made-up isola fold curve (2T) whose lowest sigma is
    0.17 at ``zeta``, joining the flip curve at sigma 0.36 (its last vertex)."""
    from hertzmap.study.products.traced_curves import combine_traced_curves, traced_curves_dataset

    join = dict(kind="fold_flip", period=2, omega=2.0, sigma=0.36, zeta=zeta, q0=0.0, v0=0.0,
                multipliers=[-1, 0.5], value=0.0, left=1e-9, right=np.nan, accuracy=1e-8,
                vertex=4)
    return combine_traced_curves([traced_curves_dataset([
        fake_trace(0, "fold", 2, zeta, [0.3, 0.2, 0.17, 0.25, 0.36], [join])])])


def write_results(ds: xr.Dataset, path) -> Path:
    """A dataset written as a zarr store (as the scheduler writes one)."""
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Cc]onsolidated metadata.*")
        ds.to_zarr(str(path), mode="w", consolidated=True)
    return Path(path)


# -- a slow curve tracer (the "curves" output's developer hook --curve-tracer) -------------------

SLOW_TRACER = "tests.helpers:slow_trace_seed"


def slow_trace_seed(seed, bounds, **kwargs):
    """study.solve.curve_seeds.trace_seed after a pause ($HERTZMAP_CURVE_DELAY s, default 1): a
    curve stage slow enough for a test to kill it between two committed curves."""
    from hertzmap.study.solve.curve_seeds import trace_seed

    time.sleep(float(os.environ.get("HERTZMAP_CURVE_DELAY", "1")))
    return trace_seed(seed, bounds, **kwargs)


# -- a slow atlas tile (the atlas's developer hook --atlas-tile) ---------------------------------

SLOW_ATLAS_TILE = "tests.helpers:slow_atlas_tile"


def slow_atlas_tile(*args, **kwargs):
    """study.solve.atlas.atlas_tile after a pause ($HERTZMAP_ATLAS_DELAY s, default 1): an
    atlas round (continuation or census) slow enough for a test to kill it between two staged
    tiles."""
    from hertzmap.study.solve.atlas import atlas_tile

    time.sleep(float(os.environ.get("HERTZMAP_ATLAS_DELAY", "1")))
    return atlas_tile(*args, **kwargs)


def align_slots(ds: xr.Dataset, like: xr.Dataset) -> xr.Dataset:
    """``ds`` with its slot dims cut to the lengths of ``like``'s (a store read while it is
    written, its dims in whole chunks, against the finished store); the cut slots must be
    empty."""
    return trim_slots(ds, {d: like.sizes[d] for d in ("solution", "attractor") if d in like.dims})


def trim_slots(ds: xr.Dataset, used: dict | None = None) -> xr.Dataset:
    """A store's Dataset with its slot dims cut to the most entries any of its points holds
    (what a finished run's store is cut to): a store left by an interrupted run, its dims still
    in whole chunks, compared with a finished one. The cut slots must be empty."""
    from hertzmap.study.schema import VARIABLES

    if used is None:
        used = {"solution": int((ds["status"].values != -1).sum(-1).max(initial=1))}
        if "attractor_kind" in ds:
            used["attractor"] = max(1, int((ds["attractor_kind"].values > 0).sum(-1)
                                           .max(initial=1)))
    for name, v in ds.data_vars.items():
        spec = VARIABLES.get(name)
        if spec is not None and spec.slot_dim in used:
            cut = v.isel({spec.slot_dim: slice(used[spec.slot_dim], None)}).values
            assert (cut == spec.fill).all() or (np.issubdtype(cut.dtype, np.inexact)
                                                 and np.isnan(cut).all()), name
    return ds.isel({d: slice(0, n) for d, n in used.items() if d in ds.dims})


def small_study_toml(name: str, *, omega, sigma, zeta, outputs, periods=(1, 2),
                     attractors: str = "never", **tables) -> str:
    """The TOML text of a small study of the tests: its grid (each axis a list of values or a
    {start, stop, num} table), the search of ``periods`` with the census ``attractors``
    ("never" unless a test needs it: seconds, not minutes), its ``outputs``, and any other
    table given by name (``sweep={...}``, ``rig={...}``)."""
    from hertzmap.study.spec import study_toml

    doc = {"study": {"name": name}, "grid": {"omega": omega, "sigma": sigma, "zeta": zeta},
           "search": {"periods": list(periods), "attractors": attractors},
           "products": {"outputs": list(outputs)}}
    doc.update(tables)
    return study_toml(doc)


def product_mtime(store, product: str) -> int:
    """The newest modification time (ns) of any file of ``products/<product>`` in a store."""
    return max(p.stat().st_mtime_ns for p in (Path(store) / "products" / product).rglob("*"))


def assert_rerun_leaves_product(main, study, store, product: str, capsys,
                                stage_line: str) -> str:
    """Rerun ``hertzmap run STUDY --store STORE`` (``main``: the CLI's entry point) on a store
    that holds everything: it exits 0, prints no ``stage_line`` (the stage's own summary line
    starts with it: nothing was computed) and leaves ``products/<product>`` untouched (no file
    of it rewritten). Returns the run's output."""
    before = product_mtime(store, product)
    assert main(["run", str(study), "--store", str(store)]) == 0
    out = capsys.readouterr().out
    assert not any(ln.startswith(stage_line) for ln in out.splitlines()), out
    assert product_mtime(store, product) == before
    return out


def assert_same_data(a: xr.Dataset, b: xr.Dataset) -> None:
    """xr.testing.assert_identical, failing first with what differs where: for each variable
    whose values differ, how many and the first few points' coordinates with both values
    (a non-determinism shows as a region, an off-by-a-slot order as a shift)."""
    lines = []
    for name in sorted(set(a.data_vars) & set(b.data_vars)):
        x, y = a[name], b[name]
        if x.shape != y.shape:
            lines.append(f"{name}: shapes {x.shape} and {y.shape}")
            continue
        xv, yv = np.asarray(x.values), np.asarray(y.values)
        same = xv == yv
        if xv.dtype.kind in "fc":
            same |= np.isnan(xv) & np.isnan(yv)
        if same.all():
            continue
        where = np.argwhere(~same)
        first = []
        for idx in where[:3]:
            at = {d: (x[d].values[i].item() if d in x.coords else int(i))
                  for d, i in zip(x.dims, idx)}
            first.append(f"{at}: {xv[tuple(idx)]!r} vs {yv[tuple(idx)]!r}")
        lines.append(f"{name}: {len(where)} of {xv.size} differ; " + "; ".join(first))
    assert not lines, "the stores differ:\n" + "\n".join(lines)
    xr.testing.assert_identical(a, b)
