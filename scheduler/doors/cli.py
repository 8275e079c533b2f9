"""The ``hertzmap`` command line: ``run``, ``scenes``, ``status``, ``plot``, ``basins``,
``fit``, ``bench``, ``explore``. The only place that parses arguments.

Subcommands register themselves in :data:`SUBCOMMANDS` (name -> (add_arguments, handler)),
so ``plot``, ``bench``... can be added without touching the others.

Exit codes: 0 success; 1 the run finished with failed tasks (rerun to retry them) or an
unexpected error; 2 invalid study file, options or store (nothing created or changed);
130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Callable

from hertzmap.scheduler.defaults import DEFAULT_TASK_SECONDS, DEFAULT_TASK_TIMEOUT, ERROR_SAMPLE

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130

SUBCOMMANDS: dict[str, tuple[Callable[[argparse.ArgumentParser], None],
                             Callable[[argparse.Namespace], int], str]] = {}


def subcommand(name: str, help: str):
    def register(add_arguments):
        def with_handler(handler):
            SUBCOMMANDS[name] = (add_arguments, handler, help)
            return handler
        return with_handler
    return register


def _error(msg: str) -> int:
    print(f"hertzmap: error: {msg}", file=sys.stderr)
    return EXIT_USAGE


# -- run --------------------------------------------------------------------------------------

def _run_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("study", type=Path, help="study file (TOML, docs/study-file.md) or the name "
                   "of a shipped scene (hertzmap scenes lists them)")
    p.add_argument("--store", type=Path, default=None,
                   help="zarr store path (default: results/<study name>.zarr)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="connect to an existing Dask scheduler (e.g. tcp://host:8786)")
    where.add_argument("--cluster", choices=["local", "slurm", "pbs", "sge", "lsf", "htcondor"],
                       default=None, help="local: embedded LocalCluster (the default, except "
                       "that a small study runs in-process unless --cluster or --workers is "
                       "given); others: dask-jobqueue (pip install 'hertzmap[jobqueue]')")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="worker processes (local: default one per core; jobqueue: processes "
                   "to scale to; --scheduler: wait for N workers before starting)")
    p.add_argument("--cluster-option", action="append", default=[], metavar="KEY=VALUE",
                   help="keyword for the dask-jobqueue cluster class, repeatable "
                   "(e.g. queue=normal cores=32 memory=64GB walltime=02:00:00 "
                   "'job_extra_directives=[\"--exclusive\"]')")
    p.add_argument("--dry-run", action="store_true",
                   help="print grid size, task count, store size and where it would run; write nothing")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a store that holds another study")
    p.add_argument("--task-seconds", type=float, default=None, metavar="S",
                   help="target duration of one task when creating a store (default "
                   f"{DEFAULT_TASK_SECONDS:g})")
    p.add_argument("--task-timeout", type=float, default=None, metavar="S",
                   help=f"wall-clock budget of one task (default {DEFAULT_TASK_TIMEOUT:g}): grid "
                   "points a task has "
                   "not reached by then are stored with status time_limit and the study goes on")
    p.add_argument("--error-sample", type=int, default=None, metavar="N",
                   help="converged orbits re-solved at rtol/1000 for the error estimate "
                   f"(default {ERROR_SAMPLE}; 0 to skip)")
    # developer hook: another block solver with the same contract (module:function)
    p.add_argument("--solver", default=None, help=argparse.SUPPRESS)
    # developer hook: another curve tracer with trace_seed's contract (module:function)
    p.add_argument("--curve-tracer", default=None, help=argparse.SUPPRESS)
    # developer hook: another atlas tile function with study.solve.atlas.atlas_tile's contract
    p.add_argument("--atlas-tile", default=None, help=argparse.SUPPRESS)
    # developer hook: the grid without the atlas (benchmarks/map_completeness.py's "before")
    p.add_argument("--skip-atlas", action="store_true", help=argparse.SUPPRESS)


def run_command_line(args: argparse.Namespace) -> str:
    """The command that resumes this run: the words the user typed, shell-quoted, without
    ``--overwrite`` (rerunning with it would start the study again instead of resuming)."""
    import shlex

    words = [w for w in args.argv if w != "--overwrite"]
    return "hertzmap " + shlex.join(words)


@subcommand("run", "run (or resume) a study into a zarr store")(_run_args)
def cmd_run(args: argparse.Namespace) -> int:
    from hertzmap.study.scenes import load_scene_or_file
    from hertzmap.study.spec import StudyError

    try:
        study = load_scene_or_file(args.study)
    except StudyError as exc:
        return _error(f"{args.study}: {exc}")

    from hertzmap.scheduler.cluster.clusters import parse_cluster_options
    from hertzmap.scheduler.doors.dry_run import describe
    from hertzmap.scheduler.errors import ClusterError, RefusedError
    from hertzmap.scheduler.run import RunOptions, cluster_for, default_store_path, run_study
    from hertzmap.scheduler.stages.worker import DEFAULT_SOLVER

    try:
        spec = cluster_for(study, scheduler=args.scheduler, cluster=args.cluster,
                           workers=args.workers,
                           options=parse_cluster_options(args.cluster_option))
    except ClusterError as exc:
        return _error(str(exc))
    if args.task_seconds is not None and not 0 < args.task_seconds < float("inf"):
        return _error(f"--task-seconds must be > 0 and finite, got {args.task_seconds}")
    if args.task_timeout is not None and not 0 < args.task_timeout < float("inf"):
        return _error(f"--task-timeout must be > 0 and finite, got {args.task_timeout}")
    if args.error_sample is not None and args.error_sample < 0:
        return _error(f"--error-sample must be >= 0, got {args.error_sample}")

    opts = RunOptions(
        store=args.store or default_store_path(study),
        cluster=spec,
        overwrite=args.overwrite,
        solver=args.solver or DEFAULT_SOLVER,
        task_seconds=args.task_seconds or DEFAULT_TASK_SECONDS,
        task_timeout=args.task_timeout or DEFAULT_TASK_TIMEOUT,
        error_sample=ERROR_SAMPLE if args.error_sample is None else args.error_sample,
        command=run_command_line(args),
    )
    if args.curve_tracer:
        opts.curve_tracer = args.curve_tracer
    if args.atlas_tile:
        opts.atlas_tile = args.atlas_tile
    opts.atlas = not args.skip_atlas
    try:
        if args.dry_run:
            print(describe(study, opts.store, opts.task_seconds, opts.cluster))
            print("dry run: nothing written")
            return EXIT_OK
        summary = run_study(study, opts)
    except RefusedError as exc:
        return _error(str(exc))
    except KeyboardInterrupt as exc:
        if not getattr(exc, "reported", False):
            print(f"\nhertzmap: interrupted; to resume, run again: {opts.command}",
                  file=sys.stderr)
        return EXIT_INTERRUPTED
    curves_failed = bool(summary.get("curves")) and not summary["curves"].get("complete")
    return EXIT_OK if not summary["failed"] and not curves_failed else EXIT_FAILED


# -- scenes -----------------------------------------------------------------------------------

def _scenes_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--path", action="store_true", help="print each scene's file path too")


@subcommand("scenes", "the study files shipped with hertzmap (hertzmap run NAME runs one)")(
    _scenes_args)
def cmd_scenes(args: argparse.Namespace) -> int:
    from hertzmap.study.scenes import scene_paths
    from hertzmap.study.spec import StudyError, load_study

    for name, path in scene_paths().items():
        try:
            about = load_study(path).description
        except StudyError as exc:       # a shipped scene is tested valid; say so if not
            about = f"(invalid: {exc})"
        print(f"{name:20s} {about}" + (f"\n{'':20s} {path}" if args.path else ""))
    return EXIT_OK


# -- status -----------------------------------------------------------------------------------

def _status_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("store", type=Path, help="a store written by hertzmap run")
    p.add_argument("--json", action="store_true", help="print the status as JSON")
    p.add_argument("--check", action="store_true", help="also read every chunk of the tasks "
                   "flagged done; exit 1 if any is missing or unreadable (rerun to repair)")


def _upgrade_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("store", type=Path, help="a store written by an older hertzmap (format 2)")


@subcommand("upgrade", "rewrite a store of an older format in place, without recomputing")(
    _upgrade_args)
def cmd_upgrade(args: argparse.Namespace) -> int:
    from hertzmap.scheduler.errors import StoreError
    from hertzmap.scheduler.store.upgrade import upgrade_store

    try:
        done = upgrade_store(args.store)
    except StoreError as exc:
        return _error(str(exc))
    if done["from"] == done["to"]:
        print(f"{args.store}: already in store format {done['to']}, nothing to do")
    else:
        print(f"{args.store}: store format {done['from']} -> {done['to']}, "
              f"{done['files_before']} -> {done['files_after']} files, nothing recomputed")
    return EXIT_OK


@subcommand("status", "tasks done/total, study name and hash, versions of a store")(_status_args)
def cmd_status(args: argparse.Namespace) -> int:
    from hertzmap.scheduler.errors import StoreError
    from hertzmap.scheduler.store import store_status

    try:
        info = store_status(args.store, check=args.check)
    except (StoreError, KeyError, FileNotFoundError) as exc:
        return _error(str(exc))
    damaged = info.get("damaged") or {}
    rc = EXIT_FAILED if damaged else EXIT_OK
    if args.json:
        print(json.dumps(info, indent=2, default=str))
        return rc
    total, done = info["tasks_total"], info["tasks_done"]
    state = "complete" if done == total else ("in progress (locked)" if info["locked_by"]
                                              else "incomplete: rerun hertzmap run to resume")
    dims = " x ".join(f"{info['dims'][d]} {d}" for d in ("omega", "sigma", "zeta", "solution",
                                                          "attractor") if d in info["dims"])
    print(f"store     {info['path']}")
    if info.get("format_note"):
        print(f"format    {info['format_note']}")
    print(f"study     {info['hertzmap_study_name']} (hash {info['hertzmap_study_hash']})")
    print(f"tasks     {done}/{total} done ({100 * done / max(1, total):.1f} %), {state}")
    print(f"grid      {dims}; chunk {info['chunk_shape']}")
    print(f"variables {', '.join(info['variables'])}")
    c = info.get("contents")
    if c:
        print(f"orbits    {c['orbits']} converged"
              + (f" ({c['stable_orbits']} stable, {c['orbits'] - c['stable_orbits']} unstable)"
                 if "stable_orbits" in c else "")
              + f", at most {c['most_orbits_at_a_point']} at a point, every one stored")
        if "attractors" in c:
            print("attractors " + ", ".join(f"{n} {k.replace('_', '-')}"
                                            for k, n in c["attractors"].items())
                  + f" (census), at most {c['most_attractors_at_a_point']} at a point")
    print("versions  " + ", ".join(f"{k} {v}" for k, v in sorted(info["versions"].items())))
    if info["locked_by"]:
        print(f"lock      held by host {info['locked_by'].get('host')} pid {info['locked_by'].get('pid')}")
    print("history   " + (info.get("history") or "").replace("\n", "\n          "))
    if args.check:
        print(f"check     {len(damaged)} damaged task(s)" + (
            "; rerun hertzmap run to recompute them: " + "; ".join(
                f"{k}: {', '.join(v)}" for k, v in list(damaged.items())[:5]) if damaged else ": ok"))
    return rc


# -- plot -------------------------------------------------------------------------------------

def _plot_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("store", type=Path, nargs="?", help="a store written by hertzmap run")
    p.add_argument("--out", type=Path, default=Path("results"), help="folder for the PNGs (default results/)")
    from hertzmap.study.plots import which_help

    p.add_argument("--which", nargs="+", default=["auto"], metavar="FIG", help=which_help())
    p.add_argument("--zeta", type=float, default=None, metavar="Z",
                   help="draw the figures of this zeta only (the store's nearest value; by "
                   "default the maps and the other per-zeta figures of every zeta)")
    p.add_argument("--paper", nargs="+", default=[], metavar="FIG",
                   help="the paper's analytic figures, no store needed: fig02 fig03 fig04 fig05")
    p.add_argument("--no-products", action="store_true",
                   help="read-only: write nothing into the store; the products are computed in "
                   "memory and the figures drawn from them (without it, from the products as "
                   "stored)")


@subcommand("plot", "products of a store into its products/ groups, and PNG figures")(_plot_args)
def cmd_plot(args: argparse.Namespace) -> int:
    """The products of a store, then its figures: compute every product that the registry
    (study.products.catalog) says the store supports, write them into its products/ groups
    (scheduler.store), read them back and draw the figures from the stored groups (study.plots),
    with the groups hertzmap run wrote (the traced curves). With --no-products nothing is
    written and the figures are drawn from the products in memory."""
    from hertzmap.scheduler.errors import StoreError
    from hertzmap.scheduler.doors.library import plot
    from hertzmap.scheduler.store import list_products
    from hertzmap.study import plots

    if args.store is None and not args.paper:
        return _error("plot: give a STORE or --paper FIG ...")
    try:
        paths = plots.plot_paper(args.paper, args.out) if args.paper else []
        if args.store is not None:
            paths += plot(args.store, args.which, out=args.out, zeta=args.zeta,
                          write=not args.no_products)
    except (ValueError, KeyError, FileNotFoundError, StoreError) as exc:
        return _error(f"plot: {exc}")
    for p in paths:
        print(p)
    if args.store is not None and not args.no_products:
        print(f"products: {', '.join(list_products(args.store))} in {args.store}/products/")
    return EXIT_OK


# -- basins -----------------------------------------------------------------------------------

def _basins_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("store", type=Path, help="a store written by hertzmap run")
    p.add_argument("--omega", type=float, required=True, metavar="W",
                   help="omega of the point: the store's nearest grid value is taken; it must "
                   "lie within the store's omega axis")
    p.add_argument("--sigma", type=float, required=True, metavar="S",
                   help="sigma of the point (the nearest grid value, within the axis)")
    p.add_argument("--zeta", type=float, default=None, metavar="Z",
                   help="zeta of the point (the nearest grid value; needed when the store has "
                   "more than one)")
    p.add_argument("--grid", default="200x200", metavar="NQxNV",
                   help="cells of the grid of initial states along q and along dq/dtau, each "
                   "2..2000 (default 200x200)")
    p.add_argument("--q-range", default=None, metavar="LO,HI",
                   help="initial displacements q at tau = 0 (default -6,4: the census's box)")
    p.add_argument("--v-range", default=None, metavar="LO,HI",
                   help="initial velocities dq/dtau at tau = 0 (default -5,5)")
    p.add_argument("--out", type=Path, default=None,
                   help="folder for the PNG (default: the store's folder)")
    p.add_argument("--method", default="reuse", choices=("reuse", "transients"),
                   help="reuse (default): transients that stop where earlier ones tell their "
                   "fate, in tiles (1000x1000 in about a minute on 2 cores); transients: one "
                   "whole census transient per state (the brute force)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="run on an existing Dask scheduler (e.g. tcp://host:8786)")
    where.add_argument("--workers", type=int, default=None, metavar="N",
                       help="worker processes of the embedded local cluster (default one per "
                       "core)")


@subcommand("basins", "the basin map of a store's grid point on a grid of initial states, "
            "with its basin entropy, as a product group and a PNG")(_basins_args)
def cmd_basins(args: argparse.Namespace) -> int:
    """The attractor of every cell of the grid of initial states at the grid point, computed in
    tiles on the cluster (scheduler.stages.basin_tasks); the map is written into the store as
    products/basin_map_omega<w>_sigma<s>_zeta<z> and drawn next to the store."""
    from hertzmap.scheduler.stages.basin_tasks import check_request, run_basins
    from hertzmap.scheduler.cluster.clusters import ClusterError, ClusterSpec
    from hertzmap.scheduler.errors import RefusedError

    try:
        req = check_request(args.store, args.omega, args.sigma, args.zeta, args.grid,
                            args.q_range, args.v_range, args.method)
        spec = (ClusterSpec(kind="address", address=args.scheduler) if args.scheduler
                else ClusterSpec(kind="local", workers=args.workers))
        spec.check()
        result = run_basins(req, spec, args.out or Path(args.store).resolve().parent)
    except (RefusedError, ClusterError) as exc:
        return _error(f"basins: {exc}")
    except KeyboardInterrupt:
        print("\nhertzmap: interrupted; nothing written", file=sys.stderr)
        return EXIT_INTERRUPTED
    print(f"basin map at omega = {req.point[0]:g}, sigma = {req.point[1]:g}, zeta = "
          f"{req.point[2]:g} on {req.grid[0]}x{req.grid[1]} initial states: "
          f"{result['seconds']:.1f} s ({result['map_seconds']:.1f} s after the cluster's "
          f"start; {req.method})")
    for kind, period, count in result["attractors"]:
        print(f"  {kind}{f' {period}T' if period else ''}: {count} cells")
    ds = result["dataset"]
    print(f"  S_b = {result['basin_entropy']:.4f} +- {float(ds.basin_entropy_error):.4f} nats, "
          f"S_bb = {result['boundary_basin_entropy']:.4f} +- "
          f"{float(ds.boundary_basin_entropy_error):.4f} nats, uncertainty fraction "
          f"{result['uncertainty_fraction']:.4f}")
    print(f"  uncertainty exponent alpha = {float(ds.uncertainty_exponent):.3f} +- "
          f"{float(ds.uncertainty_exponent_error):.3f}: boundary dimension d = "
          f"{float(ds.boundary_dimension):.3f}; Wada (merging, r = {ds.attrs['wada_dilation']} "
          f"cells): {'yes' if int(ds.wada) else 'no'} (largest distance "
          f"{float(ds.wada_hausdorff_max):.1f} cells, Wada cells "
          f"{100 * float(ds.wada_share):.1f} %)")
    if ds.attrs.get("method") == "reuse":
        print(f"  states: {ds.attrs['cells_seed']} in a certified neighbourhood, "
              f"{ds.attrs['cells_reused']} by label reuse, {ds.attrs['cells_census']} by the "
              f"census's whole transient")
    print(f"{result['figure']}\nproduct: {result['group']} in {args.store}")
    return EXIT_OK


# -- fit (scheduler/stages/fit_tasks.py) ---------------------------------------------------------------

def _fit_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("measured", type=Path,
                   help="the measured sweeps: a CSV file (columns frequency_hz, direction "
                   "up/down, H1_N, H2_N, optional H1_2_N and phases; # comments), or a netCDF "
                   "file or zarr store of an xarray Dataset with the same variables")
    p.add_argument("--rig", type=Path, required=True, metavar="RIG.toml",
                   help="the rig table: [rig] N (the preload, N) and f0 or m, E, nu, R; "
                   "[excitation] force_N or sigma (docs/identify.md)")
    p.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help="folder for NAME_fit.nc (the result) and NAME_fit.png (its figure); "
                   "default: print the result, write nothing")
    p.add_argument("--name", default=None,
                   help="the files' stem (default: the measurement file's)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="run the fit's tasks on an existing Dask scheduler "
                       "(e.g. tcp://host:8786)")
    where.add_argument("--workers", type=int, default=None, metavar="N",
                       help="worker processes of the embedded local cluster (default one "
                       "per core)")
    where.add_argument("--in-process", action="store_true",
                       help="run the tasks in this process, no Dask (a small measurement, "
                       "debugging)")


@subcommand("fit", "identify f0, zeta and sigma from measured stepped-sine sweeps, with 95 % "
            "profile-likelihood intervals")(_fit_args)
def cmd_fit(args: argparse.Namespace) -> int:
    """Read and check the measurement and the rig table (a bad row, column or field: exit 2,
    nothing written), run the fit on the cluster (scheduler.stages.fit_tasks), print the parameters
    with their intervals, and with --out write the result and its figure."""
    from hertzmap.scheduler.cluster.clusters import ClusterError, ClusterSpec
    from hertzmap.scheduler.errors import RefusedError
    from hertzmap.scheduler.stages.fit_tasks import run_fit
    from hertzmap.study.identify.measurement import FitInputError

    try:
        spec = (ClusterSpec(kind="address", address=args.scheduler) if args.scheduler
                else ClusterSpec(kind="local", workers=args.workers))
        if not args.in_process:
            spec.check()
        run_fit(args.measured, args.rig, out=args.out, name=args.name, cluster=spec,
                in_process=args.in_process)
    except FitInputError as exc:
        return _error(f"fit: {exc}")
    except (RefusedError, ClusterError) as exc:
        return _error(f"fit: {exc}")
    except KeyboardInterrupt:
        print("\nhertzmap: interrupted; nothing written", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_OK


# -- bench (benchmarks/work_precision.py) -------------------------------------------------------

def _bench_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=Path, default=Path("results"), help="folder for bench.csv and bench.png")
    p.add_argument("--quick", action="store_true", help="fewer tolerances and repeats (< 2 min)")


@subcommand("bench", "work-precision benchmark: hertzmap vs the paper's scheme vs scipy")(_bench_args)
def cmd_bench(args: argparse.Namespace) -> int:
    """Runs the benchmark harness (benchmarks/work_precision.py) as its own process: the
    benchmarks stand above the packages and are not imported by them."""
    import subprocess

    if not Path("benchmarks/work_precision.py").is_file():
        return _error("bench runs benchmarks/work_precision.py of a hertzmap checkout, which the "
                      "installed package does not hold: run it from the repository's folder")
    cmd = [sys.executable, "-m", "benchmarks.work_precision", "--out", str(args.out)]
    if args.quick:
        cmd.append("--quick")
    return subprocess.call(cmd)


# -- explore (scheduler/doors/explore/) --------------------------------------------------------------

def _explore_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("store", type=Path, help="a store written by hertzmap run (it may still be "
                   "being written: the page follows it)")
    p.add_argument("--port", type=int, default=5006,
                   help="port of the page, http://localhost:PORT/ (default 5006)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="run refines on this Dask scheduler (e.g. the one that computed the "
                       "store, tcp://host:8786) instead of an embedded local cluster")
    where.add_argument("--workers", type=int, default=None, metavar="N",
                       help="worker processes of the embedded local cluster that runs refines "
                       "(default one per core; started at the first refine)")
    p.add_argument("--max-refine-points", type=int, default=None, metavar="N",
                   help="most grid points one refine may compute (default 20000)")


@subcommand("explore", "the map of a store in the browser: click a point for its orbits, "
            "refine a window")(_explore_args)
def cmd_explore(args: argparse.Namespace) -> int:
    from hertzmap.scheduler.doors.explore import explore_command
    return explore_command(args)


# -- entry point ------------------------------------------------------------------------------

def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hertzmap",
        description="Periodic responses of a preloaded Hertzian contact over parameter grids.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (add_arguments, handler, help) in SUBCOMMANDS.items():
        # argparse formats a subcommand's help with %: a literal "95 %" would raise
        p = sub.add_parser(name, help=help.replace("%", "%%"), description=help)
        add_arguments(p)
        p.set_defaults(handler=handler)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)      # usage errors exit with code 2 (argparse)
    args.argv = argv
    try:
        return args.handler(args)
    except BrokenPipeError:         # `hertzmap scenes | head`: the reader is gone, not an error
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
