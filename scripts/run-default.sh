#!/usr/bin/env bash
# The main command of README.md: install, run the default study end to end, plot its maps.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh
.venv/bin/hertzmap run studies/default.toml "$@"
