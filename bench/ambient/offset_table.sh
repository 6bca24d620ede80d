#!/usr/bin/env bash
# bench/ambient/offset_table.sh — issue 17's accuracy table: rel_mse against
# `pathtrace` (all scattering orders, max_depth 64) of single, ao and
# ambient: the camera offsets constant (Eq. 20), offset 0 and adaptive (the
# old default) with the table's albedo weighting as before (albedo_once
# false), adaptive with albedo_once, and fill (the default) over thin / medium / dense procedural media
# (media/*.json) at r = 2, 4, 8, 14 voxels and on bonsai, engine,
# aneurism (their own r), all at SIZE² pixels.
#
#   bench/ambient/offset_table.sh [VOLUX] [OUTDIR]   (SPP=256 SIZE=96)
#
# References are kept in OUTDIR and reused. Writes OUTDIR/offset.jsonl
# ({"scene","technique","variant","radius","rel_mse"} lines); summarize
# with offset_table.py.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
out=${2:-$here/out/offset}
spp=${SPP:-256}
size=${SIZE:-96}
media=${MEDIA:-"thin medium dense"}
volumes=${VOLUMES:-"bonsai engine aneurism"}
radii=${RADII:-"2 4 8 14"}
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
mkdir -p "$out"
common=(--width "$size" --height "$size" --quiet)
jsonl="$out/offset.jsonl"
: > "$jsonl"

# one render + compare: NAME SCENE TECH VARIANT RADIUS [--set ...]
measure() {
  local name=$1 scene=$2 tech=$3 variant=$4 radius=$5
  shift 5
  local img="$out/${name}_${tech}_${variant}_r${radius}.pfm"
  "$volux" render "$scene" --technique "$tech" "${common[@]}" "$@" -o "$img" 2>>"$out/stderr.log"
  local cmp
  cmp=$("$volux" compare "$img" "$out/${name}_pathtrace.pfm" --json)
  echo "{\"scene\":\"$name\",\"technique\":\"$tech\",\"variant\":\"$variant\",\"radius\":$radius,${cmp#\{}" >> "$jsonl"
}

reference() {
  local name=$1 scene=$2
  local ref="$out/${name}_pathtrace.pfm"
  [ -f "$ref" ] || "$volux" render "$scene" --technique pathtrace --spp "$spp" --set render.max_depth=64 \
    "${common[@]}" -o "$ref"
}

ambient_variants() { # NAME SCENE RADIUS
  local name=$1 scene=$2 r=$3
  local rs=(--set techniques.ambient.radius="$r")
  local old=(--set techniques.ambient.albedo_once=false) # the table's albedo weighting as before issue 17
  measure "$name" "$scene" ambient constant "$r" "${rs[@]}" "${old[@]}" --set 'techniques.ambient.offset_mode="constant"'
  measure "$name" "$scene" ambient offset0 "$r" "${rs[@]}" "${old[@]}" --set 'techniques.ambient.offset_mode="adaptive"' \
    --set techniques.ambient.offset=0
  measure "$name" "$scene" ambient adaptive "$r" "${rs[@]}" "${old[@]}" --set 'techniques.ambient.offset_mode="adaptive"'
  measure "$name" "$scene" ambient adaptive_once "$r" "${rs[@]}" --set 'techniques.ambient.offset_mode="adaptive"'
  measure "$name" "$scene" ambient fill "$r" "${rs[@]}"
}

if [ -n "${REFS_ONLY:-}" ]; then # render the references only
  for m in $media; do reference "$m" "$here/media/$m.json"; done
  for v in $volumes; do reference "$v" "$here/$v.json"; done
  exit 0
fi
for m in $media; do
  scene="$here/media/$m.json"
  reference "$m" "$scene"
  measure "$m" "$scene" single default 0
  for r in $radii; do
    measure "$m" "$scene" ao default "$r" --set techniques.ao.radius="$r"
    ambient_variants "$m" "$scene" "$r"
  done
done
for v in $volumes; do
  scene="$here/$v.json"
  r=$(grep -o '"ambient": {"radius": [0-9.]*' "$scene" | grep -o '[0-9.]*$')
  reference "$v" "$scene"
  measure "$v" "$scene" single default 0
  measure "$v" "$scene" ao default "$r"
  ambient_variants "$v" "$scene" "$r"
done
cat "$jsonl"
