#!/bin/bash
# `make bench`: the benchmark suites, in one place. Each writes its results
# under docs/ or prints JSON lines; all need ../shared (real volumes, peers).
#   bench/run.sh [classical|pathtrace|ambient|lightvol|all]   (default: all)
# On a shared machine, set OMP_WAIT_POLICY=passive (spinning OpenMP workers
# steal the other jobs' cores and distort both).
set -euo pipefail
cd "$(dirname "$0")/.."
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
what=${1:-all}
[[ -d ../shared/data/volumes ]] || { echo "bench/run.sh: needs ../shared/data beside the checkout" >&2; exit 2; }
run() { echo "== $*"; "$@"; }
case $what in
  classical|all) run bench/kernel_rates.sh; run bench/thread_scaling.sh; run bench/classical_metrics.sh; run bench/vtk_compare.sh ;;&
  pathtrace|all) run build/volux bench bench/scenes/pt_bonsai_env.json --repeat 3 --spp 16 --width 128 --height 128 --json
                 run build/volux bench bench/scenes/pt_bonsai_env.json --repeat 3 --spp 16 --width 128 --height 128 --json \
                     --set techniques.pathtrace.majorant=global ;;&
  ambient|all)   run bench/ambient/run.sh ;;&
  lightvol|all)  run bench/lightvol/run.sh ;;&
  classical|pathtrace|ambient|lightvol|all) ;;
  *) echo "usage: bench/run.sh [classical|pathtrace|ambient|lightvol|all]" >&2; exit 2 ;;
esac
