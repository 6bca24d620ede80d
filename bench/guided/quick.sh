#!/usr/bin/env bash
# bench/guided/quick.sh — the reduced measurements behind the tables of
# docs/techniques/guided.md ("Measured" section), sized for a shared 2-vCPU
# machine: 64x64 images, one thread, CPU milliseconds as the clock.
# run.sh is the full-size version (128x128, 4096-spp references, all grid
# resolutions), which takes hours under load.
#
#   bench/guided/quick.sh [BUILD_DIR] [OUT_DIR]
. "$(dirname "$0")/common.sh" "${1:-}" "${2:-}" results_quick
small=(--set render.width=64 --set render.height=64 --set render.threads=1)
: > "$out/notes.jsonl"
note_machine

# Table 1 at the default grid (8x8 directions, cell 4: 64^3 positions) on
# bonsai 256^3; brute force on a 2x2 map (4 directions: its cost per
# direction times 16 estimates the default grid), the sweep on the same 4
: > "$out/table1.jsonl"
for f in true false; do
  "$bg" visibility "$here/bonsai.json" --repeat 1 --label "sweep default filter=$f" \
    --set techniques.guided.filter=$f --set render.threads=1 >> "$out/table1.jsonl"
done
for v in sweep bruteforce; do
  "$bg" visibility "$here/bonsai.json" --repeat 1 --label "$v dirs2" --set techniques.guided.visibility=$v \
    --set techniques.guided.directions=2 --set render.threads=1 >> "$out/table1.jsonl"
done

# references: pathtrace, 64x64, single scattering 2048 spp, max_depth 8 1024 spp
for sc in bonsai engine; do
  [[ -s $out/${sc}_ref.pfm ]] || "$volux" render "$here/$sc.json" -o "$out/${sc}_ref.pfm" --technique pathtrace \
    --spp 2048 --width 64 --height 64 --threads 1 --quiet
done
[[ -s $out/bonsai_ms_ref.pfm ]] || "$volux" render "$here/bonsai.json" -o "$out/bonsai_ms_ref.pfm" \
  --technique pathtrace --spp 1024 --max-depth 8 --width 64 --height 64 --threads 1 --quiet

# MSE vs spp per strategy (Figs. 10-13), CPU time per sample (Fig. 9)
: > "$out/strategies.jsonl"
for sc in bonsai engine; do
  for s in uniform environment visibility product two_step; do
    "$bg" converge "$here/$sc.json" --reference "$out/${sc}_ref.pfm" --spp 64 --label "$s" \
      --set techniques.guided.strategy=$s "${small[@]}" >> "$out/strategies.jsonl"
  done
done

# guided multiple scattering vs pathtrace, max_depth 8
: > "$out/multiple.jsonl"
"$bg" converge "$here/bonsai.json" --reference "$out/bonsai_ms_ref.pfm" --spp 64 --label pathtrace \
  --set render.technique=pathtrace --set render.max_depth=8 "${small[@]}" >> "$out/multiple.jsonl"
for gd in 0 1; do
  "$bg" converge "$here/bonsai.json" --reference "$out/bonsai_ms_ref.pfm" --spp 64 --label "guided depth $gd" \
    --set render.max_depth=8 --set techniques.guided.guide_depth=$gd "${small[@]}" >> "$out/multiple.jsonl"
done

# lazy updates over the animated cloud (128^3, 48 steps): per-step update vs full
: > "$out/lazy.jsonl"
for pol in round_robin environment static off; do
  "$bg" lazy "$here/cloud_sequence.json" --steps 10 --spp 1 --label "$pol" --set techniques.guided.lazy=$pol \
    --set render.threads=1 --set render.width=32 --set render.height=32 | grep -v lazy.step >> "$out/lazy.jsonl"
done
echo "wrote $out" >&2
