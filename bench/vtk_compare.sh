#!/bin/bash
# bench/vtk_compare.sh — volux side by side with VTK's CPU ray caster
# (vtkFixedPointVolumeRayCastMapper) and VolPack, in ONE run: the same data,
# transfer function, view and image size (issue 2, deliverable 10).
#
#   bench/vtk_compare.sh                  # all cases, ea + shaded, 1 and 2 threads
#   CASES="ml bonsai" TECHS=ea THREADS=2 RUNS=9 bench/vtk_compare.sh
#
# Needs: a Release build (VOLUX=build/volux), ../shared/peers set up
# (sh setup.sh; make; make volumes — see its README) and Debian's
# /usr/bin/python3 (numpy + VTK). Writes OUT (default out/bench/vtk_compare):
# results.md (table), results.csv, log.txt, images/ (PNGs, PFMs, montages).
#
# Conventions matched (../shared/peers/README.md): volume centred, orbit
# az 30 el 20 at the distance that fits the bounding sphere in fov 30,
# parallel projection with the view window 2·dist·tan(15°) high (volux's
# orthographic orbit camera frames the same way), step 0.5 voxel, opacity per
# unit distance 1, black background. `shaded` gets the peers' headlight: a
# directional light of irradiance 1 travelling along the view direction,
# ambient/diffuse/specular/power from the TF JSON; gradient_threshold is
# lowered to 0.005 because VTK does not fade shading by gradient magnitude.
# Images are compared in linear colour: the peers' PNGs hold linear values,
# volux's PFM is linear (img_convert.py).
#
# Timing: every configuration waits (up to WAIT_MAX s) for the 2-core
# machine to be <15 % busy and records what it saw. render_ms is the median
# wall time of RUNS steady-state frames; cpu_ms the median process CPU time
# per frame (all threads), the robust number when other jobs share the box.
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(dirname "$HERE")
VOLUX=${VOLUX:-$ROOT/build/volux}
VOLUX_DATA=${VOLUX_DATA:-$ROOT/../shared/data}   # docs/CONVENTIONS.md
PEERS=${PEERS:-$(cd "$VOLUX_DATA/../peers" 2>/dev/null && pwd)}
DATA=${DATA:-$(cd "$VOLUX_DATA/volumes" 2>/dev/null && pwd)}
OUT=${OUT:-${BENCH_OUT:-$ROOT/out/bench}/vtk_compare}
RUNS=${RUNS:-5}
THREADS=${THREADS:-1 2}
CASES=${CASES:-ml bonsai aneurism engine}
TECHS=${TECHS:-ea shaded}
WAIT_MAX=${WAIT_MAX:-60}
VOLPACK=${VOLPACK:-1}
PY=/usr/bin/python3
export PEERS
AZ=30 EL=20 SIZE=512

[ -x "$VOLUX" ] || { echo "vtk_compare: no volux binary at $VOLUX (build Release first)" >&2; exit 2; }
[ -n "$PEERS" ] && [ -f "$PEERS/vtk_render.py" ] || { echo "vtk_compare: $VOLUX_DATA/../peers not found" >&2; exit 2; }
if [ ! -f "$PEERS/data/ml256.nhdr" ]; then make -C "$PEERS" volumes >/dev/null || exit 1; fi
mkdir -p "$OUT/images" "$OUT/scenes"
LOG=$OUT/log.txt
: > "$LOG"

busy() {  # whole-machine CPU busy fraction over 1 s
    read -r _ a b c d e f g _ < /proc/stat; t1=$((a+b+c+d+e+f+g)); i1=$((d+e))
    sleep 1
    read -r _ a b c d e f g _ < /proc/stat; t2=$((a+b+c+d+e+f+g)); i2=$((d+e))
    awk -v t=$((t2-t1)) -v i=$((i2-i1)) 'BEGIN{printf "%.2f", (t>0)?1-i/t:0}'
}
wait_idle() {
    local start=$SECONDS b
    while :; do
        b=$(busy)
        if awk -v b="$b" 'BEGIN{exit !(b<0.15)}'; then echo "$b"; return; fi
        if (( SECONDS - start > WAIT_MAX )); then echo "${b}!"; return; fi
        sleep 3
    done
}
metric() {  # metric NAME < volux bench --json output
    grep "\"metric\":\"$1\"" | head -1 | sed 's/.*"value":\([^,]*\),.*/\1/'
}
kv() {  # kv KEY < peer output
    sed -n "s/^$1=\([0-9.]*\).*/\1/p" | tail -1
}

