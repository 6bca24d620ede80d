#!/usr/bin/env bash
# bench/march/run.sh — issue 26 item 3: frame time and march throughput of
# the illuminated ray casters at 512², 2 threads, bonsai (sun + sky, the
# default settings of each technique), after preparation, with the camera
# march forced scalar and dispatched (SIMD packets, render/packet_impl.h).
#
#   bench/march/run.sh VOLUX_BINARY [OUT_DIR]
#
# Prints one line per technique and kernel: render_ms and render_cpu_ms
# (medians of the repeats), samples_per_s (wall) and samples_per_cpu_s
# (volume samples per CPU-second), from `volux bench --json`.
# Needs VOLUX_DATA (the shared data folder); the numbers go to
# docs/BENCHMARKS.md ("One packet march for the illuminated ray casters").
set -euo pipefail
BIN=${1:?usage: run.sh VOLUX_BINARY [OUT_DIR]}
OUT=${2:-/tmp/volux_march_bench}
HERE=$(cd "$(dirname "$0")" && pwd)
SCENE=${SCENE:-$HERE/../scenes/pt_bonsai_sun.json}
REPEAT=${REPEAT:-3} # prepare_ms is measured REPEAT times too
TECHS=${TECHS:-"single ao ambient lightvol sh"}
KERNELS=${KERNELS:-"scalar auto"}
export VOLUX_DATA=${VOLUX_DATA:-/work/shared/data}
mkdir -p "$OUT"
echo "# $(date -u +%FT%TZ) $(uptime)"
for t in $TECHS; do
  for k in $KERNELS; do
    # "default": no march_kernel (a build before the packet march has none)
    kset=()
    [ "$k" = default ] || kset=(--set "techniques.$t.march_kernel=\"$k\"")
    set +e
    timeout 900 "$BIN" bench "$SCENE" --technique "$t" --repeat "$REPEAT" --json --width 512 --height 512 \
      --threads 2 --set "render.spp=1" "${kset[@]}" > "$OUT/$t.$k.json" 2> "$OUT/$t.$k.err"
    rc=$?
    set -e
    ms=$(grep '"metric": *"render_ms"' "$OUT/$t.$k.json" | sed 's/.*"value": *\([0-9.e+-]*\).*/\1/' | head -1)
    sps=$(grep '"metric": *"samples_per_s"' "$OUT/$t.$k.json" | sed 's/.*"value": *\([0-9.e+-]*\).*/\1/' | head -1)
    prep=$(grep '"metric": *"prepare_ms"' "$OUT/$t.$k.json" | sed 's/.*"value": *\([0-9.e+-]*\).*/\1/' | head -1)
    cpu=$(grep '"metric": *"render_cpu_ms"' "$OUT/$t.$k.json" | sed 's/.*"value": *\([0-9.e+-]*\).*/\1/' | head -1)
    spc=$(grep '"metric": *"samples_per_cpu_s"' "$OUT/$t.$k.json" | sed 's/.*"value": *\([0-9.e+-]*\).*/\1/' | head -1)
    echo "$t march_kernel=$k rc=$rc render_ms=${ms:-?} render_cpu_ms=${cpu:-?} samples_per_s=${sps:-?}" \
         "samples_per_cpu_s=${spc:-?} prepare_ms=${prep:-?}"
  done
done
