#!/usr/bin/env bash
# bench_clamp_layer: `pvdfkit solve` of seed 001 with a 1 N press near the clamp, default (the
# clamp's bending layer as a boundary condition, docs/fem.md §3.4) against the reference path (rim
# graded to the layer, PVDF_CLAMP_LAYER=rim-graded) and the condition without its in-plane shift
# (PVDF_CLAMP_LAYER=no-shift), one binary, one session; CPU = user + sys and peak RSS from
# /usr/bin/time; charge error = max over electrodes |Q − Q_ref| / max |Q_ref| against the stored
# rim-graded reference tests/fem/data/auto_rim_reference.json (made by bench_rim_model, another mesh
# construction). Table in docs/fem.md §3.4 and docs/bench-fem.md.
# Usage: bench/fem/bench_clamp_layer.sh [PVDFKIT (default build/app/pvdfkit)] [MODES (default "default rim-graded")]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
pvdfkit=${1:-$root/build/app/pvdfkit}
modes=${2:-default rim-graded}
scene=$root/examples/scenes/seed001.json
reference=$root/tests/fem/data/auto_rim_reference.json
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-14s %-11s %8s %8s %8s %8s %9s %9s %9s  %s\n' press mode dofs wall_s cpu_s rss_MB error estimate clamp_est treatment
for load in 0,-0.040,1 0.028,0.028,1; do
  for mode in $modes; do
    if [[ $mode == default ]]; then env_args=(env -u PVDF_CLAMP_LAYER); else env_args=(env PVDF_CLAMP_LAYER=$mode); fi
    if ! "${env_args[@]}" /usr/bin/time -f '%e %U %S %M' "$pvdfkit" solve "$scene" --load "$load" --json > "$tmp/solve.json" 2> "$tmp/time.txt"; then
      printf '%-14s %-11s failed: %s\n' "$load" "$mode" "$(grep -v '^[0-9. ]*$' "$tmp/time.txt" | head -1)"
      continue
    fi
    read -r wall user sys rss_kb < <(tail -1 "$tmp/time.txt")
    python3 - "$tmp/solve.json" "$reference" "$load" "$mode" "$wall" "$user" "$sys" "$rss_kb" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); ref = json.load(open(sys.argv[2]))
x, y, f = (float(v) for v in sys.argv[3].split(","))
probe = next(p for p in ref["probes"] if abs(p["x_m"] - x) < 1e-9 and abs(p["y_m"] - y) < 1e-9)
q = [e["charge_C"] for e in d["electrodes"]]; r = probe["charge_C"]
err = max(abs(a - b) for a, b in zip(q, r)) / max(abs(b) for b in r)
c = d.get("clamp_layer", {})
print("%-14s %-11s %8d %8.1f %8.1f %8d %9.2e %9.2e %9.2e  %s" % (sys.argv[3], sys.argv[4], d["n_dofs"], float(sys.argv[5]),
      float(sys.argv[6]) + float(sys.argv[7]), int(sys.argv[8]) // 1024, err, d["estimated_relative_error"],
      c.get("estimated_error", float("nan")), c.get("treatment", "?")))
PY
  done
done
