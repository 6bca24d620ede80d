#!/bin/bash
# bench/viewer/encode.sh — the cost of the viewer's frame encodings (JPEG
# previews, PNG refinement/final frames) at 256² and 512²: the server's CPU
# time per encode (from /proc/PID/stat, so the machine's load inflates it
# little) and the size, for the same frame of SCENE.
#
# `volux serve --idle-ms 60000` keeps an edit's preview on screen; /api/frame
# encodes it on demand in the other format, N times; a request in the
# frame's own format (a copy) is the baseline subtracted.
#
# Usage: bench/viewer/encode.sh VOLUX SCENE.json [N]
set -euo pipefail
volux=$1 scene=$2 n=${3:-30}
export OMP_WAIT_POLICY=passive
hz=$(getconf CLK_TCK)

cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }

run() { # size preview-flag other-format
  local size=$1 flag=$2 fmt=$3 own=$4
  local log; log=$(mktemp)
  "$volux" serve "$scene" --port 0 --quiet --idle-ms 60000 --preview "$size" --set render.width="$size" \
    --set render.height="$size" $flag >"$log" &
  local pid=$!
  local url=""
  for _ in $(seq 600); do url=$(grep -o 'http://127.0.0.1:[0-9]*/' "$log" || true); [[ -n $url ]] && break; sleep 0.1; done
  # The start-up frame refines at once; an edit then brings a preview that stays.
  local id
  id=$(curl -sf -D - "${url}api/frame?wait=final&timeout=120000" -o /dev/null | tr -d '\r' | awk '/^X-Volux-Frame:/ {print $2}')
  curl -sf "${url}api/edit" -H 'Content-Type: application/json' -d '[{"path":"render.exposure","value":0.01}]' >/dev/null
  curl -sf "${url}api/frame?format=$own&after=$id&timeout=120000" -o /dev/null
  sleep 0.5
  local t0 t1 t2 bytes
  t0=$(cpu_ticks $pid)
  for _ in $(seq "$n"); do curl -sf "${url}api/frame?format=$own" -o /dev/null; done
  t1=$(cpu_ticks $pid)
  for _ in $(seq "$n"); do curl -sf "${url}api/frame?format=$fmt" -o /dev/null; done
  t2=$(cpu_ticks $pid)
  bytes=$(curl -sf "${url}api/frame?format=$fmt" | wc -c)
  kill $pid; wait $pid || true
  rm -f "$log"
  awk -v s="$size" -v f="$fmt" -v a="$((t1 - t0))" -v b="$((t2 - t1))" -v n="$n" -v hz="$hz" -v by="$bytes" \
    'BEGIN { printf "| %d² | %s | %.1f | %.1f |\n", s, f, (b - a) * 1000.0 / hz / n, by / 1024.0 }'
}

echo "| frame | format | server CPU ms per encode | KiB |"
echo "|---|---|---:|---:|"
for size in 256 512; do
  run $size "" png jpeg          # preview is JPEG: PNG on demand
  run $size --preview-png jpeg png # preview is PNG: JPEG on demand
done
echo "load: $(cut -d' ' -f1-3 /proc/loadavg)"
