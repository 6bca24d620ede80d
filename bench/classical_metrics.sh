#!/bin/bash
# bench/classical_metrics.sh — the issue-2 metric set for `ea` and `shaded`:
# prepare_ms, render_ms (wall and CPU), samples_per_s, update_ms.tf,
# update_ms.camera, memory_bytes; 512×512, the real volumes of $VOLUX_DATA and
# a 256³ procedural volume; 1 and 2 threads. Prints a markdown table and
# keeps the raw JSON lines in $OUT/metrics.jsonl.
#   bench/classical_metrics.sh            (REPEAT=7 THREADS="1 2" by default)
set -eu
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(dirname "$HERE")
VOLUX=${VOLUX:-$ROOT/build/volux}
VOLUX_DATA=${VOLUX_DATA:-$ROOT/../shared/data}   # docs/CONVENTIONS.md
DATA=${DATA:-$(cd "$VOLUX_DATA/volumes" && pwd)}
TF=${TF:-$(cd "$VOLUX_DATA/../peers/tf" && pwd)}
OUT=${OUT:-${BENCH_OUT:-$ROOT/out/bench}/classical}
REPEAT=${REPEAT:-7}
THREADS=${THREADS:-1 2}
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
mkdir -p "$OUT"
: > "$OUT/metrics.jsonl"
volume_of() {
  case $1 in
    ml256) echo "{\"procedural\": \"marschner_lobb\", \"dims\": [256, 256, 256]}|$TF/ml.json" ;;
    bonsai) echo "{\"file\": \"$DATA/bonsai_256x256x256_uint8.nhdr\"}|$TF/bonsai.json" ;;
    aneurism) echo "{\"file\": \"$DATA/aneurism_256x256x256_uint8.nhdr\"}|$TF/aneurism.json" ;;
    engine) echo "{\"file\": \"$DATA/engine_256x256x128_uint8.nhdr\"}|$HERE/tf/engine.json" ;;
  esac
}
for name in ml256 bonsai aneurism engine; do
  IFS='|' read -r vol tf <<< "$(volume_of $name)"
  for tech in ea shaded; do
    scene=$OUT/${name}_$tech.json
    cat > "$scene" <<JSON
{ "volume": $vol, "transfer_function": "$tf",
  "camera": {"type": "orthographic", "orbit": {"azimuth": 30, "elevation": 20}, "fov_y": 30},
  "lights": [{"type": "directional", "direction": [-0.4, -0.5, -0.75], "irradiance": 1}],
  "render": {"technique": "$tech", "width": 512, "height": 512, "step": 0.5} }
JSON
    for th in $THREADS; do
      "$VOLUX" bench "$scene" --threads "$th" --repeat "$REPEAT" --edit tf --edit camera --json \
        | sed "s|\"scene\":\"[^\"]*\"|\"scene\":\"$name\"|" >> "$OUT/metrics.jsonl"
    done
  done
done
echo "| volume | technique | threads | prepare ms | render ms | render cpu ms | M samples/s | update_ms.tf | update_ms.camera | memory MB |"
echo "|---|---|---|---|---|---|---|---|---|---|"
awk '
  { match($0, /"scene":"[^"]*"/); s = substr($0, RSTART + 9, RLENGTH - 10)
    match($0, /"technique":"[^"]*"/); t = substr($0, RSTART + 13, RLENGTH - 14)
    match($0, /"threads":[0-9]+/); th = substr($0, RSTART + 10, RLENGTH - 10)
    match($0, /"metric":"[^"]*"/); m = substr($0, RSTART + 10, RLENGTH - 11)
    match($0, /"value":[^,]*/); v = substr($0, RSTART + 8, RLENGTH - 8)
    k = s "|" t "|" th; if (!(k in seen)) { seen[k] = 1; order[++n] = k } val[k, m] = v }
  END { for (i = 1; i <= n; i++) { k = order[i]; split(k, p, "|")
    printf "| %s | %s | %s | %.1f | %.1f | %.1f | %.0f | %.2f | %.4f | %.0f |\n", p[1], p[2], p[3],
      val[k, "prepare_ms"], val[k, "render_ms"], val[k, "render_cpu_ms"], val[k, "samples_per_s"] / 1e6,
      val[k, "update_ms.tf"], val[k, "update_ms.camera"], val[k, "memory_bytes"] / 1048576 } }' "$OUT/metrics.jsonl"
