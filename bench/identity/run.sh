#!/bin/bash
# Renders every technique on every bench scene with two volux binaries and
# compares the PFMs byte for byte (refactors that must not change images).
#   bench/identity/run.sh OLD_VOLUX NEW_VOLUX [SIZE] [SPP]
# Prints one line per (scene, technique): "same", or the largest absolute
# difference (volux compare). Needs ../shared/data for the real volumes;
# the procedural scenes in scenes/ run without it. Exit status 1 if any
# image differs.
set -u
old=${1:?usage: run.sh OLD_VOLUX NEW_VOLUX [SIZE] [SPP]}
new=${2:?usage: run.sh OLD_VOLUX NEW_VOLUX [SIZE] [SPP]}
size=${3:-128}
spp=${4:-2}
cd "$(dirname "$0")/../.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
techniques="ea shaded pathtrace single ao ambient lightvol"
# A small table keeps `ambient` quick; both binaries build (or load) the same one.
common=(--width "$size" --height "$size" --spp "$spp" --threads 2
        --set techniques.ambient.table_paths=512 --set techniques.ambient.table_theta=64
        --set techniques.ambient.table_sigma=64 --set techniques.ambient.table_g=5)
differ=0
scenes=(scenes/*.json)
[[ -d ${VOLUX_DATA:-../shared/data}/volumes ]] && scenes+=(bench/scenes/*.json bench/ambient/*.json)
for scene in "${scenes[@]}"; do
  for t in $techniques; do
    name=$(basename "$scene" .json)_$t
    "$old" render "$scene" --technique "$t" "${common[@]}" -o "$tmp/old.pfm" >/dev/null 2>"$tmp/old.err"; ro=$?
    "$new" render "$scene" --technique "$t" "${common[@]}" -o "$tmp/new.pfm" >/dev/null 2>"$tmp/new.err"; rn=$?
    if ((ro != 0 || rn != 0)); then
      if ((ro != rn)); then echo "$name: exit $ro vs $rn ($(tail -n1 "$tmp/new.err"))"; differ=1
      else echo "$name: both fail ($(tail -n1 "$tmp/new.err" | cut -c1-80))"; fi
      continue
    fi
    if cmp -s "$tmp/old.pfm" "$tmp/new.pfm"; then echo "$name: same"
    else echo "$name: DIFFERENT max_abs $("$new" compare "$tmp/new.pfm" "$tmp/old.pfm" --json | sed 's/.*"max_abs": *\([^,}]*\).*/\1/')"; differ=1; fi
  done
done
exit $differ
