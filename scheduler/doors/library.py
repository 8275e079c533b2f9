"""hertzmap as a library: what ``import hertzmap`` offers, the command line's ways in as Python
functions (``hertzmap run`` -> :func:`run`, ``plot`` -> :func:`products` and :func:`plot`,
``basins`` -> :func:`basins`, ``scenes`` -> :func:`scene_paths`, ``fit`` -> :func:`fit`), and
the store opened as one xarray DataTree (:func:`open`).

Every function takes a study as a path, a shipped scene's name, TOML text or a dict, and a
store as a path. Bad input raises before anything is written: :class:`StudyError` (its
``field`` names the study file's key, the message the allowed range) or :class:`RefusedError`
(a store of another study, a bad option, a cluster that cannot start); the command line maps
the same exceptions to its exit code 2. A run interrupted (Ctrl-C, a notebook's interrupt, a
killed kernel) resumes when :func:`run` is called again with the same study and store.
"""
from __future__ import annotations

import sys
import warnings
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, TextIO

import xarray as xr

from hertzmap.scheduler.errors import RefusedError, StoreError
from hertzmap.study.identify.measurement import FitInputError
from hertzmap.study.spec import Study, StudyError

__all__ = ["run", "open", "load_study", "scene_paths", "products", "plot", "basins", "fit",
           "Study", "StudyError", "RefusedError", "FitInputError", "IncompleteRun"]


class IncompleteRun(UserWarning):
    """A run ended with tasks that failed (each recorded in the store's history): the store
    holds the rest; calling :func:`run` again retries them."""


def load_study(study: str | Path | Mapping | Study) -> Study:
    """The validated study of ``study``: a study file's path, a shipped scene's name
    (``"default"``; :func:`scene_paths` lists them), the TOML text of a study file (a string with a
    newline), a dict of its tables (``{"grid": {"omega": [1.9, 2.0], ...}}``), or a
    :class:`Study` (returned as it is). Raises :class:`StudyError` naming the field."""
    from hertzmap.study.scenes import load_scene_or_file
    from hertzmap.study.spec import parse_study, study_from_dict

    if isinstance(study, Study):
        return study
    if isinstance(study, Mapping):
        return study_from_dict(dict(study), default_name="study")
    if isinstance(study, str) and "\n" in study:
        return parse_study(study, default_name="study")
    if isinstance(study, (str, Path)):
        return load_scene_or_file(study)
    raise StudyError("study", "give a study file's path, a scene's name, TOML text or a dict, "
                     f"got {type(study).__name__}")


def scene_paths() -> dict[str, Path]:
    """The shipped scenes (name -> study file), as ``hertzmap scenes`` lists them;
    ``run(name)`` runs one. (``hertzmap.scenes`` is the package that holds them.)"""
    from hertzmap.study.scenes import scene_paths as paths

    return paths()


def open(store: str | Path) -> xr.DataTree:
    """The store as one xarray DataTree, lazily (dask arrays): the root holds the grid's
    variables (one dimension per swept parameter), each product a group ``products/<name>``
    (docs/dataset.md). A store of another layout than this version writes is refused
    (:class:`StoreError`, naming its format and what to do), and so is a product group an
    earlier version wrote on dims that no longer align with the root (it names the group and
    the command that writes it again)."""
    from hertzmap.scheduler.store import store_attrs
    from hertzmap.study.products.results import quiet

    path = Path(store)
    store_attrs(path)
    with quiet():
        try:
            return xr.open_datatree(str(path), engine="zarr", chunks={})
        except ValueError as exc:
            if "not aligned" not in str(exc):
                raise
            group = str(exc).split("'")[1] if "'" in str(exc) else "a product group"
            raise StoreError(
                f"{path}: {group} does not align with the store's grid (written by an earlier "
                f"version of hertzmap plot or basins): run `hertzmap plot {path}` (or the "
                f"basins command again) to rewrite it; the main group reads with "
                f"xr.open_zarr({str(path)!r})") from None


