"""``hertzmap explore STORE [--port P]``: the loss-of-contact map of a store as a local web page
(a Bokeh server) where a click gives the point's orbits, "sweep through this point" the
stepped-sine sweeps up and down omega or sigma through it (computed on a thread of this server,
or the store's products/sweeps), and "refine this window" recomputes the visible window on a
finer grid through the same job queue as ``hertzmap run``.

* ``state.py``: the stores shown (read while they are written), the refine job and the sweeps.
* ``page.py``: the page (one Bokeh document per browser tab).
* the data the page shows: ``study.explore_data`` (no server there).

docs/explore.md describes the panels, a cluster store through an ssh tunnel, and the limits.
"""
from __future__ import annotations

import errno
import importlib.util
import json
import signal
import socket
import sys
from functools import partial
from pathlib import Path

DEFAULT_PORT = 5006     # the command line's default (scheduler/doors/cli.py)
ADDRESS = "127.0.0.1"     # local only: reach a remote one through an ssh tunnel (docs/explore.md)
BOKEH_MIN = (3, 1)


def _error(msg: str) -> int:
    print(f"hertzmap: error: explore: {msg}", file=sys.stderr)
    return 2


def _port_in_use(port: int) -> str | None:
    """Why ``port`` cannot be served on ADDRESS, or None when it can (the socket is closed
    again at once; Bokeh binds it a moment later)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((ADDRESS, port))
        except OSError as exc:
            return exc.strerror or str(exc)
    return None


def _is_hertzmap_store(path: Path) -> bool:
    """A zarr group with a hertzmap study hash in its attrs (read with json alone: bad input
    is answered before the numerical stack is imported)."""
    try:
        doc = json.loads((path / "zarr.json").read_text())
    except (OSError, ValueError):
        return False
    return (isinstance(doc, dict) and doc.get("node_type") == "group"
            and "hertzmap_study_hash" in (doc.get("attributes") or {}))


def explore_command(args) -> int:
    """``hertzmap explore``: returns the exit code (0 on Ctrl-C or SIGTERM; 2 on bad input,
    with nothing started or written)."""
    store: Path = args.store
    if not store.exists():
        return _error(f"{store}: no such store (give the path of a store written by hertzmap run)")
    if not _is_hertzmap_store(store):
        what = "a zarr store not written by hertzmap" if (store / "zarr.json").is_file() else \
            "not a zarr store (no zarr.json)"
        return _error(f"{store} is {what}; give a store written by hertzmap run")
    if not 1 <= args.port <= 65535:
        return _error(f"--port must be in 1..65535, got {args.port}")
    if args.max_refine_points is not None and args.max_refine_points < 4:
        return _error(f"--max-refine-points must be >= 4, got {args.max_refine_points}")
    if importlib.util.find_spec("bokeh") is None:
        return _error("the page needs bokeh (a dependency of hertzmap): pip install 'bokeh>=3.1'")
    import bokeh
    if tuple(int(x) for x in bokeh.__version__.split(".")[:2]) < BOKEH_MIN:
        return _error(f"the page needs bokeh >= {'.'.join(map(str, BOKEH_MIN))}, found "
                      f"{bokeh.__version__}: pip install 'bokeh>=3.1'")
    why = _port_in_use(args.port)
    if why:
        return _error(f"port {args.port} is in use on {ADDRESS} ({why}); choose another with "
                      "--port")

    from hertzmap.scheduler.cluster.clusters import ClusterError, ClusterSpec
    spec = (ClusterSpec(kind="address", address=args.scheduler) if args.scheduler else
            ClusterSpec(kind="local", workers=args.workers))
    try:
        spec.check()
    except ClusterError as exc:
        return _error(str(exc))

    from hertzmap.scheduler.doors.explore.state import ExploreState
    from hertzmap.study import explore_data as E
    state = ExploreState(base=store.resolve(), cluster=spec,
                         max_refine_points=args.max_refine_points or E.MAX_REFINE_POINTS)
    try:
        # read once before serving: a store that cannot be read fails here, not in the page
        state.view(state.base)
    except Exception as exc:
        return _error(f"cannot read {store}: {type(exc).__name__}: {exc}")

    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler
    from bokeh.server.server import Server

    from hertzmap.scheduler.doors.explore.page import make_document

    try:
        server = Server({"/": Application(FunctionHandler(partial(make_document, state=state)))},
                        port=args.port, address=ADDRESS, num_procs=1,
                        allow_websocket_origin=[f"localhost:{args.port}",
                                                f"127.0.0.1:{args.port}"])
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            return _error(f"port {args.port} is in use on {ADDRESS}; choose another with --port")
        return _error(f"cannot serve on {ADDRESS}:{args.port}: {exc}")
    server.start()
    loop = server.io_loop
    # Ctrl-C and SIGTERM stop the server cleanly (exit 0, no traceback), cluster closed
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.asyncio_loop.add_signal_handler(sig, loop.stop)
    print(f"hertzmap explore: {store} at http://localhost:{args.port}/  (Ctrl-C to stop)",
          flush=True)
    try:
        loop.start()
    finally:
        job = state.job
        if job is not None and job.state in ("starting", "running"):
            print(f"hertzmap explore: stopped during the refine into {job.store}: refine the "
                  "same window again (or hertzmap run its study file) to resume it",
                  file=sys.stderr, flush=True)
        state.close()
        server.stop()
    return 0
