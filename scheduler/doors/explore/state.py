"""What one ``hertzmap explore`` process shares between its pages: the stores it shows (read
as they are written), the refine job (one at a time) that writes a new store through
``scheduler.run.run_study`` on a background thread, and the stepped-sine sweeps through clicked
points (``study.explore_sweeps.line_sweep``, each on its own background thread of this process;
the store's products/sweeps where it holds the line; the sweeps computed kept for the other
pages), and the basin maps of clicked points (``scheduler.stages.basin_tasks.run_basins`` on the
refines' cluster, one at a time, its tiles drawn as they return).
"""
from __future__ import annotations

import contextlib
import io
import threading
import time
import warnings
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from hertzmap.scheduler.cluster.clusters import ClusterError, ClusterSpec, make_client
from hertzmap.scheduler.defaults import DEFAULT_TASK_SECONDS
from hertzmap.scheduler.stages.plan import choose_chunks, make_plan
from hertzmap.scheduler.errors import RunError, StoreError
from hertzmap.scheduler.run import RunOptions, run_study
from hertzmap.scheduler.store import (has_run_product, lock_path, read_attrs, read_done_flags,
                                      read_product)
from hertzmap.study import explore_data as E
from hertzmap.study import explore_sweeps as ES
from hertzmap.study import products as P
from hertzmap.study.products.stepped_sweeps import SWEEPS


@contextlib.contextmanager
def _quiet():
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Cc]onsolidated metadata.*")
        warnings.filterwarnings("ignore", message=".*not part in the Zarr format 3.*")
        yield


def is_store(path: Path) -> bool:
    attrs = read_attrs(path)
    return attrs is not None and "hertzmap_study_hash" in attrs


def read_flags(path: Path) -> np.ndarray:
    """The task_done flags of a store (read alone: cheap, for polling)."""
    return read_done_flags(path)


def read_snapshot(path: Path) -> xr.Dataset:
    """The store's main group in memory with undone blocks emptied (``products.open_store``),
    consistent while ``hertzmap run`` writes it: the flags are read before the data (a block
    is written before its flag, so every block flagged in this read is whole in the next)."""
    with _quiet():
        ds = xr.open_zarr(str(path), chunks=None)
        flags = np.asarray(ds["task_done"].values, bool).copy()
        ds = ds.load()
    ds["task_done"] = (ds["task_done"].dims, flags, ds["task_done"].attrs)
    return P.open_store(ds)


@dataclass
class StoreView:
    """One store as the page draws it, computed once per state of its flags."""

    path: Path
    ds: xr.Dataset
    lcm: xr.Dataset
    curves: xr.Dataset
    mms: xr.Dataset
    units: E.Units
    flags: np.ndarray

    _columns: dict = field(default_factory=dict, repr=False)
    _sweeps: Any = field(default=None, repr=False)

    def map_columns(self, zeta: float) -> dict[str, np.ndarray]:
        """The map's cells at ``zeta`` (``explore_data.map_columns``), computed once per store
        state for every page (about 1 s per 12,000 points with the hover summaries)."""
        if zeta not in self._columns:
            self._columns[zeta] = E.map_columns(self.ds, self.lcm, zeta, self.units)
        return self._columns[zeta]

    def sweeps(self) -> xr.Dataset | None:
        """The store's ``sweeps`` product (products/sweeps), read once; None when the store
        holds none written by a run of its study (or it cannot be read)."""
        if self._sweeps is None:
            found = None
            study_hash = self.ds.attrs.get("hertzmap_study_hash")
            try:
                if study_hash and has_run_product(self.path, SWEEPS, study_hash):
                    found = read_product(self.path, SWEEPS)
            except Exception:       # unreadable: the page computes the sweep instead
                found = None
            self._sweeps = found if found is not None else False
        return self._sweeps if self._sweeps is not False else None

    @property
    def done(self) -> tuple[int, int]:
        return int(self.flags.sum()), int(self.flags.size)

    @property
    def locked_by(self) -> dict[str, Any] | None:
        import json
        lock = lock_path(self.path)
        try:
            return json.loads(lock.read_text()) if lock.exists() else None
        except (OSError, ValueError):
            return {"host": "?", "pid": "?"}

    @property
    def name(self) -> str:
        return self.path.name

    @classmethod
    def load(cls, path: Path) -> "StoreView":
        ds = read_snapshot(path)
        lcm = P.loss_of_contact_map(ds)
        om = ds["omega"].values
        # the multiple-scales expansion is about omega = 2: its curve is drawn near there only
        lo, hi = max(float(om.min()), 2.0 - P.MMS_HALF_WIDTH), min(float(om.max()),
                                                                    2.0 + P.MMS_HALF_WIDTH)
        w = np.linspace(lo, hi, 401) if lo < hi else np.array([2.0])
        return cls(path=path, ds=ds, lcm=lcm, curves=P.bifurcation_curves(lcm),
                   mms=P.mms_curves(w, ds["zeta"].values), units=E.units_of(ds),
                   flags=np.asarray(ds["task_done"].values, bool))


