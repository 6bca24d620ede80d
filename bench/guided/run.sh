#!/usr/bin/env bash
# bench/guided/run.sh — the measurements of docs/techniques/guided.md
# (von Radziewsky et al. 2017: Table 1, Table 2, Figs. 9–13, 15 on our data).
#
#   bench/guided/run.sh [BUILD_DIR] [OUT_DIR]      (PHASES to narrow:
#       refs table1 table2 strategies multiple lazy; default all)
#
# Writes OUT_DIR/*.jsonl (one JSON object per line) and reference images;
# bench/guided/tables.py OUT_DIR turns them into the page's tables, plots
# and image strips. Needs ../shared/data (absolute paths in the scenes).
# Timings are medians of repeats; CPU milliseconds (all threads) are the
# stable clock on a shared machine, so the tables use them next to wall.
set -euo pipefail
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-$here/../../build}
out=${2:-$here/results}
phases=${PHASES:-"refs table1 table2 strategies multiple lazy"}
volux=$build/volux
bg=$build/bench/bench_guided
mkdir -p "$out"
note() { echo "{\"note\":\"$*\",\"load\":\"$(cut -d' ' -f1-3 /proc/loadavg)\",\"date\":\"$(date -u +%FT%TZ)\"}" >> "$out/notes.jsonl"; }
has() { [[ " $phases " == *" $1 "* ]]; }
note "start $phases; $(lscpu | grep 'Model name' | sed 's/  */ /g')"

if has refs; then # pathtrace references: single scattering and max_depth 8
  for sc in bonsai engine; do
    [[ -s $out/${sc}_ref.pfm ]] || "$volux" render "$here/$sc.json" -o "$out/${sc}_ref.pfm" --technique pathtrace --spp 4096 --quiet
    [[ -s $out/${sc}_ms_ref.pfm ]] || "$volux" render "$here/$sc.json" -o "$out/${sc}_ms_ref.pfm" --technique pathtrace --spp 4096 --max-depth 8 --quiet
  done
  [[ -s $out/cloud_ref_0044.pfm ]] || "$volux" render "$here/cloud_sequence.json" -o "$out/cloud_ref_%04d.pfm" --all-steps --technique pathtrace --spp 512 --quiet
  note "refs done"
fi

if has table1; then # sweep vs brute force over grid resolutions and kernel ray spacings
  : > "$out/table1.jsonl"
  for sc in bonsai engine; do
    for cell in 2 4 8 16; do
      for rs in 1 2 4 8; do
        "$bg" visibility "$here/$sc.json" --repeat 3 --label "sweep cell $cell rays $rs" --set techniques.guided.cell=$cell \
          --set techniques.guided.ray_spacing=$rs --set techniques.guided.filter=false >> "$out/table1.jsonl"
      done
      [[ $sc == engine && $cell == 2 ]] && continue # brute force at cell 2 takes minutes; bonsai has it
      "$bg" visibility "$here/$sc.json" --repeat 1 --label "bruteforce cell $cell" --set techniques.guided.cell=$cell \
        --set techniques.guided.visibility=bruteforce >> "$out/table1.jsonl"
    done
    "$bg" visibility "$here/$sc.json" --repeat 3 --label "sweep default scalar" --set techniques.guided.kernel=scalar \
      --set techniques.guided.filter=false >> "$out/table1.jsonl"
  done
  note "table1 done"
fi

if has table2; then # filtering vs angular oversampling: cost and error
  : > "$out/table2.jsonl"
  for sc in bonsai engine; do
    for cfg in "unfiltered:filter=false" "filtered:filter=true" "filtered_beta0:filter_angle=0" \
               "oversample4:filter=false,oversample=2" "oversample16:filter=false,oversample=4" \
               "bruteforce:visibility=bruteforce"; do
      label=${cfg%%:*} sets=()
      IFS=, read -ra kv <<< "${cfg#*:}"
      for x in "${kv[@]}"; do sets+=(--set "techniques.guided.$x"); done
      "$bg" visibility "$here/$sc.json" --repeat 1 --label "$label" "${sets[@]}" >> "$out/table2.jsonl"
      "$bg" converge "$here/$sc.json" --reference "$out/${sc}_ref.pfm" --spp 64 --label "$label" "${sets[@]}" >> "$out/table2.jsonl"
    done
  done
  note "table2 done"
fi

if has strategies; then # MSE vs spp per strategy (Figs. 10-13) and equal time (Fig. 9)
  : > "$out/strategies.jsonl"
  for sc in bonsai engine; do
    "$bg" converge "$here/$sc.json" --reference "$out/${sc}_ref.pfm" --spp 256 --label pathtrace \
      --set render.technique=pathtrace >> "$out/strategies.jsonl"
    for s in uniform environment visibility product two_step; do
      "$bg" converge "$here/$sc.json" --reference "$out/${sc}_ref.pfm" --spp 256 --label "$s" \
        --set techniques.guided.strategy=$s >> "$out/strategies.jsonl"
    done
    for s in uniform environment two_step; do # equal-time images (Fig. 9)
      "$volux" render "$here/$sc.json" -o "$out/${sc}_${s}_16.pfm" --spp 16 --quiet --set techniques.guided.strategy=$s
    done
  done
  note "strategies done"
fi

if has multiple; then # guided multiple scattering vs pathtrace, max_depth 8
  : > "$out/multiple.jsonl"
  for sc in bonsai engine; do
    "$bg" converge "$here/$sc.json" --reference "$out/${sc}_ms_ref.pfm" --spp 128 --label pathtrace \
      --set render.technique=pathtrace --set render.max_depth=8 >> "$out/multiple.jsonl"
    for gd in 1 0; do
      "$bg" converge "$here/$sc.json" --reference "$out/${sc}_ms_ref.pfm" --spp 128 --label "guided depth $gd" \
        --set render.max_depth=8 --set techniques.guided.guide_depth=$gd >> "$out/multiple.jsonl"
    done
  done
  note "multiple done"
fi

if has lazy; then # animated sequence: per-frame update cost and error per lazy policy (Fig. 15)
  : > "$out/lazy.jsonl"
  for pol in off round_robin environment static; do
    "$bg" lazy "$here/cloud_sequence.json" --spp 8 --reference "$out/cloud_ref_%04d.pfm" --label "$pol" \
      --set techniques.guided.lazy=$pol >> "$out/lazy.jsonl"
  done
  "$bg" lazy "$here/cloud_sequence.json" --spp 8 --reference "$out/cloud_ref_%04d.pfm" --label "environment sampling" \
    --set techniques.guided.strategy=environment --set techniques.guided.lazy=off >> "$out/lazy.jsonl"
  note "lazy done"
fi
note "end"
echo "wrote $out" >&2
