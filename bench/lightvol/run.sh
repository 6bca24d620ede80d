#!/bin/bash
# bench/lightvol/run.sh — the lightvol measurements of docs/techniques/lightvol.md
# (Sundén & Ropinski 2015, Table 1 and Fig. 10 on our data).
#
#   bench/lightvol/run.sh [BUILD_DIR] [OUT.jsonl]
#
# Writes one JSON object per line (the `volux bench` contract plus cpu_ms,
# lights, config). Single-threaded by default (THREADS=1): the development
# machine has 2 cores shared with other jobs, and CPU-time medians are the
# stable numbers there; set THREADS=2 for a parallel run. REPEAT (default 3)
# repeats per metric. Needs $VOLUX_DATA (docs/CONVENTIONS.md).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
BUILD="${1:-$ROOT/build}"
# bench_lightvol reads the scenes through the library, which has no default root.
export VOLUX_DATA="${VOLUX_DATA:-$ROOT/../shared/data}"
OUT="${2:-${BENCH_OUT:-$ROOT/out/bench}/lightvol/results.jsonl}"
mkdir -p "$(dirname "$OUT")"
THREADS="${THREADS:-1}"
REPEAT="${REPEAT:-3}"
BENCH="$BUILD/bench/bench_lightvol"
S="$ROOT/bench/scenes"
: > "$OUT"
note() { echo "{\"note\":\"$*\",\"load\":\"$(cut -d' ' -f1-3 /proc/loadavg)\",\"date\":\"$(date -u +%FT%TZ)\"}" >> "$OUT"; }
table() { # scene scale config [extra --set ...]
  local scene=$1 scale=$2 config=$3; shift 3
  "$BENCH" table "$S/$scene.json" --repeat "$REPEAT" --threads "$THREADS" \
      --set techniques.lightvol.scale="$scale" "$@" |
    sed "s/}\$/,\"scale\":$scale,\"config\":\"$config\"}/" >> "$OUT"
}
note "start"
# Table 1: scenes x illumination scale (forward scattering 0.5, cone 10 deg: the scenes' settings)
for scale in 1 0.25; do
  table lightvol_engine_2       $scale "engine, 2 lights (dir + point)"
  table lightvol_engine_fig9a   $scale "engine, 3 lights (2 dir + point)"
  table lightvol_engine_3in2    $scale "engine, 3 lights in 2 groups"
  table lightvol_bonsai_threepoint $scale "bonsai, 3 lights (spot + 2 dir)"
  table lightvol_bonsai_4       $scale "bonsai, 4 lights (2 dir + 2 point)"
done
# the coherence target's setup without forward scattering, and all-directional
for scale in 1 0.25; do
  table lightvol_engine_3in2 $scale "engine, 3 lights in 2 groups, f=0" --set techniques.lightvol.forward_scattering=0
  table lightvol_engine_3in2_dir $scale "engine, 3 directional lights in 2 groups"
  table lightvol_engine_3in2_dir $scale "engine, 3 directional lights in 2 groups, f=0" --set techniques.lightvol.forward_scattering=0
done
# Fig. 10: 1..40 lights with the direction of the scene's first light
for f in 0.5 0; do
  "$BENCH" scaling "$S/lightvol_engine_3in2.json" --max 40 --step 13 --repeat "$REPEAT" --threads "$THREADS" \
      --set techniques.lightvol.scale=0.5 --set techniques.lightvol.forward_scattering=$f |
    sed "s/}\$/,\"scale\":0.5,\"config\":\"scaling, f=$f\"}/" >> "$OUT"
done
note "end"
echo "wrote $OUT"
