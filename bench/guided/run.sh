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
. "$(dirname "$0")/common.sh" "${1:-}" "${2:-}" results
phases=${PHASES:-"refs table1 table2 strategies multiple lazy"}
note() { echo "{\"note\":\"$*\",\"load\":\"$(cut -d' ' -f1-3 /proc/loadavg)\",\"date\":\"$(date -u +%FT%TZ)\"}" >> "$out/notes.jsonl"; }
has() { [[ " $phases " == *" $1 "* ]]; }
note "start $phases; $(lscpu | grep 'Model name' | sed 's/  */ /g')"

if has refs; then # pathtrace references: single scattering and max_depth 8
  for sc in bonsai engine; do
    [[ -s $out/${sc}_ref.pfm ]] || "$volux" render "$here/$sc.json" -o "$out/${sc}_ref.pfm" --technique pathtrace --spp 4096 --quiet
    [[ -s $out/${sc}_ms_ref.pfm ]] || "$volux" render "$here/$sc.json" -o "$out/${sc}_ms_ref.pfm" --technique pathtrace --spp 4096 --max-depth 8 --quiet
  done
  note "refs done"
fi

if has table1; then # sweep vs brute force over grid resolutions and kernel ray spacings; one thread, CPU time
  # Brute force at cell 2 (128^3 positions on 256^3) takes minutes per grid:
  # there it is timed on 4 directions (directions = 2) against the sweep on
  # the same 4; every run is time-boxed (TIMEBOX seconds, "timeout" in the
  # notes when hit).
  : > "$out/table1.jsonl"
  one=(--set render.threads=1)
  tb=${TIMEBOX:-150}
  vis() { timeout "$tb" "$bg" visibility "$@" "${one[@]}" >> "$out/table1.jsonl" || note "timeout or failure: $*"; }
  for sc in bonsai engine; do
    vis "$here/$sc.json" --repeat 3 --label "sweep filtered default" --set techniques.guided.filter=true
    vis "$here/$sc.json" --repeat 1 --label "sweep default scalar" --set techniques.guided.kernel=scalar \
      --set techniques.guided.filter=false
    for cell in 16 8 4 2; do
      vis "$here/$sc.json" --repeat 3 --label "sweep cell $cell rays 1" --set techniques.guided.cell=$cell \
        --set techniques.guided.filter=false
    done
    for rs in 2 4 8; do
      vis "$here/$sc.json" --repeat 3 --label "sweep cell 4 rays $rs" --set techniques.guided.ray_spacing=$rs \
        --set techniques.guided.filter=false
    done
    for cell in 16 8 4; do
      vis "$here/$sc.json" --repeat 1 --label "bruteforce cell $cell" --set techniques.guided.cell=$cell \
        --set techniques.guided.visibility=bruteforce
    done
    vis "$here/$sc.json" --repeat 3 --label "sweep cell 2 rays 1 dirs 4" --set techniques.guided.cell=2 \
      --set techniques.guided.filter=false --set techniques.guided.directions=2
    vis "$here/$sc.json" --repeat 1 --label "bruteforce cell 2 dirs 4" --set techniques.guided.cell=2 \
      --set techniques.guided.visibility=bruteforce --set techniques.guided.directions=2
  done
  note "table1 done"
fi

if has table2; then # filtering vs angular oversampling: cost and error; 64x64, one thread
  # One instance per configuration: its preparation (prepare_cpu_ms: the
  # visibility grid plus the environment tables; "environment" builds no
  # grid, its preparation is subtracted) and the two_step image's MSE at
  # 64 spp for 3 seeds on that instance (the same seeds for every row:
  # paired), against a 2048-spp pathtrace reference at 64x64.
  : > "$out/table2.jsonl"
  t2=(--spp 64 --seeds 3 --set render.width=64 --set render.height=64 --set render.threads=1)
  for sc in bonsai engine; do
    [[ -s $out/${sc}_ref64.pfm ]] || "$volux" render "$here/$sc.json" -o "$out/${sc}_ref64.pfm" --technique pathtrace \
      --spp 2048 --width 64 --height 64 --threads 1 --quiet
    for cfg in "environment:strategy=environment" "unfiltered:filter=false" "filtered:filter=true" \
               "filtered_beta0:filter_angle=0" "oversample4:filter=false,oversample=2" \
               "oversample16:filter=false,oversample=4" "bruteforce:visibility=bruteforce"; do
      label=${cfg%%:*} sets=()
      IFS=, read -ra kv <<< "${cfg#*:}"
      for x in "${kv[@]}"; do sets+=(--set "techniques.guided.$x"); done
      "$bg" converge "$here/$sc.json" --reference "$out/${sc}_ref64.pfm" "${t2[@]}" --label "$sc $label" "${sets[@]}" \
        >> "$out/table2.jsonl"
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
  # 64x64, 8 spp per frame, steps 0..LAZY_STEPS-1, one thread; the same
  # seed for every policy (paired); "off" sweeps every direction at every
  # step (the per-step reference visibility)
  # per-step references of the animated cloud: pathtrace 512 spp, 64x64,
  # steps 0..LAZY_STEPS-1, one render per step (each well under 2 minutes)
  for ((t = 0; t < ${LAZY_STEPS:-24}; t++)); do
    f=$(printf "$out/cloud_ref_%04d.pfm" $t)
    [[ -s $f ]] || "$volux" render "$here/cloud_sequence.json" -o "$f" --technique pathtrace --spp 512 --width 64 \
      --height 64 --threads 1 --time-step $t --seed 1000 --quiet
  done
  : > "$out/lazy.jsonl"
  lz=(--spp 8 --steps "${LAZY_STEPS:-24}" --reference "$out/cloud_ref_%04d.pfm" --set render.width=64
      --set render.height=64 --set render.threads=1)
  for pol in off round_robin environment static; do
    "$bg" lazy "$here/cloud_sequence.json" "${lz[@]}" --label "$pol" --set techniques.guided.lazy=$pol >> "$out/lazy.jsonl"
  done
  "$bg" lazy "$here/cloud_sequence.json" "${lz[@]}" --label "environment sampling" \
    --set techniques.guided.strategy=environment --set techniques.guided.lazy=off >> "$out/lazy.jsonl"
  note "lazy done"
fi
note "end"
echo "wrote $out" >&2
