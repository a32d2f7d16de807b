#!/bin/sh
# `--plot` writes PNG, SVG or PDF by the file extension, through the command line: moduli, rays
# and mesh previews; another extension is a one-line error with exit 2.
# Usage: cli_formats.sh PVDFKIT WORKDIR SCENE
set -u
P=$1
W=$2
S=$3
mkdir -p "$W"
fail() { echo "FAIL: $*"; exit 1; }
check() {  # check FILE KIND: the file starts as a PNG, an SVG (XML) or a PDF must
  case $2 in
    png) head -c 8 "$1" | od -An -tx1 | tr -d ' \n' | grep -q '^89504e470d0a1a0a$' || fail "$1 is not a PNG" ;;
    svg) head -c 200 "$1" | grep -q '<?xml' && grep -q '<svg' "$1" || fail "$1 is not an SVG" ;;
    pdf) head -c 5 "$1" | grep -q '^%PDF-' || fail "$1 is not a PDF" ;;
  esac
}
for ext in png svg pdf PDF; do
  rm -f "$W/moduli.$ext"
  "$P" moduli --scene "$S" --plot "$W/moduli.$ext" > /dev/null || fail "moduli --plot .$ext exit $?"
  check "$W/moduli.$ext" "$(echo $ext | tr A-Z a-z)"
done
grep -q 'Poisson' "$W/moduli.svg" || fail "the SVG has no text layer"
"$P" synthetic-map -o "$W/map.h5" --spacing-m 0.002 > /dev/null || fail "synthetic-map exit $?"
for ext in png svg pdf; do
  "$P" rays "$W/map.h5" --plot "$W/rays.$ext" > /dev/null || fail "rays --plot .$ext exit $?"
  check "$W/rays.$ext" $ext
done
"$P" mesh "$S" -o "$W/film.msh" --preview "$W/film.svg" > /dev/null || fail "mesh --preview .svg exit $?"
check "$W/film.svg" svg
"$P" moduli --scene "$S" --plot "$W/moduli.jpg" > /dev/null 2> "$W/err.txt"
code=$?
[ $code = 2 ] || fail "--plot .jpg exit $code"
[ "$(wc -l < "$W/err.txt" | tr -d ' ')" = 1 ] || fail "--plot .jpg printed $(cat "$W/err.txt")"
grep -q '^error: .*moduli.jpg.*\.png, \.svg or \.pdf' "$W/err.txt" || fail "--plot .jpg message: $(cat "$W/err.txt")"
echo "--plot formats: all checks passed"
