#!/bin/bash
# bench/distributed/run.sh [OUT.jsonl] — the MPI front end (issue 15) on
# this machine: strong scaling of image-parallel rendering over 1-4 ranks
# (one thread each; 3-4 ranks oversubscribe a 2-core machine) for `ea` and
# `pathtrace` at 512², and the compositing time against the image size.
# Needs an MPI build (mpirun) and the shared data ($VOLUX_DATA, default
# ../shared/data; docs/CONVENTIONS.md); prints JSON lines (volux bench
# --json plus "ranks") and writes them to OUT.jsonl (default
# $BENCH_OUT/distributed/results.jsonl, BENCH_OUT default out/bench).
set -euo pipefail
cd "$(dirname "$0")/../.."
VOLUX=${VOLUX:-build/volux}
OUT=${1:-${BENCH_OUT:-out/bench}/distributed/results.jsonl}
mkdir -p "$(dirname "$OUT")"
export VOLUX_DATA=${VOLUX_DATA:-$PWD/../shared/data}
export OMP_WAIT_POLICY=passive OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl=self,vader
command -v mpirun >/dev/null || { echo "bench/distributed/run.sh: needs mpirun (openmpi-bin)" >&2; exit 2; }
[[ -d $VOLUX_DATA/volumes ]] || { echo "bench/distributed/run.sh: no volumes in VOLUX_DATA=$VOLUX_DATA" >&2; exit 2; }
: >"$OUT.tmp"
REPEAT=${REPEAT:-5}
run() { local n=$1; shift; mpirun --oversubscribe -np "$n" "$VOLUX" bench "$@" --json --repeat "$REPEAT" --threads 1 \
          --distribute image | tee -a "$OUT.tmp"; }
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
