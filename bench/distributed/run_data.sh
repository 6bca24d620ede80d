#!/bin/bash
# bench/distributed/run_data.sh [OUT.jsonl] — data-parallel (sort-last)
# rendering, --distribute data (issue 15), on this machine: per-rank brick
# render time, compositing time (binary swap with the "over" operation in
# visibility order) against the image size and the rank count, and the
# bytes of the volume each rank holds, for `ea` and `shaded` on
# Marschner–Lobb 256³ (procedural) and the bonsai (256³ gzip NRRD, each
# rank streams the file and keeps its brick). One thread per rank; 3-4
# ranks oversubscribe a 2-core machine. Prints JSON lines (volux bench
# --json) and writes them to OUT.jsonl (default
# $BENCH_OUT/distributed/data.jsonl, BENCH_OUT default out/bench).
. "$(dirname "$0")/common.sh" "${1:-}" data.jsonl data 3
for n in 1 2 3 4; do
  run "$n" bench/scenes/ml256.json --spp 1
  run "$n" scenes/bonsai.json --technique shaded --width 512 --height 512 --spp 1
done
# Compositing against the image size (2 ranks, ea, one sample).
for size in 256 1024; do
  run 2 bench/scenes/ml256.json --spp 1 --width "$size" --height "$size"
done
mv "$OUT.tmp" "$OUT"
