#!/usr/bin/env bash
# bench/ambient/run.sh — Ament et al. 2013, Table 1 on our data: update and
# render times of ea / ao / single / ambient on the scenes of this folder
# (512×512, 2 threads, real volumes from $VOLUX_DATA, docs/CONVENTIONS.md).
#
#   bench/ambient/run.sh [VOLUX] [OUT.jsonl]      (REPEAT=5 by default;
#                                                   TECHS, SCENES to narrow)
#   bench/ambient/summarize.py OUT.jsonl          → the Markdown table
#
# The ambient technique loads its preintegration table from the cache
# ($XDG_CACHE_HOME/volux or ~/.cache/volux); the first run builds it
# (minutes, see docs/techniques/ambient.md) unless it is there already.
set -euo pipefail
# Passive OpenMP waiting: on a shared (oversubscribed) machine libgomp's
# default spin-wait lets a waiting thread eat the free core at each of the
# radiance-cache sweep's barriers (docs/techniques/ambient.md, section 9).
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
here=$(cd "$(dirname "$0")" && pwd)
volux=${1:-$here/../../build/volux}
out=${2:-${BENCH_OUT:-$here/../../out/bench}/ambient/results.jsonl}
mkdir -p "$(dirname "$out")"
repeat=${REPEAT:-5}
scenes=${SCENES:-"bonsai engine aneurism"}
techs=${TECHS:-"ea ao single ambient"}
: > "$out"
for scene in $scenes; do
  for tech in $techs; do
    echo "bench: $scene $tech" >&2
    "$volux" bench "$here/$scene.json" --technique "$tech" --repeat "$repeat" \
      --edit tf --edit phase --edit light --edit light_last --edit camera --json >> "$out"
  done
done
echo "wrote $out" >&2