class RefineJob:
    """One refine: the study written next to the first store, then ``run_study`` into its
    store on a thread. ``state``: starting, running, done, failed; ``message`` says why."""

    def __init__(self, study, text: str, store: Path, study_file: Path, cluster: ClusterSpec,
                 client_of):
        self.study = study
        self.cluster = cluster
        self.text = text
        self.store = store
        self.study_file = study_file
        self._client_of = client_of
        self.state = "starting"
        self.message = "starting the workers ..."
        self.log = io.StringIO()
        self.started = time.monotonic()
        self.seconds: float | None = None
        # tasks of the store the run will create (its chunking), for the progress shown
        # before the store exists
        self.total = len(make_plan(study, choose_chunks(study, DEFAULT_TASK_SECONDS)).tasks)
        self.thread = threading.Thread(target=self._run, name="hertzmap-refine", daemon=True)

    def start(self) -> "RefineJob":
        self.thread.start()
        return self

    def progress(self) -> tuple[int, int]:
        """(tasks done, total) of the refine's store: its flags once it exists."""
        if not is_store(self.store):
            return 0, self.total
        try:
            f = read_flags(self.store)
        except Exception:       # the store is being created: not readable yet
            return 0, self.total
        return int(f.sum()), int(f.size)

    def _run(self) -> None:
        try:
            client = self._client_of()
            self.state = "running"
            self.message = "computing"
            opts = RunOptions(store=self.store, cluster=self.cluster,
                              command=f"hertzmap run {self.study_file.name} (hertzmap explore)")
            summary = run_study(self.study, opts, out=self.log, err=self.log, client=client)
            if summary.get("complete"):
                self.state = "done"
                self.message = (f"done: {summary.get('points', 0)} points in "
                                f"{summary.get('wall', 0.0):.1f} s")
            else:
                self.state = "failed"
                fails = summary.get("failed") or []
                self.message = ("incomplete: " + "; ".join(f"{k}: {m}" for k, m in fails[:3])
                                + " (refine the same window again to resume)")
        except (StoreError, RunError, ClusterError) as exc:
            self.state = "failed"
            self.message = str(exc)
        except Exception as exc:  # shown on the page; the server keeps serving
            self.state = "failed"
            self.message = f"{type(exc).__name__}: {exc}"
        finally:
            self.seconds = time.monotonic() - self.started


