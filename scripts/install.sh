#!/usr/bin/env bash
# Create .venv (if needed) and install hertzmap into it, editable: `install.sh` for running
# studies, `install.sh test` with the test extras (scripts/test.sh).
#
# --no-compile: pip would otherwise compile the bytecode of every module of every dependency,
# half of a fresh install's time; Python compiles (and caches) the modules a run imports
# instead. No pip self-upgrade: the venv's own pip installs this project. Stamps in .venv record
# what was installed: a second run with the same pyproject.toml skips pip when the extras asked
# for are in (the install is editable: source changes need no reinstall).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
EXTRAS=${1:-}
if [ ! -x .venv/bin/python ]; then
    "$PY" -m venv .venv
fi
PROJECT="$(cat pyproject.toml)"
for stamp in ".venv/.hertzmap-installed-${EXTRAS:-base}" .venv/.hertzmap-installed-test; do
    if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$PROJECT" ]; then
        exit 0
    fi
    [ -z "$EXTRAS" ] || break       # only the test extras satisfy `install.sh test`
done
.venv/bin/python -m pip install --quiet --no-compile -e ".${EXTRAS:+[$EXTRAS]}"
printf '%s' "$PROJECT" > ".venv/.hertzmap-installed-${EXTRAS:-base}"
