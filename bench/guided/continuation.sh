#!/usr/bin/env bash
# bench/guided/continuation.sh — guided multiple scattering with guided
# continuation directions (techniques.guided.guide_continuation α: the
# phase / environment-density mixture) against plain pathtrace, max_depth 8,
# the issue's equal-time target (guided MSE <= 0.5x pathtrace).
# 64x64, one thread, SPP samples per pixel, SEEDS seeds (paired: the same
# seeds for every configuration); CPU ms of the render is the clock.
# bench/guided/equal_time.py-style table: bench/guided/continuation.py OUT_DIR.
#
#   bench/guided/continuation.sh [BUILD_DIR] [OUT_DIR]   (SCENES, SEEDS, SPP, ALPHAS to narrow)
. "$(dirname "$0")/common.sh" "${1:-}" "${2:-}" results_continuation
scenes=${SCENES:-"canopy_closed bonsai"}
seeds=${SEEDS:-"1 2 3"}
spp=${SPP:-64}
alphas=${ALPHAS:-"0 0.5"}
needs_data "$scenes"
small=(--set render.width=64 --set render.height=64 --set render.threads=1 --set render.max_depth=8)
note_machine
canopies
for sc in $scenes; do
  case $sc in canopy*) json=$out/$sc/canopy.json ;; *) json=$here/$sc.json ;; esac
  [[ -s $out/${sc}_ms_ref.pfm ]] || "$volux" render "$json" -o "$out/${sc}_ms_ref.pfm" --technique pathtrace \
    --spp 2048 --max-depth 8 --width 64 --height 64 --threads 1 --quiet
  for seed in $seeds; do
    "$bg" converge "$json" --reference "$out/${sc}_ms_ref.pfm" --spp "$spp" --label "$sc pathtrace seed $seed" \
      --set render.technique='"pathtrace"' --set render.seed=$seed "${small[@]}" >> "$out/multiple.jsonl"
    for a in $alphas; do
      "$bg" converge "$json" --reference "$out/${sc}_ms_ref.pfm" --spp "$spp" --label "$sc guided alpha $a seed $seed" \
        --set techniques.guided.guide_continuation=$a --set render.seed=$seed "${small[@]}" >> "$out/multiple.jsonl"
    done
  done
done
note_machine end
echo "wrote $out" >&2