class BasinJob:
    """The basin map of a clicked point (``hertzmap basins``'s reuse method) on the server's
    cluster, on a thread: ``labels`` (cells along q', cells along q) fills in as the tiles
    return (-1: not yet), ``version`` counts the updates; once done, ``dataset`` is the map
    (written into the store as its product group, as the command writes it) and ``labels`` its
    final labels, numbered as the tiles numbered them (so the colours stay). ``state``:
    running, done, failed."""

    def __init__(self, req, cluster: ClusterSpec, client_of):
        self.req = req
        self.cluster = cluster
        self._client_of = client_of
        nq, nv = req.grid
        self.labels = np.full((nv, nq), -1, np.int16)
        self.version = 0
        self.tiles = 0
        self.state = "running"
        self.message = "starting the workers ..."
        self.dataset: xr.Dataset | None = None
        self.started = time.monotonic()
        self.seconds: float | None = None
        self.thread = threading.Thread(target=self._run, name="hertzmap-basins", daemon=True)

    def start(self) -> "BasinJob":
        self.thread.start()
        return self

    def _tile(self, step: str, spec: dict, result: dict) -> None:
        if step == "round":
            lab = result["label"]
            ok = lab >= 0
            self.labels.reshape(-1)[spec["cells"][ok]] = lab[ok]
        self.tiles += 1
        self.version += 1
        self.message = f"{self.tiles} tiles back"

    def _run(self) -> None:
        from hertzmap.scheduler.stages.basin_tasks import run_basins
        try:
            client = self._client_of()
            self.message = "computing"
            result = run_basins(self.req, self.cluster, self.req.store.parent, client=client,
                                on_tile=self._tile)
            ds = result["dataset"]
            final = ds["basin_label"].values
            self.labels = E.keep_colours(final, self.labels)
            self.dataset = ds
            self.version += 1
            self.state = "done"
            self.message = f"done in {result['map_seconds']:.1f} s"
        except Exception as exc:  # shown on the page; the server keeps serving
            self.state = "failed"
            self.message = f"{type(exc).__name__}: {exc}"
        finally:
            self.seconds = time.monotonic() - self.started


class SweepJob:
    """Stepped-sine sweeps up and down one line through a clicked point (``explore_sweeps.
    line_sweep``), computed on a thread of the server process, or a result already at hand
    (the store's products/sweeps, or a sweep this server computed before). ``state``:
    running, done, failed; ``result``: the sweep (explore_data's form) once done; ``origin``:
    "computed", "stored" or "computed before"; ``message`` says why it failed (no traceback);
    ``seconds``: from the start to the end."""

    def __init__(self, what: str, compute=None, *, result=None, origin: str = "computed",
                 on_done=None):
        self.what = what
        self.origin = origin
        self.result = result
        self.message = ""
        self.started = time.monotonic()
        self.seconds: float | None = None if result is None else 0.0
        self.state = "running" if result is None else "done"
        self._compute = compute
        self._on_done = on_done
        self.thread = None
        if result is None:
            self.thread = threading.Thread(target=self._run, name="hertzmap-sweep", daemon=True)
            self.thread.start()

    def _run(self) -> None:
        try:
            result = self._compute()
            if self._on_done is not None:
                self._on_done(result)
            self.result = result
            self.state = "done"
        except Exception as exc:  # shown on the page; the server keeps serving
            self.message = f"{type(exc).__name__}: {exc}"
            self.state = "failed"
        finally:
            self.seconds = time.monotonic() - self.started


#: sweeps computed by one server kept for its pages (a click on the same line shows them again)
SWEEP_CACHE = 32


