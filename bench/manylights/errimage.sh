#!/usr/bin/env bash
# bench/manylights/errimage.sh — Weber et al. 2013 Fig. 3: the relative
# error AVSM caching introduces, |I_avsm − I_rm| / I_rm per pixel
# (luminance), AVSMs of 40² texels × 6 faces × 8 nodes, against ray-marched
# transmittance with the same seed (identical VLs and view samples: the
# difference is the cache alone).
#
#   bench/manylights/errimage.sh [VOLUX] [OUTDIR]
#
# Environment: SCENES ("bonsai engine"), SIZE (256), VLS (500), SPP (1),
# MAX (error shown as white, default 0.2), RES (AVSM texels per face side,
# 40), CONE (avsm_cone, 0: voxel steps), KERNEL (vsl_kernel, "ball"), TAG
# (suffix of the output names). Writes OUTDIR/<scene>_{avsm,
# avsm_linear,raymarch}.pfm, <scene>_relerr_{avsm,avsm_linear}.png and
# prints the mean relative error over pixels brighter than 1e-3 of the max.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
outdir=${2:-$here/out}
scenes=${SCENES:-"bonsai engine"}
size=${SIZE:-256}
vls=${VLS:-500}
spp=${SPP:-1}
max=${MAX:-0.2}
res=${RES:-40}
cone=${CONE:-0}
kernel=${KERNEL:-ball}
tag=${TAG:-}
mkdir -p "$outdir"
export OMP_WAIT_POLICY=passive
for scene in $scenes; do
  for tm in raymarch avsm avsm_linear; do
    "$volux" render "$here/$scene.json" --width "$size" --height "$size" --spp "$spp" --quiet \
        --set techniques.manylights.vl_count="$vls" --set techniques.manylights.avsm_resolution="$res" \
        --set techniques.manylights.avsm_cone="$cone" --set techniques.manylights.vsl_kernel="\"$kernel\"" \
        --set techniques.manylights.avsm_nodes=8 --set techniques.manylights.transmittance="\"$tm\"" \
        --set techniques.manylights.preview_vls=0 \
        -o "$outdir/${scene}${tag}_$tm.pfm"
  done
  for tm in avsm avsm_linear; do
    printf '%s %-12s ' "$scene" "$tm"
    python3 "$here/pfmtool.py" relerr "$outdir/${scene}${tag}_$tm.pfm" "$outdir/${scene}${tag}_raymarch.pfm" \
        "$outdir/${scene}${tag}_relerr_$tm.png" --max "$max"
  done
done
