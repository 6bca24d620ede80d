#!/bin/bash
# Instruction counts (valgrind callgrind: exact, repeatable, independent of
# other load on the machine) of render, create and update for every
# technique with two volux binaries, side by side. For refactors that must
# not cost speed, on shared machines where wall-clock medians are noise.
#   bench/identity/instructions.sh OLD_VOLUX NEW_VOLUX [SCENE] [SIZE]
# Prints: technique, phase, Ir old, Ir new, new/old. Valgrind runs the AVX2
# paths (it does not emulate AVX-512), the same for both binaries.
set -u
old=${1:?usage: instructions.sh OLD NEW [SCENE] [SIZE]}
new=${2:?usage: instructions.sh OLD NEW [SCENE] [SIZE]}
scene=${3:-scenes/demo.json}
size=${4:-64}
cd "$(dirname "$0")/../.."
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
common=(--width "$size" --height "$size" --spp 1 --threads 1 --repeat 1
        --set techniques.ambient.table_paths=512 --set techniques.ambient.table_theta=64
        --set techniques.ambient.table_sigma=64 --set techniques.ambient.table_g=5)
# Ir inside one function (and everything it calls).
count() { # binary, function, bench args...
  local bin=$1 fn=$2; shift 2
  valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.out" --toggle-collect="$fn" \
    "$bin" bench "$scene" "${common[@]}" "$@" >/dev/null 2>"$tmp/vg.err" || { echo "?"; return; }
  callgrind_annotate "$tmp/cg.out" 2>/dev/null | awk '/PROGRAM TOTALS/ {gsub(",", "", $1); print $1; exit}'
}
printf "%-10s %-16s %15s %15s %8s\n" technique phase old new new/old
for t in ea shaded pathtrace single ao ambient lightvol; do
  for phase in render create update.tf update.light update.camera; do
    case $phase in
      render) fn=volux_render; args=(--edit camera) ;;
      create) fn=volux_technique_create; args=(--edit camera) ;;
      update.*) fn=volux_technique_update; args=(--edit "${phase#update.}") ;;
    esac
    a=$(count "$old" "$fn" --technique "$t" "${args[@]}")
    b=$(count "$new" "$fn" --technique "$t" "${args[@]}")
    ratio=$(awk -v a="$a" -v b="$b" 'BEGIN { if (a > 0) printf "%.4f", b / a; else print "-" }')
    printf "%-10s %-16s %15s %15s %8s\n" "$t" "$phase" "$a" "$b" "$ratio"
  done
done
