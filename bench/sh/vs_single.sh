#!/usr/bin/env bash
# bench/sh/vs_single.sh — issue 28's `sh` target: rel_mse of `sh` and
# `single` against single-scattering `pathtrace` (max_depth 1, converged)
# on bonsai, engine and aneurism (bench/ambient/*.json), under the scene's
# key light and under the Venice sunset HDR map alone; also sh's render
# and preparation time (one `volux render` per image: CPU seconds user+sys
# and wall, from /usr/bin/time).
#
#   bench/sh/vs_single.sh [VOLUX] [OUTDIR]   (SIZE=128 SPP_REF=1024 SH_SET="...")
#
# References are cached in OUTDIR (delete them to re-render). Prints one
# JSON line per (scene, lighting, technique): {"scene","lighting",
# "technique","rel_mse","cpu_s","wall_s","load"}. 4x-zoom crops: crops.py.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
out=${2:-$here/out}
size=${SIZE:-128}
spp_ref=${SPP_REF:-1024}
tag=${TAG:-sh}
envmap=${ENVMAP:-/work/shared/data/envmaps/venice_sunset_1k.hdr}
export VOLUX_DATA=${VOLUX_DATA:-/work/shared/data}
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
mkdir -p "$out"
common=(--width "$size" --height "$size" --quiet)
env_light="{\"type\": \"environment\", \"file\": \"$envmap\", \"intensity\": 1.0, \"visible\": false}"
read -r -a sh_set <<< "${SH_SET:-}"
for scene in ${SCENES:-bonsai engine aneurism}; do
  json="$here/../ambient/$scene.json"
  key=$(python3 -c "import json,sys; print(json.dumps(json.load(open(sys.argv[1]))['lights']))" "$json")
  for lighting in ${LIGHTINGS:-key env}; do
    case $lighting in
      key) lights=$key ;;
      env) lights="[$env_light]" ;;
    esac
    ref="$out/${scene}_${lighting}_pt1.pfm"
    [ -f "$ref" ] || "$volux" render "$json" --technique pathtrace --spp "$spp_ref" --set render.max_depth=1 \
      --set "lights=$lights" "${common[@]}" -o "$ref"
    for t in ${TECHNIQUES:-single sh}; do
      name=$t; extra=()
      if [ "$t" = sh ]; then name=$tag; for s in "${sh_set[@]}"; do extra+=(--set "$s"); done; fi
      img="$out/${scene}_${lighting}_$name.pfm"
      /usr/bin/time -f "%U %S %e" -o "$out/.time" \
        "$volux" render "$json" --technique "$t" --set "lights=$lights" "${extra[@]}" "${common[@]}" -o "$img"
      read -r usr sys wall < "$out/.time"
      secs=$(python3 -c "print('%.2f' % ($usr + $sys))")
      rel=$("$volux" compare "$img" "$ref" --json | python3 -c "import json,sys; print(json.load(sys.stdin)['rel_mse'])")
      echo "{\"scene\":\"$scene\",\"lighting\":\"$lighting\",\"technique\":\"$name\",\"rel_mse\":$rel,\"cpu_s\":$secs,\"wall_s\":$wall,\"load\":\"$(cut -d' ' -f1 /proc/loadavg)\"}"
    done
  done
done
