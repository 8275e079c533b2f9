#!/usr/bin/env bash
# Create .venv (if needed) and install hertzmap into it, editable, with the exact versions of
# uv.lock: `install.sh` for running studies, `install.sh test` with the test extras
# (scripts/test.sh). The lock moves forward with `bash scripts/lock.sh` (docs/running.md).
#
# uv installs from the lock (`uv sync --locked`: it refuses a lock that no longer matches
# pyproject.toml, so a dependency changed without relocking stops here, not in a test). uv
# itself is the version scripts/uv.sh names, installed into the venv by its pip. The bytecode of the modules a run imports is
# written at install (scripts/compile_bytecode.py, two processes at once): without it every
# process of a run (the client, each worker, the plots) compiles the source of every module
# it imports whenever Python may not write bytecode. Stamps in .venv record what was
# installed: a second run with the same pyproject.toml and uv.lock skips the install when the
# extras asked for are in (the install is editable: source changes need no reinstall).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
EXTRAS=${1:-}
UV=$(PYTHON="$PY" bash scripts/uv.sh)
STATE="$(cat pyproject.toml uv.lock)"
for stamp in ".venv/.hertzmap-installed-${EXTRAS:-base}" .venv/.hertzmap-installed-test; do
    if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$STATE" ]; then
        exit 0
    fi
    [ -z "$EXTRAS" ] || break       # only the test extras satisfy `install.sh test`
done
# --inexact: keep what the venv has beyond the lock (uv itself, pip);
# no Python download: the venv's interpreter is the one
UV_PYTHON_DOWNLOADS=never UV_PROJECT_ENVIRONMENT=.venv \
    "$UV" sync --locked --inexact --quiet ${EXTRAS:+--extra "$EXTRAS"}
# a failure here costs time only (modules then compile from source): warn, go on
.venv/bin/python scripts/compile_bytecode.py client &
client=$!
.venv/bin/python scripts/compile_bytecode.py worker \
    || echo "install: writing the workers' bytecode failed (runs are slower, not wrong)" >&2
wait "$client" \
    || echo "install: writing the client's bytecode failed (runs are slower, not wrong)" >&2
printf '%s' "$STATE" > ".venv/.hertzmap-installed-${EXTRAS:-base}"
