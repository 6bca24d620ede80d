#!/bin/bash
# The dependency rule (docs/ARCHITECTURE.md): include ← core ← sample ←
# render ← techniques ← tools, io → core only, and techniques may call io.
# Fails on any #include that crosses a layer the wrong way.  Usage: check_layers.sh VOLUX SRC_DIR
set -u
src=${2:?usage: check_layers.sh VOLUX SRC_DIR}
cd "$src" || exit 1
bad=0
check() { # folder, forbidden include prefixes...
  local dir=$1; shift
  for prefix in "$@"; do
    hits=$(grep -rnE "^#include \"$prefix" "$dir" 2>/dev/null)
    if [[ -n $hits ]]; then echo "layer violation ($dir must not include $prefix):"; echo "$hits"; bad=1; fi
  done
}
check src/core       'sample/' 'render/' 'techniques/' 'io/'
check src/sample     'render/' 'techniques/' 'io/'
check src/render     'techniques/' 'io/'
check src/io         'sample/' 'render/' 'techniques/'
check src/techniques 'tools/'
check tools          'core/' 'sample/' 'render/' 'techniques/' 'io/'
# techniques never include each other: only their own folder and shared ones
for t in src/techniques/*/; do
  name=$(basename "$t")
  hits=$(grep -rnE '^#include "techniques/' "$t" | grep -v "techniques/$name/" | grep -v 'techniques/common/')
  if [[ -n $hits ]]; then echo "technique $name includes another technique:"; echo "$hits"; bad=1; fi
done
((bad == 0)) && echo "dependency rule holds"
exit $bad
