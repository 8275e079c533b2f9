"""Write the bytecode of the modules hertzmap's processes import, and of no others: called by
scripts/install.sh after the dependencies are installed.

    .venv/bin/python scripts/compile_bytecode.py client     (the CLI, the client, the plots)
    .venv/bin/python scripts/compile_bytecode.py worker     (a Dask worker and numba's compiler)

Each imports its side's modules with bytecode writing on, whatever PYTHONDONTWRITEBYTECODE
says, so that every later process (client, workers, plots, tests) loads them compiled instead
of compiling their source again; install.sh runs the two at once. Compiling the whole of
site-packages instead (uv's --compile-bytecode) took ~10 s on the project's 2-core VM, most of
it for modules no run imports (scipy's and pandas' tests and unused subpackages); this takes
about a third of it (BENCHMARKS.md, section 6). A module a run imports that is not covered
here is still compiled from source when imported, as before: only time is at stake.
"""
from __future__ import annotations

import compileall
import importlib
import sys
import sysconfig
from pathlib import Path

sys.dont_write_bytecode = False

#: What each side imports (those of the dependencies that only some code paths import are
#: listed by name; the rest follow from the project's own modules). Found by running the
#: default study and its plots with bytecode writing on after this script: none of the
#: dependencies' modules was left to compile but the few each process imports at startup.
MODULES = {
    "client": [
        "hertzmap.scheduler.doors.cli", "hertzmap.scheduler.cluster.clusters", "hertzmap.scheduler.stages.curve_tasks", "hertzmap.scheduler.doors.report",
        "hertzmap.scheduler.run", "hertzmap.scheduler.store", "hertzmap.study.plots", "hertzmap.study.products",
        "contourpy", "dask.array", "distributed.deploy.local", "distributed.diagnostics.websocket",
        "distributed.http.health", "distributed.http.prometheus", "distributed.http.scheduler.info",
        "distributed.http.scheduler.json", "distributed.http.scheduler.prometheus",
        "distributed.http.statics", "distributed.http.worker.prometheus",
        "distributed.protocol.numpy", "matplotlib.backends.backend_agg", "matplotlib.pyplot",
        "PIL.Image", "tornado.platform.asyncio", "xarray.computation.nanops",
        "hypothesis", "pytest",             # the test extras, when installed (scripts/test.sh)
    ],
    "worker": [
        "hertzmap.scheduler.stages.worker", "hertzmap.study.solve.block", "distributed.nanny", "distributed.worker",
        "numba", "scipy.ndimage", "scipy.optimize", "scipy.spatial",
    ],
}


def main(side: str) -> None:
    if side == "client":
        import matplotlib
        matplotlib.use("Agg")
    for name in MODULES[side]:
        try:
            importlib.import_module(name)
        except ImportError:         # not installed (extras), or moved in another version
            pass
    if side == "client":
        import PIL.Image
        PIL.Image.init()            # the image plugins, imported on the first save
        # what every interpreter imports at startup, before bytecode could be turned on here:
        # the .pth hooks of site-packages (setuptools' distutils shim, the editable finder)
        site = Path(sysconfig.get_paths()["purelib"])
        compileall.compile_dir(site, maxlevels=0, quiet=1)
        if (site / "_distutils_hack").is_dir():
            compileall.compile_dir(site / "_distutils_hack", quiet=1)
    else:
        # numba imports most of its compiler on the first compile: a throwaway function (not
        # cached, no hertzmap kernel) brings it in
        import numba
        numba.njit("float64(float64)")(lambda x: x + 1.0)


if __name__ == "__main__":
    main(sys.argv[1])
