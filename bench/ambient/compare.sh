#!/usr/bin/env bash
# bench/ambient/compare.sh — error of ao / single / ambient against the
# unbiased reference `pathtrace` on the scenes of this folder (rel_mse from
# `volux compare --json`), and side-by-side images.
#
#   bench/ambient/compare.sh [VOLUX] [OUTDIR]     (SPP=1024 for the reference)
#
# Needs the `pathtrace` technique (it lands on main separately); the
# reference is rendered once per scene and kept in OUTDIR. Writes
# OUTDIR/errors.jsonl: {"scene","technique","rel_mse","rmse","psnr"} lines.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
outdir=${2:-${BENCH_OUT:-$here/../../out/bench}/ambient_compare}
spp=${SPP:-1024}
scenes=${SCENES:-"bonsai engine aneurism"}
size=${SIZE:-512}
mkdir -p "$outdir"
if ! "$volux" techniques --brief | grep -q '^pathtrace '; then
  echo "compare.sh: this volux has no 'pathtrace' technique yet (merge main first)" >&2
  exit 2
fi
: > "$outdir/errors.jsonl"
for scene in $scenes; do
  ref="$outdir/${scene}_pathtrace.pfm"
  common=(--width "$size" --height "$size" --quiet)
  if [ ! -f "$ref" ]; then
    echo "compare: reference $scene ($spp spp)" >&2
    "$volux" render "$here/$scene.json" --technique pathtrace --spp "$spp" "${common[@]}" -o "$ref"
  fi
  # ambient_o0: the camera transmittance taken at x instead of Eq. 20's x_o
  for tech in ao single ambient ambient_o0; do
    img="$outdir/${scene}_${tech}.pfm"
    if [ "$tech" = ambient_o0 ]; then
      "$volux" render "$here/$scene.json" --technique ambient --set techniques.ambient.offset=0 "${common[@]}" -o "$img"
    else
      "$volux" render "$here/$scene.json" --technique "$tech" "${common[@]}" -o "$img"
    fi
    "$volux" compare "$img" "$ref" --json |
      sed -e "s/^{/{\"scene\":\"$scene\",\"technique\":\"$tech\",/" >> "$outdir/errors.jsonl"
  done
  if command -v convert >/dev/null && command -v montage >/dev/null; then
    # linear PFM → sRGB PNG for viewing (no exposure change)
    for t in ao single ambient ambient_o0 pathtrace; do
      convert "$outdir/${scene}_$t.pfm" -set colorspace RGB -colorspace sRGB "$outdir/${scene}_$t.png"
    done
    montage "$outdir/${scene}"_{ao,single,ambient,ambient_o0,pathtrace}.png -tile 5x1 -geometry +2+2 "$outdir/${scene}_side_by_side.png"
  fi
done
cat "$outdir/errors.jsonl"
