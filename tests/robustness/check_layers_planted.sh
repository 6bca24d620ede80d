#!/bin/bash
# Proves the three guards of the dependency rule fire (docs/ARCHITECTURE.md):
#  1. check_layers.sh, on a copy of the tree with one violation planted at a
#     time: it must exit non-zero and name the planted file and line;
#  2. check_layer_symbols.sh, on the build's manifest plus one planted object
#     that references a symbol of a layer it must not use;
#  3. the per-layer include roots of the build: an upward #include compiled
#     against a layer's root fails with "No such file".
# Each has a control that must pass (the tree as is, an allowed reference),
# so a guard that always fails cannot pass this test either.
# Usage: check_layers_planted.sh VOLUX SRC_DIR
set -u
volux=${1:?usage: check_layers_planted.sh VOLUX SRC_DIR}
src=$(cd "${2:?usage: check_layers_planted.sh VOLUX SRC_DIR}" && pwd)
manifest=$(dirname "$volux")/layers/manifest.txt
cc=${CC:-cc}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# ---------------------------------------------------------------- 1. includes
mkdir "$tmp/tree"
cp -r "$src/include" "$src/src" "$src/tools" "$tmp/tree/"
layers() { bash "$src/tests/robustness/check_layers.sh" "$volux" "$tmp/tree" > "$tmp/out" 2>&1; }
first() { (cd "$tmp/tree" && ls $1 2>/dev/null | head -n 1); }
# hdr FOLDER: a header that exists in src/FOLDER, as an include target.
hdr() { echo "$1/$(cd "$src/src/$1" && ls *.h | head -n 1)"; }

layers || { cat "$tmp/out"; fail "check_layers.sh rejects the unmodified tree"; }

# expect_include_violation FILE INCLUDE-LINE: plant the line first in FILE,
# check that the script fails naming FILE:1, restore FILE.
expect_include_violation() {
  local file=$1 line=$2
  [[ -n $file ]] || { fail "no file to plant '$line' in"; return; }
  cp "$tmp/tree/$file" "$tmp/saved"
  { echo "$line"; cat "$tmp/saved"; } > "$tmp/tree/$file"
  if layers; then fail "check_layers.sh accepted '$line' in $file"
  elif ! grep -q "^$file:1: layer violation" "$tmp/out"; then cat "$tmp/out"; fail "check_layers.sh did not name $file:1"
  else echo "planted '$line' in $file -> $(grep "^$file:1:" "$tmp/out")"; fi
  cp "$tmp/saved" "$tmp/tree/$file"
}
expect_include_ok() {
  local file=$1 line=$2
  cp "$tmp/tree/$file" "$tmp/saved"
  { echo "$line"; cat "$tmp/saved"; } > "$tmp/tree/$file"
  layers || { cat "$tmp/out"; fail "check_layers.sh refused the allowed '$line' in $file"; }
  cp "$tmp/saved" "$tmp/tree/$file"
}

lightvol_h=$(hdr techniques/lightvol)
expect_include_violation "$(first 'src/techniques/ambient/*.c')" "#include \"$(hdr techniques/lightvol)\""
expect_include_violation "$(first 'src/techniques/scatter/*.c')" "#include \"$(hdr techniques/ambient)\""
expect_include_violation "$(first 'src/techniques/dvr/*.c')" "#include \"../${lightvol_h#techniques/}\""
expect_include_violation "$(first 'src/core/*.c')" "#include \"$(hdr render)\""
expect_include_violation "$(first 'src/core/*.h')" "#  include <$(hdr techniques/dvr)>"
expect_include_violation "$(first 'src/io/*.c')" "#include \"$(hdr sample)\""
expect_include_violation "$(first 'src/sample/*.c')" "#include \"$(hdr io)\""
expect_include_violation "$(first 'src/render/*.c')" "#include \"$(hdr io)\""
expect_include_violation "$(first 'src/render/*.c')" "#include \"$(hdr techniques/dvr)\""
expect_include_violation "$(first 'tools/cli/*.c')" "#include \"$(hdr core)\""
expect_include_violation include/volux/volux.h "#include \"$(hdr core)\""
expect_include_ok "$(first 'src/techniques/ambient/*.c')" "#include \"$(hdr techniques/scatter)\""
expect_include_ok "$(first 'src/techniques/lightvol/*.c')" "#include \"$(hdr io)\""
expect_include_ok "$(first 'src/techniques/*.c')" "#include \"$(hdr techniques/dvr)\""

# ---------------------------------------------------------------- 2. symbols
symbols() { bash "$src/tests/robustness/check_layer_symbols.sh" "$volux" "$src" "$tmp/manifest" > "$tmp/out" 2>&1; }
if [[ ! -r $manifest ]]; then
  fail "no layer manifest at $manifest"
