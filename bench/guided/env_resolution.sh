#!/usr/bin/env bash
# bench/guided/env_resolution.sh — does a coarser environment quadtree
# (techniques.guided.env_resolution) cut the per-sample cost without raising
# the MSE? two_step, 64x64, one thread, SPP samples per pixel, SEEDS seeds
# (the same seeds for every resolution: paired), against pathtrace
# references; CPU ms of the render is the clock.
# bench/guided/env_resolution.py OUT_DIR prints the table.
#
#   bench/guided/env_resolution.sh [BUILD_DIR] [OUT_DIR]   (SCENES, SEEDS, SPP, RESOLUTIONS to narrow)
. "$(dirname "$0")/common.sh" "${1:-}" "${2:-}" results_env_resolution
scenes=${SCENES:-"canopy_closed canopy bonsai engine"}
seeds=${SEEDS:-"1 2 3"}
spp=${SPP:-64}
resolutions=${RESOLUTIONS:-"512 256 128"}
needs_data "$scenes"
small=(--set render.width=64 --set render.height=64 --set render.threads=1)
note_machine
canopies
for sc in $scenes; do
  case $sc in canopy*) json=$out/$sc/canopy.json ;; *) json=$here/$sc.json ;; esac
  [[ -s $out/${sc}_ref.pfm ]] || "$volux" render "$json" -o "$out/${sc}_ref.pfm" --technique pathtrace \
    --spp 2048 --width 64 --height 64 --threads 1 --quiet
  for seed in $seeds; do
    for m in $resolutions; do
      "$bg" converge "$json" --reference "$out/${sc}_ref.pfm" --spp "$spp" --label "$sc env_resolution $m seed $seed" \
        --set techniques.guided.env_resolution=$m --set render.seed=$seed "${small[@]}" >> "$out/single.jsonl"
    done
  done
done
note_machine end
echo "wrote $out" >&2
