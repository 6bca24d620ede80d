#!/bin/bash
# bench/thread_scaling.sh — wall-clock speed-up of 2 threads over 1 for the
# scenes vtk_compare.sh wrote (SCENES=$BENCH_OUT/vtk_compare/scenes, default out/bench/...).
# Each pair of runs starts once the 2-core machine is < 15 % busy (waiting up
# to WAIT_MAX s) and records the busy fraction; medians of REPEAT frames.
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
VOLUX=${VOLUX:-$(dirname "$HERE")/build/volux}
SCENES=${SCENES:-${BENCH_OUT:-$(dirname "$HERE")/out/bench}/vtk_compare/scenes}
REPEAT=${REPEAT:-9}
WAIT_MAX=${WAIT_MAX:-60}
busy() {
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
        sleep 2
    done
}
metric() { grep "\"metric\":\"$1\"" | head -1 | sed 's/.*"value":\([^,]*\),.*/\1/'; }
echo "| scene | 1 thread ms | 2 threads ms | speed-up | cpu ms (1 / 2 threads) | busy before |"
echo "|---|---|---|---|---|---|"
for s in "$SCENES"/*.json; do
    b=$(wait_idle)
    o1=$("$VOLUX" bench "$s" --json --threads 1 --repeat "$REPEAT" --edit camera)
    o2=$("$VOLUX" bench "$s" --json --threads 2 --repeat "$REPEAT" --edit camera)
    m1=$(echo "$o1" | metric render_ms); m2=$(echo "$o2" | metric render_ms)
    c1=$(echo "$o1" | metric render_cpu_ms); c2=$(echo "$o2" | metric render_cpu_ms)
    printf "| %s | %.1f | %.1f | %.2f | %.1f / %.1f | %s |\n" "$(basename "$s" .json)" "$m1" "$m2" \
        "$(awk -v a="$m1" -v b="$m2" 'BEGIN{print a/b}')" "$c1" "$c2" "$b"
done
