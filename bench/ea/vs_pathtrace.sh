#!/usr/bin/env bash
# bench/ea/vs_pathtrace.sh — `ea` against the reference path tracer on real
# volumes (docs/techniques/ea.md, "Error against pathtrace").
#
#   bench/ea/vs_pathtrace.sh [VOLUX] [OUTDIR]
#
# Scenes: bench/ambient/{bonsai,engine,aneurism}.json (256³ / 256²×128
# CT data from ../shared/data, their transfer functions and lights), in two
# setups:
#   absorb — albedo 0, black colour, the lights replaced by a visible white
#            environment of radiance 1: pathtrace computes T·1, and so does
#            ea (no emission). The model is exact; what is left is ea's
#            discretisation (pre-integrated segments of `render.step`,
#            early termination) against delta tracking.
#   lit    — the scenes as they are (albedo 0.9–0.95, directional/point
#            lights, black background) against pathtrace with all orders:
#            ea's emission colour is not a radiance, so this measures how
#            far the picture is from the physics, not an error to reduce.
# ea is rendered at 4× the size and box-averaged 4×4 (one ray per
# sub-pixel: the pixel filter pathtrace integrates; one ray per pixel
# centre would add an error of the comparison at the data's sharp edges).
# Each reference is rendered twice (seeds 1 and 2) so its own noise is
# known: "noise" = rmse(seed 2 vs seed 1)/sqrt(2)/mean, the relative RMS
# error of one reference image.
# Prints one line per (scene, setup): rel_mse (`volux compare`), rmse/mean,
# mean(ea)/mean(pt) − 1, rmse/mean with ea scaled to pathtrace's mean, and
# the noise; writes OUTDIR/*.pfm and the
# montages OUTDIR/ea_vs_pathtrace_{absorb,lit}.png (ea | pathtrace | |diff|).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
out=${2:-${BENCH_OUT:-$(cd "$(dirname "$0")/../.." && pwd)/out/bench}/ea_vs_pathtrace}
size=${SIZE:-128}
spp_absorb=${SPP_ABSORB:-1024}
spp_lit=${SPP_LIT:-256}
scenes=${SCENES:-"bonsai engine aneurism"}
mkdir -p "$out"
common=(--width "$size" --height "$size" --quiet)
absorb=(--set transfer_function.albedo=0 --set 'transfer_function.color=[[0,0,0,0],[255,0,0,0]]'
        --set 'lights=[{"type":"environment","radiance":1}]')

# rmse/mean, mean ratio − 1, and rmse/mean after scaling A to B's mean, of
# A against B (linear PFMs)
stats() {
  python3 - "$1" "$2" <<'EOF'
import struct, sys, math
def load(p):
    with open(p, "rb") as f:
        f.readline(); w, h = map(int, f.readline().split()); s = float(f.readline())
        return struct.unpack(("<" if s < 0 else ">") + "%df" % (w * h * 3), f.read(w * h * 12))
a, b = load(sys.argv[1]), load(sys.argv[2])
n = len(b); mb = sum(b) / n; ma = sum(a) / n
k = mb / ma if ma > 0 else 0.0  # a scaled to b's mean: the error a brightness factor cannot fix
print("%.4g %+.4f %.4g" % (math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)) / n) / mb, ma / mb - 1,
                           math.sqrt(sum((k * x - y) ** 2 for x, y in zip(a, b)) / n) / mb))
EOF
}

# 4×4 box average of a PFM (A → B)
shrink() {
  python3 - "$1" "$2" <<'EOF'
import struct, sys
with open(sys.argv[1], "rb") as f:
    f.readline(); w, h = map(int, f.readline().split()); s = float(f.readline())
    v = struct.unpack(("<" if s < 0 else ">") + "%df" % (w * h * 3), f.read(w * h * 12))
k = 4; W, H = w // k, h // k
out = []
for y in range(H):  # rows stay bottom-up, as in the file
    for x in range(W):
        for c in range(3):
            out.append(sum(v[3 * ((y * k + j) * w + x * k + i) + c] for j in range(k) for i in range(k)) / (k * k))
with open(sys.argv[2], "wb") as f:
    f.write(b"PF\n%d %d\n-1.0\n" % (W, H))
    f.write(struct.pack("<%df" % len(out), *out))
EOF
}

for setup in absorb lit; do
  rows=()
  for scene in $scenes; do
    json="$here/../ambient/$scene.json"
    extra=()
    spp=$spp_lit
    if [ "$setup" = absorb ]; then extra=("${absorb[@]}"); spp=$spp_absorb; fi
    pre="$out/${scene}_$setup"
    "$volux" render "$json" --technique ea --width $((4 * size)) --height $((4 * size)) --quiet "${extra[@]}" \
      -o "$pre.ea4.pfm"
    shrink "$pre.ea4.pfm" "$pre.ea.pfm"
    for seed in 1 2; do
      [ -f "$pre.pt$seed.pfm" ] ||
        "$volux" render "$json" --technique pathtrace --spp "$spp" --seed "$seed" --set render.max_depth=64 \
          "${common[@]}" "${extra[@]}" -o "$pre.pt$seed.pfm"
    done
    rel_mse=$("$volux" compare "$pre.ea.pfm" "$pre.pt1.pfm" --json | sed 's/.*"rel_mse":\([^,]*\),.*/\1/')
    read -r rel_rmse mean_diff scaled < <(stats "$pre.ea.pfm" "$pre.pt1.pfm")
    read -r noise2 _ _ < <(stats "$pre.pt2.pfm" "$pre.pt1.pfm")
    noise=$(python3 -c "print('%.3g' % ($noise2 / 2 ** 0.5))")
    printf '%-9s %-7s rel_mse %-11s rmse/mean %-8s mean %-8s scaled rmse/mean %-8s pt noise %s\n' \
      "$scene" "$setup" "$rel_mse" "$rel_rmse" "$mean_diff" "$scaled" "$noise"
    # |diff| shown white at 0.1 (absorb) or 0.25 (lit)
    s=0.1; [ "$setup" = lit ] && s=0.25
    rows+=("$pre.ea.pfm,$pre.pt1.pfm,diff:$pre.ea.pfm:$pre.pt1.pfm:$s")
  done
  python3 "$here/montage.py" "$out/ea_vs_pathtrace_$setup.png" "${rows[@]}"
done