def run(study: str | Path | Mapping | Study, store: str | Path | None = None, *,
        client=None, workers: int | None = None, overwrite: bool = False,
        quiet: bool = False, out: TextIO | None = None) -> xr.DataTree:
    """Run (or resume) a study into a zarr store and return the store as a DataTree.

    ``study``: a path, a scene's name, TOML text or a dict (:func:`load_study`). ``store``:
    the zarr store's path (default ``results/<study name>.zarr``, as ``hertzmap run``).
    ``client``: a ``dask.distributed.Client`` of your own (a LocalCluster, a dask-jobqueue
    cluster, a remote scheduler): the run's tasks go to it and it stays open; its workers
    must reach the store's path. Without one, the run starts its own cluster as
    ``hertzmap run`` does (``workers`` local worker processes, default one per core; a small
    study runs in this process) and closes it. ``overwrite``: delete an existing store of
    the same path first (without it, a store of the same study resumes and one of another
    study is refused). ``quiet``: no summary lines (the progress line stays: on a terminal
    or in a notebook it is rewritten in place). ``out``: where the summary goes (stdout).

    Raises :class:`StudyError` / :class:`RefusedError` before anything is written. Failed
    tasks do not raise: the tree holds every block that was computed and an
    :class:`IncompleteRun` warning says how many failed; call ``run`` again to retry them.
    ``KeyboardInterrupt`` (a notebook's interrupt) keeps what was committed: call ``run``
    again to resume.
    """
    import io

    from hertzmap.scheduler.cluster.clusters import ClusterSpec
    from hertzmap.scheduler.run import RunOptions, cluster_for, default_store_path, run_study

    st = load_study(study)
    if client is not None:
        if workers is not None:
            raise RefusedError("workers: give either a client or workers (the number of "
                               "worker processes of the cluster run() starts), not both")
        spec = ClusterSpec(kind="address", address=getattr(client.scheduler, "address", None))
    else:
        spec = cluster_for(st, workers=workers)
    spec.check()
    path = Path(store) if store is not None else default_store_path(st)
    opts = RunOptions(store=path, cluster=spec, overwrite=overwrite,
                      command=f"hertzmap.run({_shown(study)}, {str(path)!r})")
    summary = run_study(st, opts, client=client,
                        out=io.StringIO() if quiet else (out or sys.stdout))
    failed = summary.get("failed") or []
    curves = summary.get("curves") or {}
    if failed or (curves and not curves.get("complete", True)):
        why = failed[0][1] if failed else "curves not all traced"
        warnings.warn(f"{path}: {len(failed)} task(s) failed ({why}); run() again retries "
                      "them", IncompleteRun, stacklevel=2)
    return open(path)


def _shown(study: Any) -> str:
    """The study argument in the store's history line: a path or name as given, else what
    it is."""
    if isinstance(study, (str, Path)) and "\n" not in str(study):
        return repr(str(study))
    return f"<{type(study).__name__}>"


def products(store: str | Path, which: Iterable[str] = ("auto",), *,
             write: bool = True) -> dict[str, xr.Dataset]:
    """The products of a store (``hertzmap plot`` without the figures): every product the
    registry says the store supports and the figures ``which`` draw need (docs/products.md),
    written into the store as ``products/<name>`` groups unless ``write`` is False, and
    returned with the run's own products (traced curves, thresholds) as Datasets."""
    from hertzmap.scheduler.stages.product_tasks import make_products

    return make_products(Path(store), list(which), write=write)


def plot(store: str | Path, which: Iterable[str] = ("auto",), *, out: str | Path = "results",
         zeta: float | None = None, write: bool = True) -> list[Path]:
    """The figures of a store as PNG files in ``out`` (``hertzmap plot``): the products are
    computed (and written, unless ``write`` is False) first. ``which``: the figures' names
    (``hertzmap plot --help`` lists them; ``auto``: what the products support); ``zeta``: the
    figures of that zeta only. Returns the PNG paths."""
    from hertzmap.scheduler.stages.product_tasks import make_products
    from hertzmap.study import plots
    from hertzmap.study import products as P

    which = list(which)
    if not (Path(store) / "zarr.json").is_file():
        raise StoreError(f"{store} is not a zarr store")
    ds = P.open_store(store)
    prods = make_products(Path(store), which, write=write, ds=ds)
    return plots.plot_results(ds, prods, Path(out), which,
                              prefix=ds.attrs.get("hertzmap_study_name") or Path(store).stem,
                              zeta=zeta)


