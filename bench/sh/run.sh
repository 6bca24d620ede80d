#!/usr/bin/env bash
# bench/sh/run.sh — the `sh` measurements of docs/techniques/sh.md:
#   table1.jsonl   Table 1 analogue: prepare_ms (the projection: shadows,
#                  + scattering, + bleeding) and render_ms at 512² on
#                  procedural 128³, engine 256²×128, bonsai 256³, plus
#                  update_ms.{tf,light,light_color,light_rotate_env,camera}
#                  and, with progressive projection, update_ms.tf (coarse)
#                  and refine_ms.tf
#   errors.jsonl   rel_mse of sh, shaded, ao against pathtrace (SPP) on the
#                  environment-lit bonsai and engine, 256², and montages
#
#   bench/sh/run.sh [VOLUX] [OUTDIR]    VOLUX_DATA=../shared/data  REPEAT=3  SPP=256
# Sets OMP_WAIT_POLICY=passive (docs/ARCHITECTURE.md); records uptime.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
out=${2:-${BENCH_OUT:-$here/../../out/bench}/sh}
data=${VOLUX_DATA:-$(cd "$here/../../.." && pwd)/shared/data}   # docs/CONVENTIONS.md
repeat=${REPEAT:-3}
spp=${SPP:-256}
montage=${MONTAGE:-$(dirname "$volux")/bench/bench_montage}
export OMP_WAIT_POLICY=passive
mkdir -p "$out"
ov_bonsai=(--set "volume.file=\"$data/volumes/bonsai_256x256x256_uint8.nhdr\""
           --set "transfer_function=\"$data/../peers/tf/bonsai.json\""
           --set "lights.0.file=\"$data/envmaps/venice_sunset_1k.hdr\"")
ov_engine=(--set "volume.file=\"$data/volumes/engine_256x256x128_uint8.nhdr\""
           --set "lights.0.file=\"$data/envmaps/pedestrian_overpass_1k.hdr\"")
ov_proc128=(--set "lights.0.file=\"$data/envmaps/royal_esplanade_1k.hdr\"")
modes=("shadows:" "scattering:--set techniques.sh.scattering=true"
       "bleeding:--set techniques.sh.scattering=true --set techniques.sh.bleeding=true")
tag() { sed -e "s/^{/{\"case\":\"$1\",\"mode\":\"$2\",\"load\":\"$(cut -d' ' -f1 /proc/loadavg)\",/"; }

if [ "${SKIP_TABLE:-0}" != 1 ]; then
  : > "$out/table1.jsonl"
  for scene in proc128 engine bonsai; do
    ov="ov_${scene}[@]"
    for m in "${modes[@]}"; do
      name=${m%%:*}; extra=${m#*:}
      # shellcheck disable=SC2086
      "$volux" bench "$here/${scene}_env.json" "${!ov}" $extra --repeat "$repeat" --json \
        --edit tf --edit light --edit light_color --edit light_rotate_env --edit camera | tag "$scene" "$name" >> "$out/table1.jsonl"
    done
    "$volux" bench "$here/${scene}_env.json" "${!ov}" --set techniques.sh.progressive=true --repeat "$repeat" \
      --json --edit tf | tag "$scene" progressive >> "$out/table1.jsonl"
    "$volux" bench "$here/${scene}_env.json" "${!ov}" --set render.step=1 --repeat "$repeat" --json \
      --edit camera | tag "$scene" "shadows_step1" >> "$out/table1.jsonl"
  done
fi

if [ "${SKIP_ERRORS:-0}" != 1 ]; then
  : > "$out/errors.jsonl"
  for scene in bonsai engine; do
    ov="ov_${scene}[@]"
    common=(--width 256 --height 256 "${!ov}")
    ref="$out/${scene}_pathtrace.exr"
    [ -f "$ref" ] || "$volux" render "$here/${scene}_env.json" "${common[@]}" --technique pathtrace --spp "$spp" -o "$ref"
    for tech in sh shaded ao; do
      "$volux" render "$here/${scene}_env.json" "${common[@]}" --technique "$tech" -o "$out/${scene}_$tech.exr"
      "$volux" compare "$out/${scene}_$tech.exr" "$ref" --json | tag "$scene" "$tech" >> "$out/errors.jsonl"
    done
    [ -x "$montage" ] && "$montage" "$out/${scene}_montage.png" 0 "$out/${scene}_sh.exr" "$out/${scene}_ao.exr" \
      "$out/${scene}_shaded.exr" "$ref"
  done
fi
uptime >> "$out/uptime.txt"
