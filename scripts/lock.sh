#!/usr/bin/env bash
# The lock file, uv.lock: every package hertzmap installs, at one exact version with its hashes,
# for every Python and platform pyproject.toml admits (scripts/install.sh installs from it).
#
#   bash scripts/lock.sh            move every package forward to its newest version within
#                                   pyproject.toml's ranges (then run the tests: bash scripts/test.sh)
#   bash scripts/lock.sh --check    exit 1 when uv.lock does not match pyproject.toml (CI runs it)
#
# After a change of pyproject.toml's dependencies, `bash scripts/lock.sh --keep` relocks with
# the fewest changes (the versions of the lock kept where they still fit).
set -euo pipefail
cd "$(dirname "$0")/.."
UV=$(bash scripts/uv.sh)
export UV_PYTHON_DOWNLOADS=never
case "${1:-}" in
    --check) exec "$UV" lock --locked ;;
    --keep) exec "$UV" lock ;;
    "") exec "$UV" lock --upgrade ;;
    *) echo "usage: bash scripts/lock.sh [--check | --keep]" >&2; exit 2 ;;
esac
