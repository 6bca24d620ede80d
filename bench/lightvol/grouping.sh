#!/bin/bash
# bench/lightvol/grouping.sh — positional_grouping "voxel" vs "center" (issue 17,
# deliverable 3; docs/techniques/lightvol.md, "Grouping of point and spot lights"):
# Table 1 setups with point/spot lights (entire sequential and coherent updates,
# one light's state change) and their error against pathtrace single scattering.
#
#   bench/lightvol/grouping.sh [BUILD_DIR] [OUT_DIR]
#
# Timing: bench_lightvol table, CPU-ms medians of REPEAT (3) runs, THREADS (1);
# error: `volux compare --json` of lightvol (f = 0, scale 1: its single-scattering
# model) against pathtrace max_depth 1 at W² (128²) with SPP (512) samples, and
# that reference's own noise (a quarter of the samples, another seed). Needs
# $VOLUX_DATA.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
BUILD="${1:-$ROOT/build}"
OUT="${2:-${BENCH_OUT:-$ROOT/out/bench}/lightvol_grouping}"
export VOLUX_DATA="${VOLUX_DATA:-$ROOT/../shared/data}"
export OMP_WAIT_POLICY=passive
THREADS="${THREADS:-1}" REPEAT="${REPEAT:-3}" W="${W:-128}" SPP="${SPP:-512}"
SCENES="${SCENES:-lightvol_engine_2 lightvol_engine_fig9a lightvol_engine_3in2 lightvol_bonsai_threepoint lightvol_bonsai_4}"
S="$ROOT/bench/scenes"
mkdir -p "$OUT"
J="$OUT/timing_t$THREADS.jsonl"
: > "$J"
echo "{\"note\":\"start\",\"load\":\"$(cut -d' ' -f1-3 /proc/loadavg)\",\"date\":\"$(date -u +%FT%TZ)\"}" >> "$J"
for scene in $SCENES; do
  for f in 0.5 0; do
    for g in voxel center; do
      "$BUILD/bench/bench_lightvol" table "$S/$scene.json" --repeat "$REPEAT" --threads "$THREADS" \
          --set "techniques.lightvol.positional_grouping=\"$g\"" --set techniques.lightvol.forward_scattering=$f |
        sed -e "s|$ROOT/||" -e "s/}\$/,\"grouping\":\"$g\",\"f\":$f}/" >> "$J"
    done
  done
done
echo "{\"note\":\"end\",\"load\":\"$(cut -d' ' -f1-3 /proc/loadavg)\",\"date\":\"$(date -u +%FT%TZ)\"}" >> "$J"
[ "${ERROR:-1}" = 0 ] && exit 0
V="$BUILD/volux"
E="$OUT/error.txt"
: > "$E"
common=(--width "$W" --height "$W" --threads "${ERR_THREADS:-0}")
for scene in $SCENES; do
  "$V" render "$S/$scene.json" -o "$OUT/$scene.pt1.pfm" "${common[@]}" --technique pathtrace --spp "$SPP" \
      --set render.max_depth=1 >/dev/null 2>&1
  "$V" render "$S/$scene.json" -o "$OUT/$scene.pt1_q.pfm" "${common[@]}" --technique pathtrace \
      --spp $((SPP / 4)) --set render.max_depth=1 --seed 7 >/dev/null 2>&1
  printf '%s noise %s\n' "$scene" "$("$V" compare "$OUT/$scene.pt1_q.pfm" "$OUT/$scene.pt1.pfm" --json)" >> "$E"
  for g in voxel center; do
    "$V" render "$S/$scene.json" -o "$OUT/$scene.lv_$g.pfm" "${common[@]}" \
        --set techniques.lightvol.forward_scattering=0 --set "techniques.lightvol.positional_grouping=\"$g\"" >/dev/null 2>&1
    printf '%s %s %s\n' "$scene" "$g" "$("$V" compare "$OUT/$scene.lv_$g.pfm" "$OUT/$scene.pt1.pfm" --json)" >> "$E"
  done
done
cat "$E"