def basins(store: str | Path, omega: float, sigma: float, zeta: float | None = None, *,
           grid: tuple[int, int] = (200, 200), q_range: tuple[float, float] | None = None,
           v_range: tuple[float, float] | None = None, client=None,
           workers: int | None = None, out: str | Path | None = None,
           method: str = "reuse") -> xr.Dataset:
    """The basin map of a store's grid point (``hertzmap basins``): the census's transients
    from a ``grid`` (cells along q, along dq/dtau) of initial states over ``q_range`` x
    ``v_range`` (default the census's box), labelled by the attractor each ends on, with the
    basin entropy. The point is the store's nearest grid point (``zeta`` may be left out
    when the store has one value). Runs on ``client`` (yours) or on a local cluster of
    ``workers`` processes; written into the store as a product group and drawn as a PNG in
    ``out`` (default the store's folder). ``method``: ``reuse`` (label reuse in tiles) or
    ``transients`` (one whole transient per state), as ``hertzmap basins --method``. Returns
    the map as a Dataset."""
    from hertzmap.scheduler.stages.basin_tasks import check_request, run_basins
    from hertzmap.scheduler.cluster.clusters import ClusterSpec
    from hertzmap.scheduler.store import read_product

    def text(pair, name):
        if pair is None:
            return None
        try:
            lo, hi = (float(x) for x in pair)
        except (TypeError, ValueError):
            raise RefusedError(f"{name}: give (low, high), got {pair!r}") from None
        return f"{lo!r},{hi!r}"

    try:
        nq, nv = (int(n) for n in grid)
    except (TypeError, ValueError):
        raise RefusedError(f"grid: give (cells along q, cells along dq/dtau), each 2..2000, "
                           f"got {grid!r}") from None
    req = check_request(store, omega, sigma, zeta, f"{nq}x{nv}", text(q_range, "q_range"),
                        text(v_range, "v_range"), method)
    spec = ClusterSpec(kind="local", workers=workers)
    if client is None:
        spec.check()
    result = run_basins(req, spec, Path(out) if out is not None else Path(store).resolve().parent,
                        client=client)
    return read_product(store, result["group"].removeprefix("products/"))


def fit(measured, rig, *, out: str | Path | None = None, name: str | None = None, client=None,
        workers: int | None = None, in_process: bool = False,
        quiet: bool = False) -> xr.Dataset:
    """f0, zeta and sigma (and n when the rig table asks) identified from measured stepped-sine
    sweeps, with 95 % profile-likelihood intervals (``hertzmap fit``, docs/identify.md).

    ``measured``: a CSV file's path (columns frequency_hz, direction, H1_N, H2_N, optional
    H1_2_N and phases), a netCDF file or zarr store of an xarray Dataset with the same
    variables, or such a Dataset. ``rig``: the rig table: a TOML file's path, its text or a
    dict of its tables (the preload N; f0 or m, E, nu, R; the excitation set point). The
    fit's tasks run on ``client`` (a Dask client of your own), else on a local cluster of
    ``workers`` processes (default one per core) that it starts and closes, or, with
    ``in_process``, in this process. ``out``: a folder for ``<name>_fit.nc`` and its figure
    ``<name>_fit.png`` (default: nothing written). ``quiet``: no progress lines.

    Returns the result as an xarray Dataset: the parameters (``estimate``, ``lower``,
    ``upper``, ``identified`` on dim ``parameter``), the noise model, each measured point
    beside the model (``model``, ``residual``, ``model_period``), the measured and model
    jumps (dim ``jump``), the model's sweeps at the estimate, the profiles. Bad input raises
    :class:`FitInputError` (naming the row and column, or the rig table's field) before
    anything is computed or written.
    """
    from hertzmap.scheduler.cluster.clusters import ClusterSpec
    from hertzmap.scheduler.stages.fit_tasks import run_fit

    if client is not None and (workers is not None or in_process):
        raise RefusedError("workers: give a client, workers or in_process, not two of them")
    spec = None
    if client is None and not in_process:
        spec = ClusterSpec(kind="local", workers=workers)
        spec.check()
    return run_fit(measured, rig, out=out, name=name, client=client, cluster=spec,
                   in_process=in_process,
                   report=(lambda line: None) if quiet else None)
