#!/usr/bin/env bash
# bench/guided/table2_canopy.sh — Table 2 (sweep-space filter vs 4x / 16x
# angular oversampling: the grid's cost and the error it leaves) at a
# reduced size: on canopy_closed (make_canopy.py --holes 0, 96^3, where the
# visibility decides the sampling), 64x64, one thread, two_step, 64 spp,
# SEEDS seeds. The reference is equal_time.sh's (OUT_DIR/canopy_closed_ref.pfm).
# With PHASES="table1", Table 1 at the same reduced size instead: sweep
# (unfiltered) vs brute-force visibility over grid cells 2, 4, 8.
#   bench/guided/table2_canopy.sh [BUILD_DIR] [OUT_DIR]   (then: table2_canopy.py OUT_DIR)
. "$(dirname "$0")/common.sh" "${1:-}" "${2:-}" results_equal_time
seeds=${SEEDS:-"1 2 3"}
json=$out/canopy_closed/canopy.json
[[ -s $json ]] || python3 "$here/make_canopy.py" "$out/canopy_closed" --holes 0
[[ -s $out/canopy_closed_ref.pfm ]] || "$build/volux" render "$json" -o "$out/canopy_closed_ref.pfm" --technique pathtrace \
  --spp 4096 --width 64 --height 64 --quiet
small=(--set render.width=64 --set render.height=64 --set render.threads=1)
if [[ ${PHASES:-table2} == table1 ]]; then
  : > "$out/table1.jsonl"
  for cell in 2 4 8; do
    for v in sweep bruteforce; do
      "$bg" visibility "$json" --repeat 1 --label "$v cell $cell" --set techniques.guided.visibility="\"$v\"" \
        --set techniques.guided.filter=false --set techniques.guided.cell=$cell --set render.threads=1 >> "$out/table1.jsonl"
    done
  done
  exit 0
fi
: > "$out/table2.jsonl"
for cfg in "unfiltered:filter=false" "filtered:filter=true" "filtered_beta0:filter_angle=0" \
           "oversample4:filter=false,oversample=2" "oversample16:filter=false,oversample=4" \
           "bruteforce:visibility=\"bruteforce\",filter=false"; do
  label=${cfg%%:*} sets=()
  IFS=, read -ra kv <<< "${cfg#*:}"
  for x in "${kv[@]}"; do sets+=(--set "techniques.guided.$x"); done
  "$bg" visibility "$json" --repeat 3 --label "$label" "${sets[@]}" --set render.threads=1 >> "$out/table2.jsonl"
  for seed in $seeds; do
    "$bg" converge "$json" --reference "$out/canopy_closed_ref.pfm" --spp 64 --label "$label seed $seed" "${sets[@]}" \
      --set render.seed=$seed "${small[@]}" >> "$out/table2.jsonl"
  done
done
echo "wrote $out/table2.jsonl" >&2
