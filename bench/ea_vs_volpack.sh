#!/bin/bash
# bench/ea_vs_volpack.sh — `ea` against VolPack's shear-warp on one volume
# (issue 19): time per frame at several march steps and kernel widths, and
# every image's PSNR against a step-0.05 `ea` reference (VolPack's too), in
# ONE run with interleaved rounds, 1 thread.
#
#   PEERS=/path/to/built/peers bench/ea_vs_volpack.sh            # bonsai
#   VOL=.../aneurism_256x256x256_uint8.nhdr TF=$PEERS/tf/aneurism.json ROUNDS=5 bench/ea_vs_volpack.sh
#   KERNELS="simd simd:bricked simd:corner_words" bench/ea_vs_volpack.sh   # volume_layout per kernel (default auto)
#
# Needs a Release build (VOLUX=build/volux), ../shared/peers built (`make`:
# volpack_render; Debian's /usr/bin/python3 with numpy for img_convert.py)
# and the volume. Orthographic orbit az 30 el 20, 512², no shading (the
# peers' conventions, bench/vtk_compare.sh). Prints one table row per
# configuration: median CPU ms per frame (robust on a shared machine),
# median wall ms, PSNR against the reference. OUT keeps scenes and images.
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(dirname "$HERE")
VOLUX=${VOLUX:-$ROOT/build/volux}
PEERS=${PEERS:-$(cd "$ROOT/../shared/peers" 2>/dev/null && pwd)}
VOL=${VOL:-$(cd "$ROOT/../shared/data/volumes" 2>/dev/null && pwd)/bonsai_256x256x256_uint8.nhdr}
TF=${TF:-$PEERS/tf/bonsai.json}
OUT=${OUT:-/tmp/volux_ea_vs_volpack}
ROUNDS=${ROUNDS:-5}
STEPS=${STEPS:-0.5 1 2 3 4}
KERNELS=${KERNELS:-simd avx2}
PY=/usr/bin/python3
export PEERS OMP_WAIT_POLICY=passive
[ -x "$VOLUX" ] || { echo "ea_vs_volpack: no volux binary at $VOLUX" >&2; exit 2; }
[ -x "$PEERS/volpack_render" ] || { echo "ea_vs_volpack: build the peers first (make -C PEERS)" >&2; exit 2; }
[ -f "$VOL" ] || { echo "ea_vs_volpack: no volume $VOL" >&2; exit 2; }
mkdir -p "$OUT"

scene() {  # scene STEP KERNEL[:LAYOUT] -> path (LAYOUT: volume_layout, default auto)
    local f="$OUT/ea_$1_$2.json" kernel=${2%%:*} layout=auto
    [ "$kernel" != "$2" ] && layout=${2#*:}
    cat > "$f" <<EOF
{"volume": {"file": "$VOL"}, "transfer_function": "$TF",
 "camera": {"type": "orthographic", "orbit": {"azimuth": 30, "elevation": 20}, "fov_y": 30},
 "background": [0, 0, 0],
 "render": {"technique": "ea", "width": 512, "height": 512, "step": $1},
 "techniques": {"ea": {"kernel": "$kernel", "volume_layout": "$layout"}}}
EOF
    echo "$f"
}
value() { grep "\"metric\":\"$1\"" | head -1 | sed 's/.*"value":\([^,]*\),.*/\1/'; }
med() { tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END{print a[int((NR+1)/2)]}'; }

# reference and images (2 threads: not timed)
"$VOLUX" render "$(scene 0.05 simd)" --threads 2 -o "$OUT/ref.pfm" --quiet || exit 1
declare -A CPU WALL PSNR
for k in $KERNELS; do for s in $STEPS; do
    "$VOLUX" render "$(scene "$s" "$k")" --threads 2 -o "$OUT/ea_${s}_$k.pfm" --quiet || exit 1
    PSNR[$k/$s]=$("$VOLUX" compare "$OUT/ea_${s}_$k.pfm" "$OUT/ref.pfm" --json | sed 's/.*"psnr":\([^,}]*\).*/\1/')
done; done
VP="$PEERS/volpack_render --vol $VOL --tf $TF --size 512 512 --ortho --az 30 --el 20 --step 0.5 --shade off --runs 5"
$VP --out "$OUT/volpack.png" > /dev/null 2>&1 && $PY "$HERE/img_convert.py" png2pfm "$OUT/volpack.png" "$OUT/volpack.pfm"
PSNR[volpack]=$("$VOLUX" compare "$OUT/volpack.pfm" "$OUT/ref.pfm" --json | sed 's/.*"psnr":\([^,}]*\).*/\1/')

for r in $(seq "$ROUNDS"); do
    for k in $KERNELS; do for s in $STEPS; do
        o=$("$VOLUX" bench "$OUT/ea_${s}_$k.json" --threads 1 --repeat 3 --edit camera --json 2>&1)
        CPU[$k/$s]="${CPU[$k/$s]:-} $(echo "$o" | value render_cpu_ms)"
        WALL[$k/$s]="${WALL[$k/$s]:-} $(echo "$o" | value render_ms)"
    done; done
    o=$($VP --out "$OUT/volpack_t.png" 2>&1)
    CPU[volpack]="${CPU[volpack]:-} $(echo "$o" | sed -n 's/^cpu_ms=\([0-9.]*\).*/\1/p')"
    WALL[volpack]="${WALL[volpack]:-} $(echo "$o" | sed -n 's/^render_ms=//p')"
done

echo "$(date -u '+%Y-%m-%d %H:%M UTC'), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg), $ROUNDS rounds"
echo "| renderer | step | CPU ms (median) | wall ms (median) | × VolPack (CPU) | PSNR vs step-0.05 ea, dB |"
echo "|---|---|---|---|---|---|"
vp=$(echo "${CPU[volpack]}" | med)
printf "| VolPack shear-warp | 1 per slice | %s | %s | 1.00 | %.1f |\n" "$vp" "$(echo "${WALL[volpack]}" | med)" "${PSNR[volpack]}"
for k in $KERNELS; do for s in $STEPS; do
    c=$(echo "${CPU[$k/$s]}" | med)
    printf "| volux ea %s | %s | %s | %s | %.2f | %.1f |\n" "$k" "$s" "$c" "$(echo "${WALL[$k/$s]}" | med)" \
        "$(awk -v a="$c" -v b="$vp" 'BEGIN{print a/b}')" "${PSNR[$k/$s]}"
done; done
