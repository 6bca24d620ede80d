#!/usr/bin/env bash
# bench/manylights/table2.sh — Weber et al. 2013 Table 2 on our data: render
# time with ray-marched transmittance (RM) vs AVSM look-ups (point,
# trilinear) and the AVSM creation time, for N virtual lights.
#
#   bench/manylights/table2.sh [VOLUX] [OUT.jsonl]
#
# Environment: SCENES (default "bonsai engine"), COUNTS ("100 500 1000 2000"),
# SIZE (512), RM_SIZE (image side for the RM column, default SIZE; RM is
# slow — its time is then scaled by (SIZE/RM_SIZE)² and marked "scaled"),
# SAMPLES (view samples per pixel, default 1), THREADS (2).
# One `volux bench` per configuration (1 warm-up + 1 timed frame); the
# JSON lines get "vl_count", "transmittance" and "size" added.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
out=${2:-$here/out/table2.jsonl}
scenes=${SCENES:-"bonsai engine"}
counts=${COUNTS:-"100 500 1000 2000"}
size=${SIZE:-512}
rm_size=${RM_SIZE:-$size}
samples=${SAMPLES:-1}
threads=${THREADS:-2}
mkdir -p "$(dirname "$out")"
: > "$out"
export OMP_WAIT_POLICY=passive
for scene in $scenes; do
  for n in $counts; do
    for tm in avsm avsm_linear raymarch; do
      s=$size
      [ "$tm" = raymarch ] && s=$rm_size
      "$volux" bench "$here/$scene.json" --repeat 1 --json --edit camera --threads "$threads" \
          --width "$s" --height "$s" --spp 1 \
          --set techniques.manylights.vl_count="$n" --set techniques.manylights.samples="$samples" \
          --set techniques.manylights.transmittance="\"$tm\"" --set techniques.manylights.preview_vls=0 |
        sed -e "s/}\$/,\"vl_count\":$n,\"transmittance\":\"$tm\",\"size\":$s}/" >> "$out"
      echo "table2: $scene N=$n $tm ${s}x$s done" >&2
    done
  done
done
echo "wrote $out" >&2
