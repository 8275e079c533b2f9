#!/usr/bin/env bash
# The test command of README.md: install, then run the whole test suite.
#
# Two test processes (pytest-xdist, -n 2): a test file is one unit of work, run in its order by
# one process, the longest files first (tests/parallel.py). Arguments go to pytest after these
# (`-n 0` runs everything in this one process; a test path runs only that).
#
# The tests' files (every tmp_path: --basetemp; and what their processes put in TMPDIR: Dask's
# scratch folders, the Slurm test's daemons and database) go to one new folder of this run, on
# /dev/shm where it is a tmpfs with room, else under $TMPDIR or /tmp. They are tens of
# thousands of small files, zarr stores mostly: on a disk that discards what is deleted,
# deleting them takes minutes. The folder is removed after a run that passed and kept after
# one that did not (its path is printed first, to stderr). (pytest's default, numbered folders
# in /tmp/pytest-of-USER shared with every other pytest run of the user, deletes the oldest of
# them at the end of each run.)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh test

shm_free_kb=$(df -Pk /dev/shm 2>/dev/null | awk 'NR == 2 {print $4}' || true)
if [ -d /dev/shm ] && [ -w /dev/shm ] && [ "${shm_free_kb:-0}" -ge $((4 * 1024 * 1024)) ]; then
    base=$(mktemp -d /dev/shm/hertzmap-tests.XXXXXX)
else
    base=$(mktemp -d "${TMPDIR:-/tmp}/hertzmap-tests.XXXXXX")
fi
mkdir "$base/tmp"
echo "test.sh: the tests' files are in $base (removed if every test passes)" >&2
code=0
start=$(date +%s)
# --durations=20: the slowest 20 tests and their times, printed at the end of the run
TMPDIR="$base/tmp" .venv/bin/python -m pytest -q -n 2 --dist loadgroup --durations=20 \
    --basetemp "$base/pytest" "$@" || code=$?
# the suite's budget (issue 50): 10 minutes of wall time on a 2-core machine, said when passed
wall=$(( $(date +%s) - start ))
if [ "$#" = 0 ] && [ "$wall" -gt 600 ]; then
    echo "test.sh: BUDGET: the suite took $wall s, past its 10-minute budget (600 s): see the slowest tests above" >&2
else
    echo "test.sh: the suite took $wall s (budget 600 s)" >&2
fi
if [ "$code" = 0 ] || [ "$code" = 5 ]; then
    rm -rf "$base"
fi
exit "$code"
