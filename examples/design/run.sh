#!/bin/sh
# ---------------------------------------------------------------------------------------------
# pvdfkit example: choose a sensor layout before fabrication (docs/design.md).
#
# What it shows: seed 001's three-electrode triangle compared with three alternatives — the
# same triangle enlarged to 16 mm circumradius, four electrodes on a square with the film drawn
# at 45 degrees, and seed 001's triangle on a film drawn at 45 degrees — by the Cramér–Rao
# bound of the lookup's position and force errors, the area where it meets a 0.5 mm target,
# the ambiguity regions, per-electrode sensitivity, 12-bit dynamic range and dead zones; then a
# sweep of the triangle's size with the best size marked, and the same comparison with the
# force measured separately.
#
# Run:     examples/design/run.sh [OUTDIR] [MAPS]
#          MAPS = synthetic (default: instant previews on the analytic stand-in, a few seconds)
#               | fem (FEM maps at a coarse 6 mm preview spacing: ~10-20 min on 2 cores)
#          pvdfkit is found by examples/find-pvdfkit.sh: $PVDFKIT, else this checkout's
#          build/app/pvdfkit, else the one on PATH.
# Expect:  a ranking table on stdout (four electrodes first: the only layout with a large usable
#          area when the force is unknown), OUTDIR/compare/design_position.png and
#          design_force.png (maps side by side), OUTDIR/sweep/design_sweep.png (figure of merit
#          against the triangle's circumradius), OUTDIR/*/design.json.
# ---------------------------------------------------------------------------------------------
set -eu
HERE=$(cd "$(dirname "$0")" && pwd)
if [ -f "${1:-}" ] && [ -x "${1:-}" ]; then
  echo "error: $1: the pvdfkit binary is no longer an argument; run examples/design/run.sh [OUTDIR] [MAPS]" \
       "(set PVDFKIT=$1 to choose it)" >&2
  exit 2
fi
. "$HERE/../find-pvdfkit.sh"
OUT=${1:-design-example}
MAPS=${2:-synthetic}
SCENES="$HERE/../scenes"
mkdir -p "$OUT"
if [ "$MAPS" = synthetic ]; then
  SOURCE="--synthetic --spacing-m 0.0015"
else
  SOURCE="--spacing-m 0.006"
fi

echo "== 1. Compare seed 001's triangle with three alternatives (force unknown, 0.05 pC noise, 12-bit ADC, target 0.5 mm)"
"$PVDFKIT" design "$SCENES/seed001.json" "$SCENES/design-large-triangle.json" \
  "$SCENES/four-electrodes-45deg.json" "$SCENES/design-draw-45deg.json" \
  --noise-C 5e-14 --target-mm 0.5 $SOURCE --out-dir "$OUT/compare"

echo "== 2. The same layouts with the force measured separately (a force transducer)"
if [ "$MAPS" = synthetic ]; then
  "$PVDFKIT" design "$SCENES/seed001.json" "$SCENES/design-large-triangle.json" \
    "$SCENES/four-electrodes-45deg.json" "$SCENES/design-draw-45deg.json" \
    --force-known --noise-C 5e-14 --target-mm 0.5 $SOURCE --out-dir "$OUT/compare-force-known"
else  # reuse the FEM maps of step 1: no new solves
  MAPSDIR="$OUT/compare/maps"
  "$PVDFKIT" design --map "$MAPSDIR/seed001_6mm.h5" --map "$MAPSDIR/design-large-triangle_6mm.h5" \
    --map "$MAPSDIR/four-electrodes-45deg_6mm.h5" --map "$MAPSDIR/design-draw-45deg_6mm.h5" \
    --force-known --noise-C 5e-14 --target-mm 0.5 --out-dir "$OUT/compare-force-known"
fi

echo "== 3. Sweep the triangle's size (mean distance of the electrodes from their centroid) and mark the best"
if [ "$MAPS" = synthetic ]; then
  "$PVDFKIT" design "$SCENES/seed001.json" --vary @layout_radius_m=0.006:0.002:0.02 --force-known \
    --synthetic --spacing-m 0.0015 --refine-best 1 --out-dir "$OUT/sweep"
else
  "$PVDFKIT" design "$SCENES/seed001.json" --vary @layout_radius_m=0.006:0.005:0.021 --force-known \
    --spacing-m 0.006 --out-dir "$OUT/sweep"
fi

echo "== 4. A layout that cannot work is refused: electrode C moved onto B overlaps it (exit 2, the file and key named)"
sed 's/"name": "C", "center_m": \[0.00866025403784439, -0.005\]/"name": "C", "center_m": [-0.00866025403784439, -0.005]/' \
  "$SCENES/seed001.json" > "$OUT/coincident.json"
if "$PVDFKIT" design "$OUT/coincident.json" --synthetic --spacing-m 0.002 --no-plots > "$OUT/coincident.txt" 2>&1; then
  echo "expected exit 2 for coincident electrodes"; exit 1
fi
grep "electrodes\[2\].*overlaps" "$OUT/coincident.txt"
