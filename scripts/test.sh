#!/usr/bin/env bash
# The test command of README.md: install, then run the whole test suite.
#
# Two test processes (pytest-xdist, -n 2): a test file is one unit of work, run in its order by
# one process, the longest files first (tests/parallel.py). Arguments go to pytest after these
# (`-n 0` runs everything in this one process; a test path runs only that).
#
# Every test's tmp_path is under one new folder (--basetemp), on /dev/shm where it is a tmpfs
# with room (the stores of the suite are tens of thousands of small files: on a disk, making
# and deleting them costs minutes), else under $TMPDIR; it is removed after a run that passed
# and kept after one that did not (its path is printed first, to stderr). (pytest's default, a numbered
# folder in /tmp/pytest-of-USER shared with every other pytest run of the user, would also
# delete older runs' folders at the end of this one.)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh test

shm_free_kb=$(df -Pk /dev/shm 2>/dev/null | awk 'NR == 2 {print $4}' || true)
if [ -d /dev/shm ] && [ -w /dev/shm ] && [ "${shm_free_kb:-0}" -ge $((4 * 1024 * 1024)) ]; then
    base=$(mktemp -d /dev/shm/hertzmap-tests.XXXXXX)
else
    base=$(mktemp -d "${TMPDIR:-/tmp}/hertzmap-tests.XXXXXX")
fi
echo "test.sh: the tests' folders are in $base (removed if every test passes)" >&2
code=0
.venv/bin/python -m pytest -q -n 2 --dist loadgroup --basetemp "$base" "$@" || code=$?
if [ "$code" = 0 ] || [ "$code" = 5 ]; then
    rm -rf "$base"
fi
exit "$code"
