#!/bin/bash
# `make bench`: the benchmark suites, in one place. Results go under
# $BENCH_OUT (default out/bench/, not tracked); to refresh the committed
# tables, run a suite with its output path in docs/ or bench/ explicitly
# (each script's header says how). All need the shared data: $VOLUX_DATA,
# default ../shared/data beside the checkout (docs/CONVENTIONS.md).
#   bench/run.sh [classical|pathtrace|ambient|lightvol|all]   (default: all)
# On a shared machine, set OMP_WAIT_POLICY=passive (spinning OpenMP workers
# steal the other jobs' cores and distort both).
set -euo pipefail
cd "$(dirname "$0")/.."
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
export VOLUX_DATA=${VOLUX_DATA:-$PWD/../shared/data}
export BENCH_OUT=${BENCH_OUT:-$PWD/out/bench}
what=${1:-all}
[[ -d $VOLUX_DATA/volumes ]] || { echo "bench/run.sh: no volumes in VOLUX_DATA=$VOLUX_DATA (see docs/CONVENTIONS.md)" >&2; exit 2; }
mkdir -p "$BENCH_OUT"
echo "bench/run.sh: results under $BENCH_OUT"
run() { echo "== $*"; "$@"; }
case $what in
  classical|all) run bench/kernel_rates.sh | tee "$BENCH_OUT/kernel_rates.txt"
                 run bench/thread_scaling.sh | tee "$BENCH_OUT/thread_scaling.txt"
                 run bench/classical_metrics.sh; run bench/vtk_compare.sh ;;&
  pathtrace|all) { run build/volux bench bench/scenes/pt_bonsai_env.json --repeat 3 --spp 16 --width 128 --height 128 --json
                   run build/volux bench bench/scenes/pt_bonsai_env.json --repeat 3 --spp 16 --width 128 --height 128 --json \
                       --set techniques.pathtrace.majorant=global; } | tee "$BENCH_OUT/pathtrace.jsonl"
                 # sampler sobol vs independent: variance·spp (docs/techniques/pathtrace.md "Sampling")
                 VOLUX=build/volux run python3 bench/sampler/measure.py --seeds 4 --spp 4,16,64 \
                     bench/sampler/cube_sun.json bench/sampler/cube_env.json bench/scenes/pt_bonsai_sun.json \
                     bench/scenes/pt_bonsai_env.json | tee "$BENCH_OUT/sampler.txt" ;;&
  ambient|all)   run bench/ambient/run.sh ;;&
  lightvol|all)  run bench/lightvol/run.sh ;;&
  classical|pathtrace|ambient|lightvol|all) ;;
  *) echo "usage: bench/run.sh [classical|pathtrace|ambient|lightvol|all]" >&2; exit 2 ;;
esac
