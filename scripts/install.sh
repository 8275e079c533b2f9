#!/usr/bin/env bash
# Create .venv (if needed) and install hertzmap into it, editable: `install.sh` for running
# studies, `install.sh test` with the test extras (scripts/test.sh).
#
# uv installs the wheels in parallel: 4 s for the dependencies on this project's 2-core VM
# against pip's 15 s (BENCHMARKS.md, section 6); it is taken from PATH, else installed into the
# venv (one wheel), and where it cannot be had or fails (no network to PyPI, a local index in
# pip.conf, which uv does not read) pip installs as before. The bytecode of the modules a run
# imports is written at install (scripts/compile_bytecode.py, two processes at once): without it
# every process of a run (the client, each worker, the plots) compiles the source of every
# module it imports again whenever Python may not write bytecode (PYTHONDONTWRITEBYTECODE), and
# even where it may, the first run's workers each compile it at once. Only those modules: all
# of site-packages (uv's --compile-bytecode) took twice as long, mostly for modules no run
# imports. Stamps in .venv record what was installed: a second run with the
# same pyproject.toml skips the install when the extras asked for are in (the install is
# editable: source changes need no reinstall).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
EXTRAS=${1:-}
if [ ! -x .venv/bin/python ]; then
    # without pip: ensurepip took 3.7 s of the fresh install; pip comes with uv's install below
    "$PY" -m venv --without-pip .venv
fi
PROJECT="$(cat pyproject.toml)"
for stamp in ".venv/.hertzmap-installed-${EXTRAS:-base}" .venv/.hertzmap-installed-test; do
    if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$PROJECT" ]; then
        exit 0
    fi
    [ -z "$EXTRAS" ] || break       # only the test extras satisfy `install.sh test`
done
TARGET=".${EXTRAS:+[$EXTRAS]}"
has_pip() { .venv/bin/python -m pip --version >/dev/null 2>&1; }
UV=$(command -v uv || true)
if [ -z "$UV" ]; then
    # into the venv, by the interpreter's own pip (pip >= 22.3: --python), else by the venv's
    if "$PY" -m pip --python .venv/bin/python install --quiet uv >/dev/null 2>&1 \
            || { { has_pip || .venv/bin/python -m ensurepip >/dev/null 2>&1; } \
                 && .venv/bin/python -m pip install --quiet uv >/dev/null 2>&1; }; then
        UV=.venv/bin/uv
    fi
fi
if [ -n "$UV" ] && "$UV" pip install --quiet --python .venv/bin/python -e "$TARGET" pip; then
    # a failure here costs time only (modules then compile from source): warn, go on
    .venv/bin/python scripts/compile_bytecode.py client &
    client=$!
    .venv/bin/python scripts/compile_bytecode.py worker \
        || echo "install: writing the workers' bytecode failed (runs are slower, not wrong)" >&2
    wait "$client" \
        || echo "install: writing the client's bytecode failed (runs are slower, not wrong)" >&2
else
    [ -z "$UV" ] || echo "install: uv could not install hertzmap; installing with pip" >&2
    has_pip || .venv/bin/python -m ensurepip >/dev/null
    .venv/bin/python -m pip install --quiet -e "$TARGET"      # pip compiles all the bytecode
fi
printf '%s' "$PROJECT" > ".venv/.hertzmap-installed-${EXTRAS:-base}"
