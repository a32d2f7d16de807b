#!/bin/sh
# `pvdfkit export-map` end to end: the binary file and the C header hold the same bytes (the
# header is compiled with the C compiler by a program that writes its array back out), --format
# and --symbol work, and bad input exits 2 with one `error: ...` line.
#   export_map_cli.sh PVDFKIT WORK_DIR C_COMPILER
set -eu
pvdfkit=$1 work=$2 cc=$3
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
"$pvdfkit" synthetic-map -o "$work/map.h5" --spacing-m 0.002 --forces-N 0.5,1,2 > /dev/null

"$pvdfkit" export-map "$work/map.h5" -o "$work/map.flat" > "$work/out.txt"
grep -q "^wrote $work/map.flat (flat map, [0-9]* bytes" "$work/out.txt" || fail "binary: $(cat "$work/out.txt")"
[ "$(head -c 8 "$work/map.flat")" = PVDFFLAT ] || fail "the binary does not start with PVDFFLAT"
[ "$(od -An -tu4 -j8 -N4 "$work/map.flat" | tr -d ' ')" = 2 ] || fail "the binary is not flat map version 2"
grep -q "no per-node charge errors; version 2)" "$work/out.txt" || fail "the summary does not say what errors it carries: $(cat "$work/out.txt")"
"$pvdfkit" export-map "$work/map.h5" -o "$work/sensor_map.h" > /dev/null
grep -q 'static const unsigned char sensor_map\[sensor_map_SIZE\]' "$work/sensor_map.h" || fail "C header lacks the array sensor_map"
"$pvdfkit" export-map "$work/map.h5" -o "$work/other.txt" --format c-header --symbol film_a > /dev/null
grep -q 'film_a_SIZE' "$work/other.txt" || fail "--format c-header --symbol film_a"

# The C header, compiled as C89, gives back the binary file's bytes.
cat > "$work/dump.c" <<'C'
#include <stdio.h>
#include "sensor_map.h"
int main(void) { return fwrite(sensor_map, 1, sensor_map_SIZE, stdout) == sensor_map_SIZE ? 0 : 1; }
C
"$cc" -std=c89 -pedantic -Wall -Werror -I"$work" "$work/dump.c" -o "$work/dump" || fail "the C header does not compile as C89"
"$work/dump" > "$work/from_header.flat"
cmp "$work/from_header.flat" "$work/map.flat" || fail "the C header's bytes differ from the binary file"

# Bad input: exit 2, one line naming input, value and fix.
expect_error() {  # expect_error WHAT PATTERN ARGS...
  what=$1 pattern=$2
  shift 2
  set +e
  "$pvdfkit" export-map "$@" > /dev/null 2> "$work/err.txt"
  rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "$what: exit $rc, expected 2 ($(cat "$work/err.txt"))"
  [ "$(wc -l < "$work/err.txt")" -eq 1 ] || fail "$what: not one line: $(cat "$work/err.txt")"
  grep -q "^error: .*$pattern" "$work/err.txt" || fail "$what: $(cat "$work/err.txt")"
}
expect_error "missing map" "missing.h5" "$work/missing.h5" -o "$work/x.flat"
expect_error "flat file given as the map" "map.flat" "$work/map.flat" -o "$work/x.flat"
expect_error "bad --format" "format" "$work/map.h5" -o "$work/x.flat" --format elf
expect_error "bad --symbol" "symbol 9lives.*C identifier" "$work/map.h5" -o "$work/x.h" --symbol 9lives
expect_error "--symbol for a binary" "symbol.*C header" "$work/map.h5" -o "$work/x.flat" --symbol ok_name
expect_error "output is a folder" "$work" "$work/map.h5" -o "$work"
[ ! -e "$work/x.flat" ] && [ ! -e "$work/x.h" ] || fail "a refused export left a file behind"
echo "export-map: binary and C header agree ($(wc -c < "$work/map.flat") bytes); bad input refused"