case_volume() {  # NAME -> "OURS_JSON|PEER_VOL|TF"
    case $1 in
        ml) echo "{\"procedural\": \"marschner_lobb\", \"dims\": [256, 256, 256]}|$PEERS/data/ml256.nhdr|$PEERS/tf/ml.json" ;;
        bonsai) echo "{\"file\": \"$DATA/bonsai_256x256x256_uint8.nhdr\"}|$DATA/bonsai_256x256x256_uint8.nhdr|$PEERS/tf/bonsai.json" ;;
        aneurism) echo "{\"file\": \"$DATA/aneurism_256x256x256_uint8.nhdr\"}|$DATA/aneurism_256x256x256_uint8.nhdr|$PEERS/tf/aneurism.json" ;;
        engine) echo "{\"file\": \"$DATA/engine_256x256x128_uint8.nhdr\"}|$DATA/engine_256x256x128_uint8.nhdr|$HERE/tf/engine.json" ;;
        *) echo "vtk_compare: unknown case $1" >&2; exit 2 ;;
    esac
}

# headlight: the light travels along the view direction (eye → centre)
LIGHT=$(awk -v az=$AZ -v el=$EL 'BEGIN{p=3.14159265358979/180; printf "[%.6f, %.6f, %.6f]", -cos(el*p)*sin(az*p), -sin(el*p), -cos(el*p)*cos(az*p)}')

{
echo "# volux vs VTK fixed-point ray caster (and VolPack)"
echo
echo "$(date -u '+%Y-%m-%d %H:%M UTC'), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(nproc) cores, load before: $(cut -d' ' -f1-3 /proc/loadavg)."
echo "${SIZE}x${SIZE}, ortho, az $AZ el $EL, step 0.5, RUNS=$RUNS. ms = median wall per frame; cpu = median CPU ms per frame (all threads)."
echo "ratio = volux / VTK (wall; cpu in parentheses) — below 1 means volux is faster. busy = machine busy fraction before the run (! = never idle within ${WAIT_MAX}s)."
echo "RMSE/PSNR: linear colour in [0,1] (VTK's 8-bit PNG vs volux PFM)."
echo
echo "| volume | technique | threads | volux ms | volux cpu | VTK ms | VTK cpu | ratio wall (cpu) | VolPack ms | volux Msamples/cpu-s | RMSE vs VTK | PSNR dB | busy (volux/VTK) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
} > "$OUT/results.md"
echo "volume,technique,threads,volux_ms,volux_cpu_ms,vtk_ms,vtk_cpu_ms,ratio_wall,ratio_cpu,volpack_ms,volux_samples_per_cpu_s,rmse,psnr,busy_volux,busy_vtk" > "$OUT/results.csv"

