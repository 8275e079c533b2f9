#!/usr/bin/env bash
# Prints the path of a uv of the version UV_VERSION names (the one uv.lock is written and read
# with), after creating .venv if needed: a uv on PATH when it is that version, else the one in
# .venv, installed there by the venv's pip. Used by install.sh and lock.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
UV_VERSION=0.13.9
PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
version() { "$1" --version 2>/dev/null | cut -d' ' -f2; }
UV=$(command -v uv || true)
if [ -n "$UV" ] && [ "$(version "$UV")" = "$UV_VERSION" ]; then
    echo "$UV"
    exit 0
fi
if [ "$(version .venv/bin/uv)" != "$UV_VERSION" ]; then
    .venv/bin/python -m pip install --quiet --disable-pip-version-check "uv==$UV_VERSION" >&2
fi
echo "$PWD/.venv/bin/uv"
