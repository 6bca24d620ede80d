#!/bin/bash
# The dependency rule at link level (docs/ARCHITECTURE.md): no object of a
# layer may reference a symbol that only a layer it must not use defines.
# The include roots stop an upward #include; this stops what they cannot see,
# a prototype or `extern` copied into a lower layer (or into a sibling:
# io <-> sample, one technique <-> another).
# The manifest (written by CMakeLists.txt into <build>/layers/manifest.txt)
# has tab-separated lines:
#   layer  <name>  <folders it may use, space-separated>
#   object <name>  <object file>
#   root   <name>  <its include root>        (not used here)
# A symbol defined nowhere in the manifest (libc, OpenMP, ...) is ignored.
# Usage: check_layer_symbols.sh VOLUX SRC_DIR [MANIFEST]
#   (ctest passes VOLUX = <build>/volux; the manifest defaults to the one
#   beside it)
set -u
volux=${1:?usage: check_layer_symbols.sh VOLUX SRC_DIR [MANIFEST]}
manifest=${3:-$(dirname "$volux")/layers/manifest.txt}
[[ -r $manifest ]] || { echo "no layer manifest at $manifest (configure and build first)"; exit 1; }

objects=()
while IFS=$'\t' read -r kind layer path; do
  [[ $kind == object && -n $path ]] || continue
  [[ -r $path ]] || { echo "$manifest: object $path is missing (build first)"; exit 1; }
  objects+=("$path")
done < "$manifest"
((${#objects[@]} > 0)) || { echo "$manifest lists no objects"; exit 1; }

# nm -P -A: "<object>: <symbol> <type> [value size]"; -g: external symbols only.
nm -P -g -A "${objects[@]}" | awk -v manifest="$manifest" '
  BEGIN {
    FS = "\t"
    while ((getline line < manifest) > 0) {
      split(line, f, "\t")
      if (f[1] == "layer") { sees[f[2]] = " " f[2] " " f[3] " "; may[f[2]] = f[3]; layers++ }
      else if (f[1] == "object" && f[3] != "") layer_of[f[3]] = f[2]
    }
    FS = " "
  }
  {
    obj = $1; sub(/:$/, "", obj); sym = $2; type = $3
    layer = layer_of[obj]
    if (layer == "") { print "nm reported an object not in the manifest: " obj; bad = 1; next }
    if (type == "U") { nrefs++; ref_obj[nrefs] = obj; ref_sym[nrefs] = sym; ref_layer[nrefs] = layer }
    else if (type != "w" && type != "v") {
      if (index(" " defined_in[sym] " ", " " layer " ") == 0) defined_in[sym] = defined_in[sym] " " layer
      ndefs++
    }
  }
  END {
    cross = 0
    for (i = 1; i <= nrefs; i++) {
      sym = ref_sym[i]; layer = ref_layer[i]
      if (!(sym in defined_in)) continue # outside the library
      n = split(defined_in[sym], where, " ")
      ok = 0
      for (k = 1; k <= n; k++) if (index(sees[layer], " " where[k] " ")) ok = 1
      if (ok) { if (defined_in[sym] != " " layer) cross++; continue }
      printf "%s: layer violation: %s references %s, defined only in%s (it may use: %s)\n",
             ref_obj[i], layer, sym, defined_in[sym], may[layer]
      bad = 1
    }
    if (!bad) printf "layer symbols hold: %d layers, %d symbols defined, %d cross-layer references, all allowed\n",
                      layers, ndefs, cross
    exit bad
  }'
