#!/usr/bin/env bash
# bench/brightness/envdir.sh — issue 28: `ambient` with the environment
# per direction (default) against its previous model (env_directions=0:
# the isotropic occlusion times the environment's mean radiance), `ao`
# (isotropic, default) against its opt-in directional occlusion
# (directional=true), and `single`, on the scenes and
# lightings of run.sh (same references, same file names: an OUTDIR of
# run.sh is reused). Per image: mean luminance / pathtrace (all orders and
# max_depth 1), rel_mse against both (volux compare's metric), and the
# render's CPU time.
#
#   bench/brightness/envdir.sh [VOLUX] [OUTDIR]      (SPP=64 SIZE=96)
#
# Writes OUTDIR/envdir.jsonl.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
out=${2:-$here/out}
spp=${SPP:-64}
size=${SIZE:-96}
envmap=${ENVMAP:-/work/shared/data/envmaps/venice_sunset_1k.hdr}
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
mkdir -p "$out"
jsonl="$out/envdir.jsonl"
: > "$jsonl"
common=(--width "$size" --height "$size" --quiet)
env_light="{\"type\": \"environment\", \"file\": \"$envmap\", \"intensity\": 1.0, \"visible\": false}"
variants=("single|single|" "ao|ao|" "ao_directional|ao|techniques.ao.directional=true"
          "ambient|ambient|" "ambient_old|ambient|techniques.ambient.env_directions=0")
for scene in ${SCENES:-bonsai engine aneurism}; do
  json="$here/../ambient/$scene.json"
  key=$(python3 -c "import json,sys; print(json.dumps(json.load(open(sys.argv[1]))['lights']))" "$json")
  for lighting in key env mixed; do
    case $lighting in
      key) lights=$key ;;
      env) lights="[$env_light]" ;;
      mixed) lights="${key%]}, $env_light]" ;;
    esac
    set_lights=(--set "lights=$lights")
    ref="$out/${scene}_${lighting}_pathtrace.pfm"
    [ -f "$ref" ] || "$volux" render "$json" --technique pathtrace --spp "$spp" --set render.max_depth=64 \
      "${set_lights[@]}" "${common[@]}" -o "$ref"
    ref1="$out/${scene}_${lighting}_pathtrace1.pfm"
    [ -f "$ref1" ] || "$volux" render "$json" --technique pathtrace --spp "$spp" --set render.max_depth=1 \
      "${set_lights[@]}" "${common[@]}" -o "$ref1"
    for v in "${variants[@]}"; do
      IFS='|' read -r name t extra <<< "$v"
      img="$out/${scene}_${lighting}_$name.pfm"
      set_extra=()
      [ -n "$extra" ] && set_extra=(--set "$extra")
      cpu=$( { /usr/bin/time -f '%U %S' "$volux" render "$json" --technique "$t" "${set_lights[@]}" "${set_extra[@]}" \
        "${common[@]}" -o "$img" 2>&1 >/dev/null; } | tail -1 | awk '{print $1 + $2}')
      python3 "$here/envdir_stats.py" "$img" "$ref" "$ref1" "$scene" "$lighting" "$name" "$cpu" | tee -a "$jsonl"
    done
  done
done
