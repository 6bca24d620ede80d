#!/usr/bin/env bash
# bench/manylights/vs_pathtrace.sh — error of manylights against the
# unbiased reference `pathtrace` (multiple scattering, max_depth 64) as the
# VL count N grows, the VL-set variance (Weber et al. 2013 Fig. 4: SEEDS
# different VL sets per N), and `single` / `ambient` on the same scenes.
#
#   bench/manylights/vs_pathtrace.sh [VOLUX] [OUTDIR]
#
# Environment: SCENES ("bonsai engine"), SIZE (192), REF_SPP (1024),
# SPP (manylights pixel samples, 16), COUNTS ("100 250 500 1000 2000"),
# SEEDS ("1 2 3 4"), SET (extra --set arguments for manylights, e.g.
# "techniques.manylights.vsl_radius=8"), TAG (name of this configuration).
# Writes OUTDIR/vs_pathtrace.jsonl ({"scene","technique","tag","vl_count",
# "seed","rel_mse","rmse","psnr","mean_lum"}), the reference and every
# image as PFM, <scene>_side_by_side.png (single, ambient, manylights
# N=1000 seed 1, pathtrace) and <scene>_vlset_relerr.png (|I_seed1 −
# I_seed2| / I_seed1 at N=200, Fig. 4).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
outdir=${2:-$here/out}
scenes=${SCENES:-"bonsai engine"}
size=${SIZE:-192}
ref_spp=${REF_SPP:-1024}
spp=${SPP:-16}
counts=${COUNTS:-"100 250 500 1000 2000"}
seeds=${SEEDS:-"1 2 3 4"}
tag=${TAG:-default}
extra=()
for s in ${SET:-}; do extra+=(--set "$s"); done
mkdir -p "$outdir"
out="$outdir/vs_pathtrace.jsonl"
export OMP_WAIT_POLICY=passive
common=(--width "$size" --height "$size" --quiet)
record() { # scene technique n seed image
  local lum
  lum=$(python3 -c "import sys; sys.path.insert(0, '$here'); from pfmtool import read_pfm, lum
w, h, p = read_pfm('$5'); print('%.6g' % (sum(lum(p, i) for i in range(w * h)) / (w * h)))")
  "$volux" compare "$5" "$outdir/${1}_pathtrace.pfm" --json |
    sed -e "s/^{/{\"scene\":\"$1\",\"technique\":\"$2\",\"tag\":\"$tag\",\"vl_count\":$3,\"seed\":$4,\"mean_lum\":$lum,/" >> "$out"
}
for scene in $scenes; do
  ref="$outdir/${scene}_pathtrace.pfm"
  if [ ! -f "$ref" ]; then
    echo "vs_pathtrace: reference $scene ($ref_spp spp)" >&2
    "$volux" render "$here/$scene.json" --technique pathtrace --spp "$ref_spp" --set render.max_depth=64 \
        "${common[@]}" -o "$ref"
  fi
  for t in single ambient; do
    [ -f "$outdir/${scene}_$t.pfm" ] || "$volux" render "$here/$scene.json" --technique "$t" "${common[@]}" -o "$outdir/${scene}_$t.pfm"
    record "$scene" "$t" 0 0 "$outdir/${scene}_$t.pfm"
  done
  for n in $counts; do
    for seed in $seeds; do
      img="$outdir/${scene}_${tag}_n${n}_s${seed}.pfm"
      "$volux" render "$here/$scene.json" --spp "$spp" --seed "$seed" --set render.max_depth=64 \
          --set techniques.manylights.vl_count="$n" "${extra[@]}" "${common[@]}" -o "$img"
      record "$scene" manylights "$n" "$seed" "$img"
      echo "vs_pathtrace: $scene $tag N=$n seed=$seed done" >&2
    done
  done
  # Fig. 4: two VL sets of 200
  for seed in 1 2; do
    "$volux" render "$here/$scene.json" --spp "$spp" --seed "$seed" --set render.max_depth=64 \
        --set techniques.manylights.vl_count=200 "${extra[@]}" "${common[@]}" -o "$outdir/${scene}_${tag}_n200_s$seed.pfm"
  done
  printf '%s fig4 (200 VLs, two sets): ' "$scene"
  python3 "$here/pfmtool.py" relerr "$outdir/${scene}_${tag}_n200_s2.pfm" "$outdir/${scene}_${tag}_n200_s1.pfm" \
      "$outdir/${scene}_${tag}_vlset_relerr.png" --max 1.0
  python3 "$here/pfmtool.py" png "$outdir/${scene}_${tag}_side_by_side.png" "$outdir/${scene}_single.pfm" \
      "$outdir/${scene}_ambient.pfm" "$outdir/${scene}_${tag}_n1000_s1.pfm" "$ref"
done
echo "wrote $out" >&2
