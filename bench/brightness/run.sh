#!/usr/bin/env bash
# bench/brightness/run.sh — issue 17's brightness table: the mean linear
# luminance (Rec. 709 weights) of every technique relative to `pathtrace`
# (all scattering orders, max_depth 64) on bonsai, engine and aneurism
# (bench/ambient/*.json) under three lightings: key (the scene's own
# lights), env (only the Venice sunset HDR map, intensity 1) and mixed
# (both); also relative to `pathtrace` with max_depth 1 (single
# scattering: what single, ao, lightvol and sh model). Also records each
# technique's warnings (lights it ignores).
#
#   bench/brightness/run.sh [VOLUX] [OUTDIR]     (SPP=64 SIZE=96)
#
# Writes OUTDIR/brightness.jsonl: {"scene","lighting","technique",
# "mean_luminance","reference","ratio","reference1","ratio1","warnings"};
# table.py prints the markdown table.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
out=${2:-$here/out}
spp=${SPP:-64}
size=${SIZE:-96}
envmap=${ENVMAP:-/work/shared/data/envmaps/venice_sunset_1k.hdr}
techniques=${TECHNIQUES:-"ea shaded single ao ambient lightvol sh manylights"}
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
mkdir -p "$out"
jsonl="$out/brightness.jsonl"
: > "$jsonl"
common=(--width "$size" --height "$size" --quiet)
env_light="{\"type\": \"environment\", \"file\": \"$envmap\", \"intensity\": 1.0, \"visible\": false}"

mean_lum() { python3 "$here/pfm_mean.py" "$1"; }

for scene in bonsai engine aneurism; do
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
    ref_lum=$(mean_lum "$ref")
    # single scattering (max_depth 1): what the single-scattering techniques model
    ref1="$out/${scene}_${lighting}_pathtrace1.pfm"
    [ -f "$ref1" ] || "$volux" render "$json" --technique pathtrace --spp "$spp" --set render.max_depth=1 \
      "${set_lights[@]}" "${common[@]}" -o "$ref1"
    ref1_lum=$(mean_lum "$ref1")
    for t in $techniques; do
      img="$out/${scene}_${lighting}_$t.pfm"
      warn=$("$volux" render "$json" --technique "$t" "${set_lights[@]}" "${common[@]}" -o "$img" 2>&1 >/dev/null |
        grep -c 'warning' || true)
      lum=$(mean_lum "$img")
      ratio=$(python3 -c "print('%.4f' % ($lum / $ref_lum))")
      ratio1=$(python3 -c "print('%.4f' % ($lum / $ref1_lum))")
      echo "{\"scene\":\"$scene\",\"lighting\":\"$lighting\",\"technique\":\"$t\",\"mean_luminance\":$lum,\"reference\":$ref_lum,\"ratio\":$ratio,\"reference1\":$ref1_lum,\"ratio1\":$ratio1,\"warnings\":$warn}" | tee -a "$jsonl"
    done
  done
done
