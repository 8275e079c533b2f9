#!/usr/bin/env bash
# The main command of README.md: install, run the default study end to end (or resume it),
# then compute its products and plot its maps into results/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh
.venv/bin/hertzmap run scenes/default.toml "$@"
.venv/bin/hertzmap plot results/default.zarr
