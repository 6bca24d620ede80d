#!/usr/bin/env bash
# bench/guided/canopy_figure.sh — docs/images/guided_canopy{0,1}.png: the closed
# canopy scene (make_canopy.py --holes 0) and the one-shaft one (--holes 1),
# each as pathtrace reference | environment | two_step, the last two at
# about equal render CPU time (environment gets 1.3x the samples: the
# measured per-sample cost ratio, bench/guided/equal_time.sh).
#   bench/guided/canopy_figure.sh [BUILD_DIR] [OUT_DIR]
. "$(dirname "$0")/common.sh" "${1:-}" "${2:-}" results_figure
size=(--width 96 --height 96)
for holes in 0 1; do
  d=$out/canopy$holes
  [[ -s $d/canopy.json ]] || python3 "$here/make_canopy.py" "$d" --holes $holes
  [[ -s $d/ref.pfm ]] || "$volux" render "$d/canopy.json" -o "$d/ref.pfm" --technique pathtrace --spp 2048 "${size[@]}" --quiet
  "$volux" render "$d/canopy.json" -o "$d/env.pfm" --spp 21 "${size[@]}" --quiet --set techniques.guided.strategy='"environment"'
  "$volux" render "$d/canopy.json" -o "$d/two.pfm" --spp 16 "${size[@]}" --quiet --set techniques.guided.strategy='"two_step"'
  "$build/bench/bench_montage" "$out/guided_canopy$holes.png" 2 "$d/ref.pfm" "$d/env.pfm" "$d/two.pfm"
done
echo "wrote $out/guided_canopy{0,1}.png" >&2
