#!/bin/bash
# bench/distributed/run.sh [OUT.jsonl] — the MPI front end (issue 15) on
# this machine: strong scaling of image-parallel rendering over 1-4 ranks
# (one thread each; 3-4 ranks oversubscribe a 2-core machine) for `ea` and
# `pathtrace` at 512², and the compositing time against the image size.
# Needs an MPI build (mpirun) and the shared data ($VOLUX_DATA, default
# ../shared/data; docs/CONVENTIONS.md); prints JSON lines (volux bench
# --json plus "ranks") and writes them to OUT.jsonl (default
# $BENCH_OUT/distributed/results.jsonl, BENCH_OUT default out/bench).
. "$(dirname "$0")/common.sh" "${1:-}" results.jsonl image 5
[[ -d $VOLUX_DATA/volumes ]] || { echo "bench/distributed/run.sh: no volumes in VOLUX_DATA=$VOLUX_DATA" >&2; exit 2; }
# Strong scaling: the same frame on 1..4 ranks, interleaved per repeat
# round so load changes hit every rank count alike.
for round in 1 2; do
  for n in 1 2 3 4; do
    run "$n" bench/scenes/ml256.json --set 'render.technique="ea"' --spp 1
    run "$n" bench/scenes/pt_bonsai_env.json --width 512 --height 512 --spp 4
  done
done
# Compositing against the image size (2 ranks, ea, one sample).
for size in 256 512 1024 2048; do
  run 2 bench/scenes/ml256.json --set 'render.technique="ea"' --spp 1 --width "$size" --height "$size"
done
mv "$OUT.tmp" "$OUT"
