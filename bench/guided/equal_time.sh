#!/usr/bin/env bash
# bench/guided/equal_time.sh — the issue's two equal-time targets, on the
# canopy scenes (bench/guided/make_canopy.py: a fog box under a dense roof,
# the sun occluded for most scattering points; procedural) and on bonsai /
# engine (bench/guided/*.json, $VOLUX_DATA):
#   (a) two_step vs environment sampling, single scattering (the paper);
#   (b) guided multiple scattering (two_step at every event) vs pathtrace,
#       max_depth 8.
# 64x64, one thread, SPP samples per pixel, SEEDS independent seeds; CPU ms
# of the render is the clock (visibility-grid preparation reported apart).
# bench/guided/equal_time.py OUT_DIR prints the table (medians over seeds).
#
#   bench/guided/equal_time.sh [BUILD_DIR] [OUT_DIR]   (SCENES, SEEDS, SPP to narrow)
. "$(dirname "$0")/common.sh" "${1:-}" "${2:-}" results_equal_time
scenes=${SCENES:-"canopy canopy_closed bonsai engine"}
seeds=${SEEDS:-"1 2 3"}
spp=${SPP:-64}
needs_data "$scenes"
small=(--set render.width=64 --set render.height=64 --set render.threads=1)
note_machine
canopies
for sc in $scenes; do
  case $sc in canopy*) json=$out/$sc/canopy.json ;; *) json=$here/$sc.json ;; esac
  # references: pathtrace, 64x64, 32x the samples of the measured runs or more
  [[ -s $out/${sc}_ref.pfm ]] || "$volux" render "$json" -o "$out/${sc}_ref.pfm" --technique pathtrace \
    --spp 4096 --width 64 --height 64 --quiet
  [[ -s $out/${sc}_ms_ref.pfm ]] || "$volux" render "$json" -o "$out/${sc}_ms_ref.pfm" --technique pathtrace \
    --spp 2048 --max-depth 8 --width 64 --height 64 --quiet
  for seed in $seeds; do
    for s in environment two_step; do
      "$bg" converge "$json" --reference "$out/${sc}_ref.pfm" --spp "$spp" --label "$sc single $s seed $seed" \
        --set techniques.guided.strategy="\"$s\"" --set render.seed=$seed "${small[@]}" >> "$out/single.jsonl"
    done
    "$bg" converge "$json" --reference "$out/${sc}_ms_ref.pfm" --spp "$spp" --label "$sc multiple pathtrace seed $seed" \
      --set render.technique='"pathtrace"' --set render.max_depth=8 --set render.seed=$seed "${small[@]}" >> "$out/multiple.jsonl"
    for gd in 0 1; do
      "$bg" converge "$json" --reference "$out/${sc}_ms_ref.pfm" --spp "$spp" \
        --label "$sc multiple guided_depth$gd seed $seed" --set techniques.guided.guide_depth=$gd \
        --set render.max_depth=8 --set render.seed=$seed "${small[@]}" >> "$out/multiple.jsonl"
    done
  done
done
note_machine end
echo "wrote $out" >&2
