"""Numba's disk cache, keyed on the source of every kernel module.

numba invalidates a cached function when *its own* file changes, not when a function it calls
in another module does: after an edit of integrate.py, shooting.py's cached machine code would
still hold the old integrator, silently. Pointing the cache at a folder named after a hash of
every kernels/**/*.py (subpackages included: kernels/continuation/) makes any change to any
kernel a fresh cache, shared by every process (Dask workers included) that runs the same code.
NUMBA_CACHE_DIR, if set, is respected as a root.
"""
import hashlib
import os
import pathlib

import numba


def kernels_source_hash() -> str:
    h = hashlib.sha256()
    here = pathlib.Path(__file__).parent
    for path in sorted(here.rglob("*.py")):
        h.update(path.relative_to(here).as_posix().encode())
        h.update(path.read_bytes())
    h.update(numba.__version__.encode())
    return h.hexdigest()[:16]


def configure_cache_dir() -> str:
    root = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
        "hertzmap")
    path = os.path.join(root, "numba-" + kernels_source_hash())
    numba.config.CACHE_DIR = path
    return path