else
  cp "$manifest" "$tmp/manifest"
  symbols || { cat "$tmp/out"; fail "check_layer_symbols.sh rejects the build as is"; }
  # defined_in LAYER: one function (type T) that LAYER's objects define.
  defined_in() {
    local objs
    mapfile -t objs < <(awk -F'\t' -v l="$1" '$1 == "object" && $2 == l && $3 != "" { print $3 }' "$manifest")
    ((${#objs[@]})) && nm -P -g --defined-only "${objs[@]}" 2>/dev/null | awk '$2 == "T" { print $1; exit }'
  }
  # plant LAYER SYMBOL: an object of LAYER that calls SYMBOL, as a copied
  # prototype would; echoes its path.
  plant() {
    local base="$tmp/planted_${1//\//_}_$2"
    printf 'extern void %s(void);\nvoid volux_planted(void) { %s(); }\n' "$2" "$2" > "$base.c"
    "$cc" -c -w "$base.c" -o "$base.o" || { fail "cannot compile a planted object"; return 1; }
    printf 'object\t%s\t%s\n' "$1" "$base.o" >> "$tmp/manifest"
    echo "$base.o"
  }
  expect_symbol_violation() { # LAYER DEFINING-LAYER
    local sym obj
    sym=$(defined_in "$2")
    [[ -n $sym ]] || { fail "layer $2 defines no function to reference"; return; }
    cp "$manifest" "$tmp/manifest"
    obj=$(plant "$1" "$sym") || return
    if symbols; then fail "check_layer_symbols.sh accepted $1 calling $sym of $2"
    elif ! grep -q "^$obj: layer violation: $1 references $sym" "$tmp/out"; then cat "$tmp/out"; fail "check_layer_symbols.sh did not name $obj"
    else echo "planted $1 -> $sym ($2): $(grep "^$obj:" "$tmp/out" | sed "s|$tmp/||")"; fi
  }
  expect_symbol_ok() { # LAYER DEFINING-LAYER
    local sym
    sym=$(defined_in "$2")
    cp "$manifest" "$tmp/manifest"
    plant "$1" "$sym" > /dev/null || return
    symbols || { cat "$tmp/out"; fail "check_layer_symbols.sh refused the allowed $1 -> $sym ($2)"; }
  }
  expect_symbol_violation core techniques
  expect_symbol_violation core render
  expect_symbol_violation render techniques
  expect_symbol_violation io sample
  expect_symbol_violation sample io
  expect_symbol_violation techniques/ambient techniques/lightvol
  expect_symbol_violation techniques/scatter techniques/ambient
  expect_symbol_ok techniques/ambient techniques/scatter
  expect_symbol_ok techniques/ambient io
  expect_symbol_ok techniques techniques/lightvol
  expect_symbol_ok render core
fi

# ---------------------------------------------------------------- 3. include roots
root_of() { awk -F'\t' -v l="$1" '$1 == "root" && $2 == l { print $3 }' "$manifest" 2>/dev/null; }
compiles() { # LAYER INCLUDE: does `#include INCLUDE` compile against LAYER's root?
  printf '#include "%s"\n' "$2" > "$tmp/probe.c"
  "$cc" -std=c11 -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE -fsyntax-only \
        -I "$src/include" -I "$(root_of "$1")" "$tmp/probe.c" > "$tmp/out" 2>&1
}
expect_root_refuses() {
  if compiles "$1" "$2"; then fail "layer $1's include root reaches $2"
  elif ! grep -q "No such file" "$tmp/out"; then cat "$tmp/out"; fail "$1 including $2 failed for another reason"
  else echo "include root of $1 refuses $2: $(grep -m1 'No such file' "$tmp/out" | sed "s|$tmp/||")"; fi
}
expect_root_allows() { compiles "$1" "$2" || { cat "$tmp/out"; fail "layer $1's include root refuses $2"; }; }
if [[ -r $manifest ]]; then
  raycaster=render/raycaster.h
  [[ -f $src/src/$raycaster ]] || raycaster=render/$(cd "$src/src/render" && ls *.h | head -n 1)
  lightvol=techniques/lightvol/$(cd "$src/src/techniques/lightvol" && ls *.h | head -n 1)
  scatter=techniques/scatter/$(cd "$src/src/techniques/scatter" && ls *.h | head -n 1)
  expect_root_refuses core "$raycaster"
  expect_root_refuses io "$raycaster"
  expect_root_refuses techniques/ambient "$lightvol"
  expect_root_allows render "$raycaster"
  expect_root_allows techniques/ambient "$scatter"
  expect_root_allows techniques/lightvol "$lightvol"
fi

((failures == 0)) && echo "every layer guard fires on its planted violation"
exit $((failures > 0))
