#!/bin/sh
# CI check of the installable runtime: `cmake --install` the lookup component into a temporary
# prefix, configure and build examples/deploy against it with find_package(pvdfkit), run it on a
# flat map exported by `pvdfkit export-map` and a recorded stream, and compare its output with
# `pvdfkit locate MAP.h5 --stream` on the same input (identical rows expected: same runtime, and
# the flat map holds the HDF5 map's numbers bit for bit). Also: the installed program loads no
# HDF5/PNG/FreeType/Cairo/deal.II library, and refuses a truncated flat map with exit 2.
#   deploy_example.sh PVDFKIT BUILD_DIR SOURCE_DIR WORK_DIR MAKE_STREAM CXX_COMPILER
set -eu
pvdfkit=$1 build=$2 source=$3 work=$4 make_stream=$5 cxx=$6
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix

# 1. Install the runtime alone (component lookup) into the temporary prefix.
cmake --install "$build" --prefix "$prefix" --component lookup > "$work/install.log"
for f in lib/cmake/pvdfkit/pvdfkitConfig.cmake lib/cmake/pvdfkit/pvdfkitConfigVersion.cmake \
         include/pvdf/mapping/locator.hpp include/pvdf/mapping/flat_map.hpp; do
  [ -f "$prefix/$f" ] || fail "the install lacks $f"
done
ls "$prefix"/lib*/libpvdf_lookup.a > /dev/null 2>&1 || ls "$prefix"/lib/*/libpvdf_lookup.a > /dev/null 2>&1 \
  || fail "the install lacks libpvdf_lookup.a"
if find "$prefix" -name '*hdf5*' -o -name 'map_io*' -o -name 'pictures.hpp' -o -name 'generate.hpp' | grep -q .; then
  fail "the runtime install holds more than the runtime: $(find "$prefix" -name '*hdf5*' -o -name 'pictures.hpp' -o -name 'generate.hpp')"
fi

# 2. Build examples/deploy against the installed package only.
cmake -S "$source/examples/deploy" -B "$work/build" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF > "$work/configure.log" 2>&1 \
  || { cat "$work/configure.log"; fail "configuring examples/deploy against $prefix"; }
grep -q "^pvdfkit_DIR:PATH=$prefix/" "$work/build/CMakeCache.txt" || fail "find_package(pvdfkit) did not use $prefix"
cmake --build "$work/build" > "$work/build.log" 2>&1 || { cat "$work/build.log"; fail "building examples/deploy"; }
exe=$work/build/locate_flat
if ldd "$exe" | grep -Eiq 'hdf5|png|freetype|cairo|deal'; then fail "locate_flat loads $(ldd "$exe" | grep -Ei 'hdf5|png|freetype|cairo|deal')"; fi

# 3. A map, its flat export, a recorded stream.
# The map carries per-node charge error estimates (flat map version 2, content bit 2).
"$pvdfkit" synthetic-map -o "$work/plain.h5" --spacing-m 0.002 --forces-N 0.5,1,2 > /dev/null
"$make_stream" --with-errors "$work/plain.h5" "$work/map.h5" || fail "adding per-node errors to the map"
"$pvdfkit" export-map "$work/map.h5" -o "$work/map.flat" || fail "export-map"
[ "$(od -An -tu4 -j8 -N4 "$work/map.flat" | tr -d ' ')" = 2 ] || fail "the flat map is not version 2"
[ $(($(od -An -tu4 -j32 -N4 "$work/map.flat" | tr -d ' ') & 4)) -eq 4 ] || fail "the flat map lacks the charge error section (bit 2)"
"$make_stream" "$work/map.h5" > "$work/stream.csv"

# 4. The same answers from the installed program and from pvdfkit.
"$exe" "$work/map.flat" < "$work/stream.csv" > "$work/deployed.csv" 2> "$work/deployed.err" \
  || { cat "$work/deployed.err"; fail "locate_flat exited $?"; }
"$pvdfkit" locate "$work/map.h5" --stream < "$work/stream.csv" > "$work/pvdfkit.csv" 2> "$work/pvdfkit.err"
rows=$(($(wc -l < "$work/pvdfkit.csv") - 1))
[ "$rows" -eq 1500 ] || fail "pvdfkit located $rows rows, expected 1500 (1501 data rows, one malformed)"
located=$(awk -F, 'NR > 1 && $2 != ""' "$work/pvdfkit.csv" | wc -l)
[ "$located" -ge 1300 ] || fail "only $located of $rows rows located: the stream is not a useful comparison"
cmp "$work/deployed.csv" "$work/pvdfkit.csv" || { diff "$work/deployed.csv" "$work/pvdfkit.csv" | head -5; fail "answers differ"; }
echo "installed runtime: $rows rows, $located located, identical to pvdfkit locate --stream"

# 5. A truncated flat map: exit 2 and one error line naming the file.
head -c 1000 "$work/map.flat" > "$work/cut.flat"
set +e
"$exe" "$work/cut.flat" < "$work/stream.csv" > /dev/null 2> "$work/cut.err"
rc=$?
set -e
[ "$rc" -eq 2 ] || fail "a truncated flat map gave exit $rc, expected 2"
[ "$(wc -l < "$work/cut.err")" -eq 1 ] && grep -q "^error: $work/cut.flat: truncated" "$work/cut.err" \
  || fail "a truncated flat map: $(cat "$work/cut.err")"
echo "truncated flat map refused: $(cat "$work/cut.err")"