for name in $CASES; do
    IFS='|' read -r ours_vol peer_vol tf <<< "$(case_volume "$name")"
    for tech in $TECHS; do
        shade=off; [ "$tech" = shaded ] && shade=on
        scene=$OUT/scenes/${name}_$tech.json
        cat > "$scene" <<JSON
{
  "volume": $ours_vol,
  "transfer_function": "$tf",
  "camera": {"type": "orthographic", "orbit": {"azimuth": $AZ, "elevation": $EL}, "fov_y": 30},
  "lights": [{"type": "directional", "direction": $LIGHT, "irradiance": 1, "color": [1, 1, 1]}],
  "background": [0, 0, 0],
  "render": {"technique": "$tech", "width": $SIZE, "height": $SIZE, "step": 0.5},
  "techniques": {"shaded": {"gradient_threshold": 0.005}}
}
JSON
        peer_args=(--vol "$peer_vol" --tf "$tf" --size $SIZE $SIZE --ortho --step 0.5 --az $AZ --el $EL --shade $shade)
        img=$OUT/images/${name}_$tech
        # Images once (2 threads): volux PFM -> linear PNG; VTK PNG -> PFM.
        "$VOLUX" render "$scene" -o "$img.volux.pfm" >> "$LOG" 2>&1
        $PY "$HERE/img_convert.py" pfm2png "$img.volux.pfm" "$img.volux.png"
        for th in $THREADS; do
            b1=$(wait_idle)
            vout=$("$VOLUX" bench "$scene" --threads "$th" --repeat "$RUNS" --edit camera --json 2>&1)
            echo "=== volux $name $tech threads=$th busy=$b1" >> "$LOG"; echo "$vout" >> "$LOG"
            v_ms=$(echo "$vout" | metric render_ms); v_cpu=$(echo "$vout" | metric render_cpu_ms)
            v_sps=$(echo "$vout" | metric samples_per_cpu_s)
            b2=$(wait_idle)
            pout=$($PY "$PEERS/vtk_render.py" --mapper fixed "${peer_args[@]}" --threads "$th" --runs "$RUNS" \
                   --out "$img.vtk.png" 2>&1 | grep -v 'glx extensions')
            echo "=== vtk $name $tech threads=$th busy=$b2" >> "$LOG"; echo "$pout" >> "$LOG"
            p_ms=$(echo "$pout" | kv render_ms); p_cpu=$(echo "$pout" | kv cpu_ms)
            vp_ms=-
            if [ "$VOLPACK" = 1 ] && [ "$th" = 1 ] && [ -x "$PEERS/volpack_render" ]; then
                vpout=$("$PEERS/volpack_render" "${peer_args[@]}" --runs "$RUNS" --out "$img.volpack.png" 2>&1)
                echo "=== volpack $name $tech" >> "$LOG"; echo "$vpout" >> "$LOG"
                vp_ms=$(echo "$vpout" | kv render_ms)
            fi
            $PY "$HERE/img_convert.py" png2pfm "$img.vtk.png" "$img.vtk.pfm"
            cmp=$("$VOLUX" compare "$img.volux.pfm" "$img.vtk.pfm" --json 2>>"$LOG")
            rmse=$(echo "$cmp" | sed 's/.*"rmse":\([^,}]*\).*/\1/'); psnr=$(echo "$cmp" | sed 's/.*"psnr":\([^,}]*\).*/\1/')
            rw=$(awk -v a="$v_ms" -v b="$p_ms" 'BEGIN{printf (b>0)?"%.2f":"-", a/b}')
            rc=$(awk -v a="$v_cpu" -v b="$p_cpu" 'BEGIN{printf (b>0)?"%.2f":"-", a/b}')
            sps=$(awk -v s="$v_sps" 'BEGIN{printf "%.0f", s/1e6}')
            printf "| %s | %s | %s | %.1f | %.1f | %s | %s | %s (%s) | %s | %s | %.4f | %.1f | %s/%s |\n" \
                "$name" "$tech" "$th" "$v_ms" "$v_cpu" "$p_ms" "$p_cpu" "$rw" "$rc" "$vp_ms" "$sps" "$rmse" "$psnr" "$b1" "$b2" \
                >> "$OUT/results.md"
            echo "$name,$tech,$th,$v_ms,$v_cpu,$p_ms,$p_cpu,$rw,$rc,$vp_ms,$v_sps,$rmse,$psnr,$b1,$b2" >> "$OUT/results.csv"
            echo "$name $tech threads=$th: volux ${v_ms} ms (cpu $v_cpu) vs VTK ${p_ms} ms (cpu $p_cpu): ${rw}x (cpu ${rc}x), RMSE $rmse, busy $b1/$b2"
        done
        # side by side: volux | VTK | VolPack (+ 4x |volux − VTK|)
        extra=(); [ -f "$img.volpack.png" ] && extra=("$img.volpack.png")
        $PY "$PEERS/compare_png.py" "$img.volux.png" "$img.vtk.png" "${extra[@]}" --montage "$img.montage.png" >> "$LOG" 2>&1
    done
done
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)" >> "$OUT/results.md"
echo "wrote $OUT/results.md"
