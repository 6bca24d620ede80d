#!/usr/bin/env bash
# bench/guided/env_resolution.sh — does a coarser environment quadtree
# (techniques.guided.env_resolution) cut the per-sample cost without raising
# the MSE? two_step, 64x64, one thread, SPP samples per pixel, SEEDS seeds
# (the same seeds for every resolution: paired), against pathtrace
# references; CPU ms of the render is the clock.
# bench/guided/env_resolution.py OUT_DIR prints the table.
#
#   bench/guided/env_resolution.sh [BUILD_DIR] [OUT_DIR]   (SCENES, SEEDS, SPP, RESOLUTIONS to narrow)
set -euo pipefail
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-$here/../../build}
out=${2:-$here/results_env_resolution}
scenes=${SCENES:-"canopy_closed canopy bonsai engine"}
seeds=${SEEDS:-"1 2 3"}
spp=${SPP:-64}
resolutions=${RESOLUTIONS:-"512 256 128"}
volux=$build/volux bg=$build/bench/bench_guided
[[ $scenes != *bonsai* && $scenes != *engine* ]] || [[ -n ${VOLUX_DATA:-} ]] || { echo "set VOLUX_DATA (the folder with volumes/, envmaps/)" >&2; exit 2; }
small=(--set render.width=64 --set render.height=64 --set render.threads=1)
mkdir -p "$out"
echo "{\"cpu\":\"$(lscpu | grep 'Model name' | sed 's/.*: *//')\",\"load\":\"$(cut -d' ' -f1-3 /proc/loadavg)\",\"date\":\"$(date -u +%FT%TZ)\"}" >> "$out/notes.jsonl"
[[ -s $out/canopy/canopy.json ]] || python3 "$here/make_canopy.py" "$out/canopy" --holes 1
[[ -s $out/canopy_closed/canopy.json ]] || python3 "$here/make_canopy.py" "$out/canopy_closed" --holes 0
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
echo "{\"end\":\"$(date -u +%FT%TZ)\",\"load\":\"$(cut -d' ' -f1-3 /proc/loadavg)\"}" >> "$out/notes.jsonl"
echo "wrote $out" >&2
