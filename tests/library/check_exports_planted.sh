#!/bin/bash
# A check must be seen to fail (STYLE §13): plants each kind of ABI mistake in
# a tiny stand-in library and checks that check_exports.sh refuses it by
# name, and that the clean stand-in passes.
# Usage: check_exports_planted.sh VOLUX SRC_DIR
set -u
src=${2:?usage: check_exports_planted.sh VOLUX SRC_DIR}
check=$src/tests/library/check_exports.sh
cc=${CC:-cc}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0

# make_lib NAME C-SOURCE: a shared library and an "installable" archive of
# it, built the way cmake/library.cmake builds volux (hidden by default).
make_lib() {
  mkdir -p "$tmp/$1"
  printf '%s\n' "$2" > "$tmp/$1/lib.c"
  $cc -fPIC -fvisibility=hidden -c "$tmp/$1/lib.c" -o "$tmp/$1/lib.o" || exit 1
  $cc -shared -Wl,-soname,libplanted.so.0 "$tmp/$1/lib.o" -o "$tmp/$1/lib.so" || exit 1
  ld -r -o "$tmp/$1/all.o" "$tmp/$1/lib.o" && objcopy --localize-hidden "$tmp/$1/all.o" &&
    ar qc "$tmp/$1/lib.a" "$tmp/$1/all.o" || exit 1
}
# expect NAME SYMBOLS-FILE HEADER-DIR PATTERN: the check fails and says PATTERN.
expect() {
  out=$(bash "$check" "$tmp/volux" "$src" "$tmp/$1/lib.so" "${5:-$tmp/$1/lib.a}" "$2" "$3" 2>&1)
  rc=$?
  if [[ $4 == ok ]]; then
    if [[ $rc == 0 ]]; then echo "ok   $1 passes"; else echo "FAIL $1: clean case refused: $out"; fail=1; fi
  elif [[ $rc == 0 ]] || ! grep -q -- "$4" <<< "$out"; then
    echo "FAIL $1: expected '$4', got (rc $rc): $out"; fail=1
  else
    echo "ok   $1 refused: $(grep -- "$4" <<< "$out" | head -1)"
  fi
}

API='__attribute__((visibility("default")))'
mkdir -p "$tmp/h" && printf '#define VOLUX_API %s\nVOLUX_API int volux_a(void);\nVOLUX_API int volux_b(int x);\n' "$API" > "$tmp/h/a.h"
printf 'volux_a\nvolux_b\n' > "$tmp/list"
good="$API int volux_a(void) { return 1; }
$API int volux_b(int x) { return x; }
int helper(void) { return 2; }"

make_lib clean "$good"
expect clean "$tmp/list" "$tmp/h" ok
make_lib leak "$good
$API int tube_march(void) { return 3; }"
expect leak "$tmp/list" "$tmp/h" "leaked internal symbol: tube_march"
make_lib extra "$good
$API int volux_secret(void) { return 4; }"
expect extra "$tmp/list" "$tmp/h" "unlisted export: volux_secret"
make_lib removed "$API int volux_a(void) { return 1; }"
expect removed "$tmp/list" "$tmp/h" "removed export: volux_b"
mkdir -p "$tmp/h2" && printf '#define VOLUX_API x\nVOLUX_API int volux_a(void);\n' > "$tmp/h2/a.h"
expect clean "$tmp/list" "$tmp/h2" "undeclared listing: volux_b"
printf 'VOLUX_API int volux_c(void);\n' >> "$tmp/h2/a.h" && printf 'VOLUX_API int volux_b(int x);\n' >> "$tmp/h2/a.h"
expect clean "$tmp/list" "$tmp/h2" "unlisted declaration: volux_c"
# An archive made without --localize-hidden leaks the hidden helper.
ar qc "$tmp/clean/raw.a" "$tmp/clean/lib.o"
expect clean "$tmp/list" "$tmp/h" "static archive leak: .* helper" "$tmp/clean/raw.a"
exit $fail
