#!/bin/bash
# Scaling figures (docs/SCALE.md): prepare, per-edit (TF) update, frame time,
# technique memory, the model's estimate and the peak resident memory of
# every technique on the procedural phantom at N³, one process per run.
# Usage: bench/scale/run.sh VOLUX OUT.jsonl [SIZES...] (default 128 256 512)
# Env: TECHS (default all), TIMEOUT per run in s (default 900), W (256),
#      U16DIR: bench DIR/phantom16_N.nhdr (the 16-bit phantom, written by
#      build/bench/bench_phantom16 when missing) instead of procedural:phantom:N,
#      ARGS: more `volux bench` options (e.g. "--memory-limit 8G", "--out-of-core").
set -u
volux=${1:?usage: run.sh VOLUX OUT.jsonl [SIZES...]}
out=${2:?usage: run.sh VOLUX OUT.jsonl [SIZES...]}
shift 2
sizes=${*:-128 256 512}
techs=${TECHS:-ea shaded pathtrace single ao ambient lightvol sh manylights guided}
w=${W:-256}
for n in $sizes; do
  vol="procedural:phantom:$n"
  if [ -n "${U16DIR:-}" ]; then
    vol="$U16DIR/phantom16_$n.nhdr"
    [ -f "$vol" ] || "$(dirname "$volux")/bench/bench_phantom16" "$n" "$vol" || exit 1
  fi
  for t in $techs; do
    load=$(cut -d' ' -f1 /proc/loadavg)
    start=$(date +%s.%N)
    # one frame at 1 spp; the TF edit is the per-edit cost every technique has
    timeout "${TIMEOUT:-900}" "$volux" bench "$vol" --technique "$t" --repeat 1 --edit tf ${ARGS:-} \
      --width "$w" --height "$w" --spp 1 --json 2>/dev/null |
      sed "s/}\$/,\"n\":$n,\"load\":$load}/" >>"$out"
    rc=${PIPESTATUS[0]}
    echo "{\"n\":$n,\"technique\":\"$t\",\"metric\":\"exit\",\"value\":$rc,\"wall_s\":$(printf %.3f "$(echo "$(date +%s.%N) - $start" | bc)"),\"load\":$load}" >>"$out"
  done
done
