#!/bin/bash
# bench/kernel_rates.sh — ray-marching throughput of the `ea` kernels in the
# configuration of ../shared/perf/LIMITS.md: Marschner–Lobb 256³ uint8,
# 512×512, step 0.5 voxel, trilinear, no early termination, no empty-space
# skipping; axis-aligned (az 0 el 0) and oblique (az 30 el 20) orthographic
# views. Prints million samples per CPU-second (= per core: robust on a
# shared machine) for the scalar and SIMD kernels, with and without
# pre-integration, and the wall-clock rate at 1 and 2 threads. SIMD kernels
# (KERNELS, default "avx2 simd"): "avx2" = the 8-lane packets, "simd" = the
# widest the CPU has (16-lane AVX-512 where present).
#   bench/kernel_rates.sh [REPEAT]      (VOLUX=build/volux)
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
VOLUX=${VOLUX:-$(dirname "$HERE")/build/volux}
REPEAT=${1:-5}
S=$HERE/scenes/ml256.json
metric() { grep "\"metric\":\"$1\"" | head -1 | sed 's/.*"value":\([^,]*\),.*/\1/'; }
echo "| view | kernel | pre-integration | threads | M samples / CPU-s | M samples / s (wall) | render_ms | render_cpu_ms |"
echo "|---|---|---|---|---|---|---|---|"
for view in "0 0" "30 20"; do
    set -- $view
    for kernel in scalar ${KERNELS:-avx2 simd}; do
        for pre in false true; do
            for th in 1 2; do
                out=$("$VOLUX" bench "$S" --json --repeat "$REPEAT" --threads "$th" --edit camera \
                    --set camera.orbit.azimuth="$1" --set camera.orbit.elevation="$2" \
                    --set techniques.ea.kernel="\"$kernel\"" --set techniques.ea.preintegrate=$pre \
                    --set techniques.ea.early_termination=0 --set techniques.ea.skip_empty=false)
                printf "| az %s el %s | %s | %s | %s | %.1f | %.1f | %.1f | %.1f |\n" "$1" "$2" "$kernel" "$pre" "$th" \
                    "$(echo "$out" | metric samples_per_cpu_s | awk '{print $1/1e6}')" \
                    "$(echo "$out" | metric samples_per_s | awk '{print $1/1e6}')" \
                    "$(echo "$out" | metric render_ms)" "$(echo "$out" | metric render_cpu_ms)"
            done
        done
    done
done
