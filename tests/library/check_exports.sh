#!/bin/bash
# The library's exported symbols are its ABI (docs/API.md). This fails when
#   - libvolux.so exports a symbol that is not volux_* (a leaked internal),
#   - it exports one that abi/volux.symbols does not list (accidental export),
#   - it lacks one the list has (accidental removal: deprecate first),
#   - the list and the VOLUX_API declarations in include/volux/ differ,
#   - the installable static archive (dist/libvolux.a) defines other global
#     symbols than the shared library exports,
#   - the SONAME is not the one version.h implies.
# Usage: check_exports.sh VOLUX SRC_DIR [LIB STATIC SYMBOLS HEADER_DIR]
#   (ctest passes VOLUX = <build>/volux; the rest default to that build and
#   tree; tests/library/check_exports_planted.sh passes planted ones)
set -u
volux=${1:?usage: check_exports.sh VOLUX SRC_DIR [LIB STATIC SYMBOLS HEADER_DIR]}
src=${2:?usage: check_exports.sh VOLUX SRC_DIR [LIB STATIC SYMBOLS HEADER_DIR]}
build=$(dirname "$volux")
lib=${3:-$build/libvolux.so}
static=${4:-$build/dist/libvolux.a}
symbols=${5:-$src/abi/volux.symbols}
headers=${6:-$src/include/volux}
for f in "$lib" "$static" "$symbols"; do
  [[ -r $f ]] || { echo "missing $f (build first)"; exit 1; }
done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
bad=0

# Defined dynamic symbols (functions and data), names only.
nm -D --defined-only "$lib" | awk 'NF >= 3 { print $3 }' | LC_ALL=C sort -u > "$tmp/exported"
grep -v '^#' "$symbols" | sed '/^[[:space:]]*$/d' | LC_ALL=C sort -u > "$tmp/listed"
# Every VOLUX_API declaration: the identifier right before the first '('.
grep -hv "^[[:space:]]*#" "$headers"/*.h | grep -o 'VOLUX_API[^(;]*(' | sed -E 's/.*[^A-Za-z0-9_]([A-Za-z_][A-Za-z0-9_]*)[[:space:]]*\($/\1/' |
  LC_ALL=C sort -u > "$tmp/declared"
nm -g --defined-only "$static" | awk 'NF == 3 { print $3 }' | LC_ALL=C sort -u > "$tmp/static"

while read -r s; do
  echo "leaked internal symbol: $s is exported from $(basename "$lib") but is not volux_* (mark it static or hidden)"
  bad=1
done < <(grep -v '^volux_' "$tmp/exported")
while read -r s; do
  echo "unlisted export: $s is exported but not in $symbols (add it with its header, or hide it)"
  bad=1
done < <(LC_ALL=C comm -23 "$tmp/exported" "$tmp/listed")
while read -r s; do
  echo "removed export: $s is listed in $symbols but no longer exported (deprecate before removing, docs/API.md)"
  bad=1
done < <(LC_ALL=C comm -13 "$tmp/exported" "$tmp/listed")
while read -r s; do
  echo "undeclared listing: $s is in $symbols but no header in $headers declares it VOLUX_API"
  bad=1
done < <(LC_ALL=C comm -23 "$tmp/listed" "$tmp/declared")
while read -r s; do
  echo "unlisted declaration: $s is declared VOLUX_API in $headers but missing from $symbols"
  bad=1
done < <(LC_ALL=C comm -13 "$tmp/listed" "$tmp/declared")
while read -r s; do
  echo "static archive leak: $(basename "$static") defines global $s, which the shared library does not export"
  bad=1
done < <(LC_ALL=C comm -23 "$tmp/static" "$tmp/exported")

# SONAME: libvolux.so.0.MINOR while MAJOR is 0, else libvolux.so.MAJOR.
if [[ -r $headers/version.h ]] && [[ -z ${3:-} ]]; then
  major=$(sed -n 's/^#define VOLUX_VERSION_MAJOR \([0-9]*\)$/\1/p' "$headers/version.h")
  minor=$(sed -n 's/^#define VOLUX_VERSION_MINOR \([0-9]*\)$/\1/p' "$headers/version.h")
  if [[ $major == 0 ]]; then want=libvolux.so.0.$minor; else want=libvolux.so.$major; fi
  soname=$(readelf -d "$lib" | sed -n 's/.*SONAME.*\[\(.*\)\]/\1/p')
  [[ $soname == "$want" ]] || { echo "SONAME is '$soname', version.h implies '$want'"; bad=1; }
fi

n=$(wc -l < "$tmp/exported")
((bad)) && exit 1
echo "ok: $n exported symbols, all volux_*, equal to $(basename "$symbols") and to the VOLUX_API declarations; static archive matches"