@dataclass
class ExploreState:
    """Shared by every page of one server: the first store, where refines run, the job."""

    base: Path
    cluster: ClusterSpec
    max_refine_points: int = E.MAX_REFINE_POINTS
    job: RefineJob | None = None
    basin_job: BasinJob | None = None
    _views: dict[Path, StoreView] = field(default_factory=dict)
    _client: Any = None
    _cluster_obj: Any = None
    _lock: threading.Lock = field(default_factory=threading.Lock)
    # its own lock: starting a cluster takes seconds and must not hold up the pages' reads
    _client_lock: threading.Lock = field(default_factory=threading.Lock)
    _sweeps: OrderedDict = field(default_factory=OrderedDict)
    _sweep_lock: threading.Lock = field(default_factory=threading.Lock)

    def stores(self) -> list[Path]:
        """The first store and the refines next to it (``<stem>.refine-*.zarr``), oldest first."""
        stem = self.base.name[:-5] if self.base.name.endswith(".zarr") else self.base.name
        refs = [p for p in self.base.parent.glob(f"{stem}.refine-*.zarr") if is_store(p)]
        refs.sort(key=lambda p: (p.stat().st_mtime, p.name))
        return [self.base] + refs

    def view(self, path: Path) -> StoreView:
        """The store at ``path``, reloaded when its flags changed since the last read."""
        path = Path(path)
        with self._lock:
            v = self._views.get(path)
            if v is not None:
                try:
                    flags = read_flags(path)
                except Exception:
                    return v
                if flags.shape == v.flags.shape and (flags == v.flags).all():
                    return v
            v = StoreView.load(path)
            self._views[path] = v
            return v

    def _client_for_refines(self):
        """One Dask client for every refine of this server: the embedded LocalCluster (started
        at the first refine, not before: it costs memory and a few seconds) or the scheduler
        given with --scheduler."""
        with self._client_lock:
            if self._client is None:
                self._client, self._cluster_obj = make_client(self.cluster)
            return self._client

    def start_basins(self, path: Path, omega: float, sigma: float, zeta: float,
                     side: int) -> BasinJob:
        """The basin map (side x side initial states over the census's box) of the grid point
        of the store ``path`` nearest (omega, sigma, zeta), on the refines' cluster. Raises
        ValueError (shown on the page) while another basin map runs or the request is
        refused."""
        from hertzmap.scheduler.stages.basin_tasks import check_request
        from hertzmap.scheduler.errors import RefusedError

        if self.basin_job is not None and self.basin_job.state == "running":
            raise ValueError("a basin map is being computed; wait for it")
        try:
            req = check_request(path, omega, sigma, zeta, f"{side}x{side}", None, None)
        except (RefusedError, StoreError) as exc:
            raise ValueError(str(exc)) from None
        self.basin_job = BasinJob(req, self.cluster, self._client_for_refines).start()
        return self.basin_job

    def start_refine(self, ds: xr.Dataset, omega_range, sigma_range, num_omega: int,
                     num_sigma: int, zeta: float) -> RefineJob:
        """Start the refine of a window (dimensionless ranges). Raises ValueError (shown on the
        page, nothing written) when a refine runs or the window is refused."""
        if self.job is not None and self.job.state in ("starting", "running"):
            raise ValueError(f"a refine is running ({self.job.store.name}); wait for it")
        text, study = E.refine_study(ds, omega_range, sigma_range, num_omega, num_sigma, zeta,
                                     max_points=self.max_refine_points)
        store = self.base.parent / E.refine_store_name(self.base.name, study.name)
        study_file = store.with_suffix(".toml")
        if store.exists() and not is_store(store):
            raise ValueError(f"{store} exists and is not a hertzmap store; move it away")
        study_file.write_text(text)
        self.job = RefineJob(study, text, store, study_file, self.cluster,
                             self._client_for_refines).start()
        return self.job

    def start_sweep(self, view: StoreView, axis: str, omega: float, sigma: float,
                    zeta: float) -> SweepJob:
        """The sweeps up and down ``axis`` through the grid point nearest (omega, sigma, zeta)
        of the store ``view``: the store's products/sweeps when it holds that line (nothing
        computed), else a sweep this server computed before on the same line and steps, else
        ``explore_sweeps.line_sweep`` started on a thread (the job answers at once: the page
        polls it). Raises ValueError (shown on the page, nothing computed) when the line cannot
        be swept (one grid value along the axis)."""
        values, _ = ES.sweep_values(view.ds, axis, omega, sigma)     # ValueError: refused
        stored = ES.stored_line_sweep(view.sweeps(), axis, omega, sigma, zeta)
        fixed = ES.sweep_fixed(view.ds, axis, omega, sigma, zeta)
        what = (f"{axis} ({values.size} steps) at "
                + ", ".join(f"{a} = {v:g}" for a, v in fixed.items()))
        if stored is not None:
            return SweepJob(what, result=stored, origin="stored")
        key = (str(view.path), view.ds.attrs.get("hertzmap_study_hash"), axis,
               tuple(sorted(fixed.items())), values.tobytes())
        with self._sweep_lock:
            hit = self._sweeps.get(key)
            if hit is not None:
                self._sweeps.move_to_end(key)
                return SweepJob(what, result=hit, origin="computed before")

        def keep(result) -> None:
            with self._sweep_lock:
                self._sweeps[key] = result
                while len(self._sweeps) > SWEEP_CACHE:
                    self._sweeps.popitem(last=False)

        ds = view.ds
        return SweepJob(what, lambda: ES.line_sweep(ds, axis, omega, sigma, zeta), on_done=keep)

    def close(self) -> None:
        # bounded: a scheduler that went away first must not hold up Ctrl-C
        for obj in (self._client, self._cluster_obj):
            if obj is not None:
                with contextlib.suppress(Exception):
                    obj.close(timeout=5)
        self._client = self._cluster_obj = None
