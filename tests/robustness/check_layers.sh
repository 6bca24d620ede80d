#!/bin/bash
# The dependency rule (docs/ARCHITECTURE.md): include/volux <- core <- sample
# <- render <- techniques <- tools, io -> core only, and techniques may use io.
# A technique folder includes only itself, the shared family folders below
# and the lower layers; src/techniques/*.c (the registry) may name any
# technique; tools/ includes only volux/ and tools/ headers (the CLI and its
# MPI front end share tools/cli/cli.h and tools/mpi/distribute.h).
# Every #include "..." or <...> whose target starts with a project folder is
# judged on its target alone; a target containing ".." is always refused (it
# would step around the per-layer include roots the build uses).
# Usage: check_layers.sh VOLUX SRC_DIR   (VOLUX unused; ctest passes it)
set -u
root=${2:?usage: check_layers.sh VOLUX SRC_DIR}
cd "$root" || exit 1

# Technique folders that other technique folders may include (the one list;
# CMakeLists.txt's VOLUX_SHARED_TECHNIQUE_FOLDERS must match it).
SHARED_TECHNIQUE_FOLDERS=(scatter)

bad=0
# allowed_for FILE: the include prefixes FILE may use, one per line. An
# include without a slash is a same-folder header and always allowed.
allowed_for() {
  local f=$1
  case $f in
    include/volux/*) echo volux/ ;;
    src/core/*)      printf '%s\n' volux/ core/ ;;
    src/io/*)        printf '%s\n' volux/ core/ io/ ;;
    src/sample/*)    printf '%s\n' volux/ core/ sample/ ;;
    src/render/*)    printf '%s\n' volux/ core/ sample/ render/ ;;
    src/techniques/*/*)
      local name=${f#src/techniques/}; name=${name%%/*}
      printf '%s\n' volux/ core/ io/ sample/ render/ "techniques/$name/"
      for s in "${SHARED_TECHNIQUE_FOLDERS[@]}"; do echo "techniques/$s/"; done ;;
    src/techniques/*) printf '%s\n' volux/ core/ io/ sample/ render/ techniques/ ;;
    tools/*)         printf '%s\n' volux/ tools/ ;;
    *)               echo "unknown location $f" >&2; return 1 ;;
  esac
}

project='(volux|core|io|sample|render|techniques|tools)/'
while IFS= read -r -d '' f; do
  allowed=$(allowed_for "$f") || { bad=1; continue; }
  # line number and include target of every #include in f
  while IFS=$'\t' read -r line target; do
    if [[ $target == *..* ]]; then
      echo "$f:$line: layer violation: #include \"$target\" steps out with '..'"; bad=1; continue
    fi
    [[ $target == */* ]] || continue # same-folder header
    [[ $target =~ ^$project ]] || continue # a system or third-party header
    ok=0
    while IFS= read -r prefix; do [[ $target == "$prefix"* ]] && ok=1 && break; done <<< "$allowed"
    if ((ok == 0)); then
      echo "$f:$line: layer violation: ${f%/*}/ must not include \"$target\""; bad=1
    fi
  done < <(awk '{ if (match($0, /^[ \t]*#[ \t]*include[ \t]*["<][^">]+[">]/)) {
                    s = substr($0, RSTART, RLENGTH); sub(/^[^"<]*["<]/, "", s); sub(/[">]$/, "", s);
                    printf "%d\t%s\n", NR, s } }' "$f")
done < <(find include src tools -type f \( -name '*.c' -o -name '*.h' \) -print0 | sort -z)

((bad == 0)) && echo "dependency rule holds"
exit $bad
