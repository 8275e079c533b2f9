#!/usr/bin/env bash
# Remake every figure the docs ship (docs/figures/): each scene is run into
# results/make-figures/<scene>.zarr (git ignores results/; a rerun resumes there, delete the
# folder to run afresh) and the figures the README and docs/gallery.md show are drawn into docs/figures/;
# then the paper's analytic figures, the explore page's screenshots (the browser test, when
# chromium is there), a basin map of the default scene (hertzmap basins) and the fit of the
# worked example of docs/identify.md (hertzmap fit). Prints the wall time of each scene's run and plot.
#
#   bash scripts/make-figures.sh              # everything (about 10 minutes on 2 cores, and
#                                             # the damping scene's 13 on one worker)
#   bash scripts/make-figures.sh fig06 fig08  # those scenes only
#   WORKERS=4 bash scripts/make-figures.sh    # workers of each run (default 2)
#
# `hertzmap bench --out docs/figures` remakes docs/figures/bench.png (BENCHMARKS.md section 1).
set -euo pipefail
cd "$(dirname "$0")/.."
HM=.venv/bin/hertzmap
OUT=docs/figures
mkdir -p "$OUT/explore"

# scene -> the figures of it that the docs show (hertzmap plot --which)
declare -A FIGURES=(
    [default]="map measures bifurcation"
    [fig03]="map"
    [fig06]="response"
    [fig07]="bifurcation"
    [fig08]="response"
    [fig09]="map bifurcation"
    [fig10]="response"
    [fig12]="harmonics"
    [fig13]="harmonics"
    [fig14]="histories"
    [fig15]="histories"
    [vibro_impact]="map lyapunov strobe"
    [damping]="thresholds zeta_maps impact_onset"
    [sweeps]="sweeps"
)
ORDER="default fig03 fig06 fig07 fig08 fig09 fig10 fig12 fig13 fig14 fig15 vibro_impact damping sweeps"
SCENES="${*:-$ORDER paper explore basins fit}"

ms() { date +%s%3N; }
STORES=results/make-figures
for scene in $SCENES; do
    case "$scene" in
    paper)
        "$HM" plot --paper fig02 fig03 fig04 fig05 --out "$OUT" ;;
    basins)
        # a 1000 x 1000 basin map on the default scene's store (run above), its zoom and
        # f(eps): README and docs/gallery.md
        "$HM" basins "$STORES/default.zarr" --omega 1.35 --sigma 0.7625 --grid 1000x1000 \
            --workers "${WORKERS:-2}" --out "$OUT" ;;
    fit)
        # docs/identify.md's worked example: its result and figure (paper_rig_sweeps_fit.*)
        "$HM" fit docs/examples/paper_rig_sweeps.csv --rig docs/examples/paper_rig.toml \
            --out "$OUT" --workers "${WORKERS:-2}" ;;
    explore)
        HERTZMAP_SCREENSHOTS="$OUT/explore" .venv/bin/python -m pytest -q -p no:cacheprovider \
            tests/end_to_end/test_explore.py -k click_gives_the_orbits ;;
    *)
        [ -n "${FIGURES[$scene]+x}" ] || { echo "no figures listed for scene $scene" >&2; exit 2; }
        t0=$(ms)
        "$HM" run "scenes/$scene.toml" --store "$STORES/$scene.zarr" --workers "${WORKERS:-2}"
        t1=$(ms)
        "$HM" plot "$STORES/$scene.zarr" --out "$OUT" --which ${FIGURES[$scene]}
        t2=$(ms)
        awk -v s="$scene" -v r=$((t1 - t0)) -v p=$((t2 - t1)) \
            'BEGIN { printf "make-figures: %s: run %.1f s, plot %.1f s\n", s, r / 1000, p / 1000 }' ;;
    esac
done
