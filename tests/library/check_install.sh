#!/bin/bash
# `cmake --install` into a temporary prefix, then build examples/ against the
# INSTALLED tree only (not this source tree) in every supported way:
#   pkg-config + libvolux.so, pkg-config --static + libvolux.a, and
#   find_package(volux) with volux::volux and volux::volux_static;
# each program must run and pass its Beer–Lambert check. Also checks the
# layout: the public headers and nothing else, both libraries with the
# SONAME link, volux.pc, the CMake package, the CLI (which must run from the
# prefix through its RPATH).
# The headers must also compile as C99 and C++11 (embedding in C++ tools).
# Usage: check_install.sh VOLUX SRC_DIR
set -u
volux=${1:?usage: check_install.sh VOLUX SRC_DIR}
src=${2:?usage: check_install.sh VOLUX SRC_DIR}
build=$(cd "$(dirname "$volux")" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
prefix=$tmp/prefix
fail() { echo "FAIL: $*"; exit 1; }

# A sanitizer build's library needs the same runtime in the consumer.
flags=()
grep -q '^VOLUX_SANITIZE:BOOL=ON' "$build/CMakeCache.txt" && flags=(-fsanitize=address,undefined)

cmake --install "$build" --prefix "$prefix" > "$tmp/install.log" || { cat "$tmp/install.log"; fail "cmake --install"; }
pc=$(find "$prefix" -name volux.pc) ; [[ -n $pc ]] || fail "no volux.pc installed"
libdir=$(dirname "$(dirname "$pc")")
version=$(sed -n 's/^#define VOLUX_VERSION "\(.*\)"$/\1/p' "$src/include/volux/version.h")

# Layout.
for f in "$prefix/bin/volux" "$libdir/libvolux.a" "$libdir/libvolux.so" "$libdir/libvolux.so.$version" \
         "$libdir/cmake/volux/voluxConfig.cmake" "$libdir/cmake/volux/voluxConfigVersion.cmake"; do
  [[ -e $f ]] || fail "missing $f"
done
soname=$(readelf -d "$libdir/libvolux.so.$version" | sed -n 's/.*SONAME.*\[\(.*\)\]/\1/p')
[[ -L $libdir/$soname ]] || fail "no $soname link in $libdir"
diff <(cd "$src/include/volux" && ls *.h) <(cd "$prefix/include/volux" && ls) > "$tmp/hdiff" ||
  { cat "$tmp/hdiff"; fail "installed headers differ from include/volux/*.h"; }
grep -rq '"\.\./\|#include "[a-z_]*/' "$prefix/include/volux" && fail "an installed header includes outside volux/"
"$prefix/bin/volux" --version | grep -q "$version" || fail "installed CLI does not run"

export PKG_CONFIG_PATH=$libdir/pkgconfig
[[ $(pkg-config --modversion volux) == "$version" ]] || fail "pkg-config --modversion volux is not $version"
grep -q "^prefix=$prefix\$" "$pc" || fail "volux.pc does not name the install prefix $prefix"

# pkg-config, shared.
cc -std=c11 -Wall -Wextra -Werror "${flags[@]}" "$src/examples/beer_lambert.c" -o "$tmp/bl_shared" \
   $(pkg-config --cflags --libs volux) -lm -Wl,-rpath,"$libdir" || fail "pkg-config shared build"
readelf -d "$tmp/bl_shared" | grep -q "NEEDED.*\[$soname\]" || fail "consumer does not need $soname"
"$tmp/bl_shared" || fail "pkg-config shared example failed"
ldd "$tmp/bl_shared" | grep -q "$libdir/$soname" || fail "consumer did not load the installed library"

# The installed headers stand alone for C99 and C++11 consumers (extern "C",
# no C11-only syntax, no warnings under -pedantic).
printf '#include <volux/volux.h>\nint main(void) { return volux_version_number() > 0 ? 0 : 1; }\n' > "$tmp/hdr.c"
cc -std=c99 -Wall -Wextra -Werror -pedantic "${flags[@]}" "$tmp/hdr.c" -o "$tmp/hdr_c" $(pkg-config --cflags --libs volux) \
   -Wl,-rpath,"$libdir" && "$tmp/hdr_c" || fail "the headers do not compile as C99"
if command -v g++ > /dev/null; then
  g++ -std=c++11 -Wall -Wextra -Werror -pedantic "${flags[@]}" -x c++ "$tmp/hdr.c" -o "$tmp/hdr_cxx" \
      $(pkg-config --cflags --libs volux) -Wl,-rpath,"$libdir" && "$tmp/hdr_cxx" || fail "the headers do not compile as C++11"
fi

# pkg-config --static: libvolux.a plus Libs.private.
cc -std=c11 -Wall -Wextra -Werror "${flags[@]}" "$src/examples/beer_lambert.c" -o "$tmp/bl_static" \
   $(pkg-config --cflags volux) $(pkg-config --static --libs volux | sed 's/-lvolux\b/-l:libvolux.a/') -lm ||
  fail "pkg-config static build"
readelf -d "$tmp/bl_static" | grep -q 'libvolux' && fail "static consumer still needs libvolux.so"
"$tmp/bl_static" || fail "pkg-config static example failed"

# find_package(volux): the examples' own CMake project.
cmake -S "$src/examples" -B "$tmp/ex" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_C_FLAGS="${flags[*]}" > "$tmp/ex.log" 2>&1 || { cat "$tmp/ex.log"; fail "find_package(volux) configure"; }
cmake --build "$tmp/ex" -j2 >> "$tmp/ex.log" 2>&1 || { cat "$tmp/ex.log"; fail "examples build"; }
"$tmp/ex/beer_lambert" || fail "CMake example (volux::volux) failed"
"$tmp/ex/beer_lambert_static" || fail "CMake example (volux::volux_static) failed"
readelf -d "$tmp/ex/beer_lambert_static" | grep -q 'libvolux' && fail "volux::volux_static links libvolux.so"
# Python: the installed package finds the installed library by itself, and
# `pip install` of the tree works offline. (Not with a sanitizer library:
# the interpreter is not instrumented.)
if ((${#flags[@]} == 0)); then
  py=/usr/bin/python3
  pycheck='import volux, numpy as np
v = volux.Volume.from_numpy(np.ones((8, 8, 8), np.float32))
s = volux.Scene.from_json({"transfer_function": {"opacity": [[0, 0], [1, 0.5]]}, "render": {"width": 8, "height": 8}}, volume=v)
img = s.render()
assert img.shape == (8, 8, 3) and img.dtype == np.float32, img.shape
print("python ok", volux.version(), volux.__file__)'
  [[ -r $prefix/lib/python3/dist-packages/volux/_install.py ]] || fail "no installed Python package"
  (cd "$tmp" && env -u VOLUX_LIBRARY PYTHONPATH="$prefix/lib/python3/dist-packages" "$py" -c "$pycheck") |
    grep -q "python ok $version $prefix" || fail "installed Python package does not work"
  cp -r "$src/python" "$tmp/pysrc"
  "$py" -m pip install -q --no-build-isolation --no-deps --no-index --target "$tmp/pip" "$tmp/pysrc" > "$tmp/pip.log" 2>&1 ||
    { cat "$tmp/pip.log"; fail "pip install ./python (offline)"; }
  (cd "$tmp" && VOLUX_LIBRARY="$libdir/libvolux.so.$version" PYTHONPATH="$tmp/pip" "$py" -c "$pycheck") |
    grep -q "python ok $version $tmp/pip" || fail "pip-installed Python package does not work"
fi
echo "ok: installed to $prefix; pkg-config (shared, static), find_package (shared, static) and Python consumers pass"
