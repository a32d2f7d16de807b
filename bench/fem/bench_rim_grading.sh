#!/usr/bin/env bash
# bench_rim_grading: the rim-graded path of `pvdfkit solve` (bending kept, plain clamp) on seed 001
# with the rim graded to the clamp layer's own width along the rim (default since r14) against the
# whole rim graded to the centred press's width (PVDF_RIM_GRADING=uniform, the path before r14), one
# binary, one session. Presses: (−32, 28) mm, where `solve` falls back to the rim-graded path by
# itself (the clamp-layer condition's estimate exceeds its share) and a map's direct solve lands in
# `design`; (0, −40) and (28, 28) mm with the condition switched off (PVDF_CLAMP_LAYER=rim-graded),
# where tests/fem/data/auto_rim_reference.json (another mesh construction) gives the charges.
# CPU = user + sys and peak RSS from /usr/bin/time. Table in docs/fem.md §6.1.
# Usage: bench/fem/bench_rim_grading.sh [PVDFKIT (default build/app/pvdfkit)]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
pvdfkit=${1:-$root/build/app/pvdfkit}
scene=$root/examples/scenes/seed001.json
reference=$root/tests/fem/data/auto_rim_reference.json
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-16s %-8s %8s %8s %8s %8s %10s %10s  %s\n' press grading dofs wall_s cpu_s rss_MB estimate off_ref charges_pC
for case in "-0.032,0.028,1 default" "0,-0.040,1 rim-graded" "0.028,0.028,1 rim-graded"; do
  read -r load clamp <<< "$case"
  for grading in local uniform; do
    env_args=(env PVDF_RIM_GRADING=$grading)
    [[ $clamp == rim-graded ]] && env_args+=(PVDF_CLAMP_LAYER=rim-graded)
    if ! "${env_args[@]}" /usr/bin/time -f '%e %U %S %M' "$pvdfkit" solve "$scene" --load="$load" --json > "$tmp/solve.json" 2> "$tmp/time.txt"; then
      printf '%-16s %-8s failed: %s\n' "$load" "$grading" "$(grep -v '^[0-9. ]*$' "$tmp/time.txt" | head -1)"
      continue
    fi
    read -r wall user sys rss_kb < <(tail -1 "$tmp/time.txt")
    python3 - "$tmp/solve.json" "$reference" "$load" "$grading" "$wall" "$user" "$sys" "$rss_kb" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); ref = json.load(open(sys.argv[2]))
x, y, f = (float(v) for v in sys.argv[3].split(","))
q = [e["charge_C"] for e in d["electrodes"]]
probe = [p for p in ref["probes"] if abs(p["x_m"] - x) < 1e-9 and abs(p["y_m"] - y) < 1e-9]
off = "-"
if probe:
    r = probe[0]["charge_C"]
    off = "%.2e" % (max(abs(a - b) for a, b in zip(q, r)) / max(abs(b) for b in r))
print("%-16s %-8s %8d %8.1f %8.1f %8d %10.2e %10s  %s" % (sys.argv[3], sys.argv[4], d["n_dofs"], float(sys.argv[5]),
      float(sys.argv[6]) + float(sys.argv[7]), int(sys.argv[8]) // 1024, d["estimated_relative_error"], off,
      " ".join("%.3f" % (c * 1e12) for c in q)))
PY
  done
done
