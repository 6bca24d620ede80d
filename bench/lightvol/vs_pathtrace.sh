#!/bin/bash
# bench/lightvol/vs_pathtrace.sh — lightvol against the reference path tracer
# on a multi-light scene (docs/techniques/lightvol.md, "Error vs pathtrace").
#
#   bench/lightvol/vs_pathtrace.sh [BUILD_DIR] [OUT_DIR] [SCENE]
#
# References: pathtrace single scattering (max_depth 1, what lightvol
# computes when forward_scattering = 0) and multiple scattering (max_depth
# 64). Prints `volux compare --json` lines (rmse, rel_mse, psnr, max_abs)
# for each lightvol variant, and the references' own noise (same
# estimator at a quarter of the samples).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
BUILD="${1:-$ROOT/build}"
OUT="${2:-${BENCH_OUT:-$(cd "$(dirname "$0")/../.." && pwd)/out/bench}/lightvol_vs_pathtrace}"
SCENE="${3:-$ROOT/bench/scenes/lightvol_engine_fig9a.json}"
SPP1="${SPP1:-1024}" SPP64="${SPP64:-256}" W="${W:-256}"
V="$BUILD/volux"
mkdir -p "$OUT"
common=(--width "$W" --height "$W" --threads "${THREADS:-0}")
run() { "$V" render "$SCENE" -o "$OUT/$1.pfm" "${common[@]}" "${@:2}" 2>&1 | sed 's/^/  /'; }
cmp() { printf '%-34s vs %-10s ' "$1" "$2"; "$V" compare "$OUT/$1.pfm" "$OUT/$2.pfm" --json; }
run pt1 --technique pathtrace --spp "$SPP1" --set render.max_depth=1
run pt1_q --technique pathtrace --spp $((SPP1 / 4)) --set render.max_depth=1 --seed 7
run pt64 --technique pathtrace --spp "$SPP64" --set render.max_depth=64
run pt64_q --technique pathtrace --spp $((SPP64 / 4)) --set render.max_depth=64 --seed 7
run lv_f0 --set techniques.lightvol.forward_scattering=0
run lv_f0_q --set techniques.lightvol.forward_scattering=0 --set techniques.lightvol.scale=0.25
run lv_f05 --set techniques.lightvol.forward_scattering=0.5 --set techniques.lightvol.scatter_cone=10
run lv_f1 --set techniques.lightvol.forward_scattering=1 --set techniques.lightvol.scatter_cone=10
cmp pt1_q pt1
cmp lv_f0 pt1
cmp lv_f0_q pt1
cmp lv_f05 pt1
cmp pt64_q pt64
cmp lv_f0 pt64
cmp lv_f05 pt64
cmp lv_f1 pt64
