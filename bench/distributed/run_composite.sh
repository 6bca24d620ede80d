#!/bin/bash
# bench/distributed/run_composite.sh [OUT.jsonl] — data-parallel compositing
# (issue 31): binary swap (the default) against one MPI_Reduce with the
# "over" operation (VOLUX_COMPOSITE=reduce), at 2-8 ranks (oversubscribed
# on a 2-core machine), 256² and 512², 1 spp, `ea` on a small procedural
# volume (the brick render is cheap, the image is what is composited).
# Rounds interleave the two schemes; every JSON line gets
# "composite":"swap"|"reduce" and "round". composite_ms is timed after a
# barrier (the exchange alone); composite_bytes_max is the most one rank
# sent. Output: $BENCH_OUT/distributed/composite.jsonl by default.
. "$(dirname "$0")/common.sh" "${1:-}" composite.jsonl data 5
scene=$(mktemp --suffix=.json)
trap 'rm -f "$scene"' EXIT
cat >"$scene" <<'JSON'
{
  "volume": {"procedural": "marschner_lobb", "dims": [64, 64, 64]},
  "transfer_function": {"color": [[0, 0.2, 0.3, 0.6], [255, 1, 0.9, 0.8]],
                        "opacity": [[0, 0], [100, 0.02], [255, 0.3]]},
  "camera": {"type": "orthographic", "orbit": {"azimuth": 30, "elevation": 20}, "fov_y": 30},
  "render": {"technique": "ea", "width": 512, "height": 512, "spp": 1}
}
JSON
for round in 1 2; do
  for size in 256 512; do
    for n in 2 3 4 5 6 8; do
      for scheme in reduce swap; do
        VOLUX_COMPOSITE=$scheme mpirun --oversubscribe -np "$n" "$VOLUX" bench "$scene" \
            --spp 1 --width "$size" --height "$size" --json --repeat "$REPEAT" --threads 1 --distribute data |
          grep -E '"metric":"(render_ms|composite_ms|composite_bytes_max)"' |
          sed "s/}\$/,\"composite\":\"$scheme\",\"round\":$round}/" | tee -a "$OUT.tmp"
      done
    done
  done
done
mv "$OUT.tmp" "$OUT"
