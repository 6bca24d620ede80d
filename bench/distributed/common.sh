# bench/distributed/common.sh — what both MPI benchmarks start with. Sourced:
#
#   . "$(dirname "$0")/common.sh" "${1:-}" DEFAULT_NAME.jsonl MODE REPEAT
#
# cds to the checkout, sets VOLUX, OUT (its folder created, OUT.tmp emptied)
# and REPEAT (env REPEAT wins), exports the shared data and the Open MPI
# settings for a root, loopback-only run, checks mpirun, and defines
# run RANKS ARGS... (one `volux bench --json` per rank count, MODE =
# `--distribute` image or data, appended to OUT.tmp).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
VOLUX=${VOLUX:-build/volux}
OUT=${1:-${BENCH_OUT:-out/bench}/distributed/$2}
mkdir -p "$(dirname "$OUT")"
export VOLUX_DATA=${VOLUX_DATA:-$PWD/../shared/data}
export OMP_WAIT_POLICY=passive OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl=self,vader
command -v mpirun >/dev/null || { echo "$0: needs mpirun (openmpi-bin)" >&2; exit 2; }
: >"$OUT.tmp"
REPEAT=${REPEAT:-$4}
distribute_mode=$3
run() { local n=$1; shift; mpirun --oversubscribe -np "$n" "$VOLUX" bench "$@" --json --repeat "$REPEAT" --threads 1 \
          --distribute "$distribute_mode" | tee -a "$OUT.tmp"; }
