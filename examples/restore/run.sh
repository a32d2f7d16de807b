#!/bin/sh
# ---------------------------------------------------------------------------------------------
# pvdfkit example: seed 000's two-edge experiment, in simulation (docs/restore.md).
#
# What it shows: the cylindrical PVDF scanner of seed 000 is simulated scanning two raised edges
# with known forces (0.6, 0.9) N and (0.2, 1.0) N (Figs 11-12); the 2x2 transfer matrix G is
# identified from those two scans (eq. 6) and inverted with regularization (eq. 4) into four FIR
# filters (Fig. 13); the filters then restore f_x, f_z and mu from a new scan of a surface with two
# edges and a ridged texture whose friction rises from 0.2 to 0.8 (Fig. 14). Once with the paper's
# settings (Tikhonov, constant beta = 1e-4, no target, no low cut), once with the defaults (isotropic
# regularization, beta chosen by the predicted mu error, a target resolution and a low cut from the
# strips' effective depth).
#
# Run:     examples/restore/run.sh [OUTDIR]
#          (default ./restore-example). About 2 s. pvdfkit is found by examples/find-pvdfkit.sh:
#          $PVDFKIT, else this checkout's build/app/pvdfkit, else the one on PATH.
# Expect:  the edges of the test surface restored at -30 mm and -15 mm (no shift), PNGs of Figs
#          11-14 in OUTDIR/plots*, forces in OUTDIR/forces*.csv with columns
#          x_m,fx_N,fz_N,mu,mu_valid,fx_N_per_m,fz_N_per_m (line forces in N/m, per sample in N).
# ---------------------------------------------------------------------------------------------
set -eu
HERE=$(cd "$(dirname "$0")" && pwd)
if [ -f "${1:-}" ] && [ -x "${1:-}" ]; then
  echo "error: $1: the pvdfkit binary is no longer an argument; run examples/restore/run.sh [OUTDIR]" \
       "(set PVDFKIT=$1 to choose it)" >&2
  exit 2
fi
. "$HERE/../find-pvdfkit.sh"
OUT=${1:-restore-example}
mkdir -p "$OUT"

echo "== 1. Scan the two raised edges of seed 000 Fig. 6 (edge at x = -12.5 mm)"
"$PVDFKIT" restore simulate "$HERE/edge_a.json" -o "$OUT/edge_a.csv" --plot "$OUT/fig11_edge_a.png"
"$PVDFKIT" restore simulate "$HERE/edge_b.json" -o "$OUT/edge_b.csv" --plot "$OUT/fig12_edge_b.png"

echo "== 2. Identify G and design the inverse filters as in the paper (Tikhonov, constant beta = 1e-4, no target, no low cut)"
"$PVDFKIT" restore identify --scan "$OUT/edge_a.csv" --force 0.6,0.9 --edge-x-m -0.0125 \
  --scan "$OUT/edge_b.csv" --force 0.2,1.0 --edge-x-m -0.0125 \
  --beta 1e-4 --resolution-m 0 --low-cut-m 0 --regularization tikhonov -o "$OUT/filter_paper.json" --plot-dir "$OUT/plots_paper"

echo "== 3. The same with the default (recommended) settings: beta, target resolution and low cut chosen from the data"
"$PVDFKIT" restore identify --scan "$OUT/edge_a.csv" --force 0.6,0.9 --edge-x-m -0.0125 \
  --scan "$OUT/edge_b.csv" --force 0.2,1.0 --edge-x-m -0.0125 \
  -o "$OUT/filter.json" --plot-dir "$OUT/plots"

echo "== 4. Scan a new surface: edges at -30 mm (mu 0.375) and -15 mm (mu 0.786), texture 0-30 mm"
"$PVDFKIT" restore simulate "$HERE/scanner.json" -o "$OUT/surface.csv" --plot "$OUT/surface_signals.png"

echo "== 5. Restore it offline with both filters, and block by block as a real-time loop would"
"$PVDFKIT" restore apply "$OUT/filter_paper.json" "$OUT/surface.csv" -o "$OUT/forces_paper.csv" --plot "$OUT/fig14_paper.png"
"$PVDFKIT" restore apply "$OUT/filter.json" "$OUT/surface.csv" -o "$OUT/forces.csv" --plot "$OUT/fig14.png"
"$PVDFKIT" restore apply "$OUT/filter.json" "$OUT/surface.csv" -o "$OUT/forces_streamed.csv" --block 1000

echo "== 6. Forgetting where the identification edges were is refused (the cause of a shifted Fig. 14)"
if "$PVDFKIT" restore identify --scan "$OUT/edge_a.csv" --force 0.6,0.9 --scan "$OUT/edge_b.csv" --force 0.2,1.0 \
     -o "$OUT/filter_wrong.json" 2>"$OUT/refused.txt"; then
  echo "expected a refusal"; exit 1
fi
cat "$OUT/refused.txt"
echo "done: results in $OUT"
