#!/usr/bin/env bash
# bench/manylights/timeline.sh — the TF-edit timeline (Weber et al. 2013
# §4, Fig. 6): an extinction edit (× 1.25³ ≈ 2) answered at once by Eq. 6
# and then `update_budget` VLs per frame, against a fresh create.
#
#   bench/manylights/timeline.sh [BENCH_MANYLIGHTS] [OUTDIR]
#
# Environment: SCENES ("bonsai engine"), SIZE (256), VLS (1000), BUDGET
# (100), SAMPLES (1). Writes OUTDIR/timeline.jsonl (one line per frame:
# ms, CPU ms, pending VLs, rel_mse and mean relative difference against the
# fresh image; plus the fresh create's prepare and render times) and, per
# scene, <scene>_timeline.png: before the edit, the immediate update
# (frame 1), halfway, converged, fresh.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bench=${1:-$here/../../build/bench/bench_manylights}
outdir=${2:-$here/out}
scenes=${SCENES:-"bonsai engine"}
size=${SIZE:-256}
vls=${VLS:-1000}
budget=${BUDGET:-100}
samples=${SAMPLES:-1}
mkdir -p "$outdir"
out="$outdir/timeline.jsonl"
: > "$out"
export OMP_WAIT_POLICY=passive
for scene in $scenes; do
  dir="$outdir/timeline_$scene"
  mkdir -p "$dir"
  "$bench" timeline "$here/$scene.json" --images "$dir" --set render.width="$size" --set render.height="$size" \
      --set techniques.manylights.vl_count="$vls" --set techniques.manylights.update_budget="$budget" \
      --set techniques.manylights.samples="$samples" --set techniques.manylights.preview_vls=0 | tee -a "$out"
  last=$(ls "$dir"/frame_*.pfm | tail -1)
  n=$(ls "$dir"/frame_*.pfm | wc -l)
  mid=$(ls "$dir"/frame_*.pfm | sed -n "$(( (n + 1) / 2 ))p")
  python3 "$here/pfmtool.py" png "$outdir/${scene}_timeline.png" "$dir/before.pfm" "$dir/frame_001.pfm" "$mid" \
      "$last" "$dir/fresh.pfm"
done
echo "wrote $out" >&2
