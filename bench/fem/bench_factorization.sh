#!/usr/bin/env bash
# bench_factorization: the seed-001 centre solve with CHOLMOD's supernodal Cholesky (the default)
# against Eigen's simplicial LDLT (PVDF_FACTORIZATION=simplicial-ldlt), one binary, one session,
# interleaved RUNS times; CPU = user + sys of /usr/bin/time. Table in docs/bench-fem.md.
# Usage: bench/fem/bench_factorization.sh [PVDFKIT (default build/app/pvdfkit)] [RUNS (default 3)]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
pvdfkit=${1:-$root/build/app/pvdfkit}
runs=${2:-3}
scene=$root/examples/scenes/seed001.json
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-16s %8s %8s %8s %8s %7s  %s\n' method cpu_s lin_s asm_s rss_MB newton "w0_m charges_C"
for _ in $(seq "$runs"); do
  for method in simplicial-ldlt cholmod; do
    if [[ $method == cholmod ]]; then env_args=(env -u PVDF_FACTORIZATION); else env_args=(env PVDF_FACTORIZATION=$method); fi
    "${env_args[@]}" /usr/bin/time -f '%U %S %M' "$pvdfkit" solve "$scene" --json > "$tmp/solve.json" 2> "$tmp/time.txt"
    read -r user sys rss_kb < <(tail -1 "$tmp/time.txt")
    python3 - "$tmp/solve.json" "$method" "$user" "$sys" "$rss_kb" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); t = d["time_breakdown_s"]
cpu = float(sys.argv[3]) + float(sys.argv[4])
q = " ".join("%.9e" % e["charge_C"] for e in d["electrodes"])
print("%-16s %8.2f %8.2f %8.2f %8d %7d  %.9e %s" % (sys.argv[2], cpu, t["linear_solve"], t["assembly"],
      int(sys.argv[5]) // 1024, d["newton_iterations"], d["deflection_at_load_m"], q))
PY
  done
done
