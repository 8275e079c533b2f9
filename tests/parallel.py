"""How the suite is spread over processes (pytest-xdist; scripts/test.sh runs ``-n 2 --dist
loadgroup``): which tests must share a process, and which go first.

* **Groups.** A test file is one unit of work, run in its order by one process: its module
  fixtures (a reference store, a Slurm cluster, a browser) are made once, and files whose
  tests build on each other (tests/docs/test_docs.py runs the docs' commands in order in one
  workspace) keep their order. An explicit ``xdist_group`` mark still groups as xdist does.
* **Order.** Units are handed out in the order of :data:`SECONDS`, longest first (the longest
  processing time rule: the last unit to start is a short one, so both processes end close
  together); the others follow in collection order. The figures are a rough guide, not a
  contract: a file missing from them only starts later.

Without ``-n`` nothing here applies: the suite runs in collection order in one process.
"""
from __future__ import annotations

#: seconds per test file in a full run with two processes (tests that share a file share a
#: process), the longest first; measured on a 2-core machine that other jobs kept busy: only
#: the proportions matter
SECONDS: dict[str, float] = {
    "tests/docs/test_docs.py": 523,
    "tests/kernels/continuation/test_curve.py": 370,
    "tests/end_to_end/test_slurm.py": 330,
    "tests/end_to_end/test_atlas.py": 310,
    "tests/kernels/test_jit.py": 294,
    "tests/test_packaging.py": 229,
    "tests/end_to_end/test_traced_curves.py": 221,
    "tests/hardening/test_faults.py": 213,
    "tests/scheduler/test_run.py": 176,
    "tests/test_recipes.py": 132,
    "tests/end_to_end/test_explore.py": 129,
    "tests/end_to_end/test_located_bifurcations.py": 116,
    "tests/scheduler/test_store.py": 113,
    "tests/hardening/test_input.py": 85,
    "tests/scheduler/store/test_one_writer_per_shard.py": 70,
    "tests/end_to_end/test_map_hatching.py": 48,
    "tests/hardening/test_time_limit.py": 47,
    "tests/kernels/test_attractors.py": 47,
    "tests/study/test_plots.py": 43,
    "tests/scheduler/doors/test_cli.py": 40,
    "tests/benchmarks/test_work_precision.py": 32,
    "tests/test_architecture.py": 30,
    "tests/study/solve/test_thresholds.py": 25,
}


def unit_of(nodeid: str) -> str:
    """The unit of work of a test: its xdist_group (a ``@name`` suffix), else its file."""
    if nodeid.rfind("@") > nodeid.rfind("]"):
        return nodeid.rsplit("@", 1)[-1]
    return nodeid.split("::", 1)[0]


def rank(nodeid: str) -> tuple[int, float]:
    """Sort key of a test: the units of SECONDS first, longest first (stable otherwise)."""
    seconds = SECONDS.get(unit_of(nodeid))
    return (1, 0.0) if seconds is None else (0, -seconds)


def make_scheduler(config, log):
    """xdist's loadgroup scheduling with a file as the default group (instead of each test on
    its own), units in collection order (which :func:`rank` sorted)."""
    from xdist.scheduler import LoadScopeScheduling

    class FileGroupScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return unit_of(nodeid)

    # the collection order is the order wanted (rank): not xdist's reordering by test count
    config.option.loadscopereorder = False
    return FileGroupScheduling(config, log)
