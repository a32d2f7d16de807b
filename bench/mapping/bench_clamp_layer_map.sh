#!/usr/bin/env bash
# bench_clamp_layer_map: a seed-001 map over a patch at the clamp, its near-clamp nodes solved with
# the clamp's bending layer as a boundary condition (the default, docs/fem.md §3.4) against the
# rim-graded reference path (PVDF_CLAMP_LAYER=rim-graded: the rim model, bending on a mesh graded
# toward the clamp), same binary, same session, one thread each, one after the other.
#   - CPU = user + sys and peak RSS of the whole `pvdfkit map` run (/usr/bin/time), and the
#     solves' CPU per solved position from `map --json` (cpu_s_per_solve);
#   - per node: which model solved it (/model: 0 cheap, 1 rim-graded, 3 clamp-layer condition), the
#     charge difference between the two maps, max_k |Q_k − Q_rim,k| / max_k |Q_rim,k|, and each map's
#     stated error max_k err_k / max_k |Q_k| (/estimated_charge_error_C);
#   - at (0, −40) mm, the true error of both against the stored rim-graded reference
#     tests/fem/data/auto_rim_reference.json (122 199 DOFs, its own estimate 0.07 %).
# Table in docs/map-generation.md §6.2.
# Usage: bench/mapping/bench_clamp_layer_map.sh [PVDFKIT (default build/app/pvdfkit)] [REGION (default
#        -0.004,0.004,-0.044,-0.036)] [SPACING_M (default 0.002)]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
pvdfkit=${1:-$root/build/app/pvdfkit}
region=${2:--0.004,0.004,-0.044,-0.036}
spacing=${3:-0.002}
scene=$root/examples/scenes/seed001.json
reference=$root/tests/fem/data/auto_rim_reference.json
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

for mode in default rim-graded; do
  if [[ $mode == default ]]; then env_args=(env -u PVDF_CLAMP_LAYER); else env_args=(env PVDF_CLAMP_LAYER=$mode); fi
  "${env_args[@]}" /usr/bin/time -f '%e %U %S %M' "$pvdfkit" map "$scene" -o "$tmp/$mode.h5" --region "$region" \
    --spacing-m "$spacing" --threads 1 --json --no-checkpoint --quiet > "$tmp/$mode.json" 2> "$tmp/$mode.time"
  for d in charge_C estimated_charge_error_C model status grid/x_m grid/y_m; do
    h5dump -A 0 -d "/$d" -y -w 0 -m %.17g "$tmp/$mode.h5" | sed -n '/DATA {/,/}/p' | sed '1d;$d' | tr -d ' \n' | tr ',' '\n' \
      > "$tmp/$mode.${d//\//_}.txt"
  done
done

python3 - "$tmp" "$reference" <<'PY'
import json, sys
tmp, reference = sys.argv[1], sys.argv[2]
def load(mode):
    r = lambda d, f=float: [f(v) for v in open(f"{tmp}/{mode}.{d}.txt").read().split()]
    t = open(f"{tmp}/{mode}.time").read().split("\n")
    wall, user, sys_, rss = (float(v) for v in [l for l in t if l.strip()][-1].split())
    return dict(q=r("charge_C"), e=r("estimated_charge_error_C"), model=r("model", int), status=r("status", int),
                x=r("grid_x_m"), y=r("grid_y_m"), json=json.load(open(f"{tmp}/{mode}.json")),
                wall=wall, cpu=user + sys_, rss_MB=rss / 1024)
c, g = load("default"), load("rim-graded")
nx, ny = len(c["x"]), len(c["y"])
ref = next(p for p in json.load(open(reference))["probes"] if p["x_m"] == 0.0 and p["y_m"] == -0.04)["charge_C"]
print("run          wall_s  cpu_s  rss_MB  solves  cpu_s/solve  n_clamp_layer  n_rim_model  rim_solves  "
      "clamp_layer_solves  n_tolerance_not_met  n_direct  sweep_dofs  probe_mesh_dofs  rim_dofs")
for name, m in (("clamp-layer", c), ("rim-graded", g)):
    j = m["json"]
    print("%-11s %7.1f %6.1f %7.0f %7d %12.2f %14d %12d %11d %19d %20d %9d %11d %16.0f %9d" % (
        name, m["wall"], m["cpu"], m["rss_MB"], j["n_solved"], j["cpu_s_per_solve"], j.get("n_clamp_layer", 0),
        j["n_rim_model"], j["rim_solves"], j.get("clamp_layer_solves", 0), j["n_tolerance_not_met"], j["n_direct"],
        j["n_dofs"], j["probe_mesh_dofs"], j["rim_n_dofs"]))
print()
print("  x_mm   y_mm  model(def/rim)  diff_vs_rim_%  stated_def_%  stated_rim_%  stated_def/diff  "
      "true_def_%  true_rim_% (vs stored reference)")
diffs = []
for jy in range(ny):
    for ix in range(nx):
        p = jy * nx + ix
        if c["status"][p] != 0 or g["status"][p] != 0:  # ok only (0)
            continue
        qc, qg = c["q"][3 * p:3 * p + 3], g["q"][3 * p:3 * p + 3]
        scale_c, scale_g = max(abs(v) for v in qc), max(abs(v) for v in qg)
        diff = max(abs(a - b) for a, b in zip(qc, qg)) / scale_g
        sc = max(c["e"][3 * p:3 * p + 3]) / scale_c
        sg = max(g["e"][3 * p:3 * p + 3]) / scale_g
        x, y = c["x"][ix], c["y"][jy]
        true = ""
        if abs(x) < 1e-9 and abs(y + 0.04) < 1e-9:
            tc = max(abs(a - b) for a, b in zip(qc, ref)) / max(abs(b) for b in ref)
            tg = max(abs(a - b) for a, b in zip(qg, ref)) / max(abs(b) for b in ref)
            true = "%10.3f  %10.3f" % (100 * tc, 100 * tg)
        diffs.append((c["model"][p], diff, sc))
        print("%6.1f %6.1f  %6d/%-6d  %12.3f  %12.3f  %12.3f  %15.2f  %s" % (
            1e3 * x, 1e3 * y, c["model"][p], g["model"][p], 100 * diff, 100 * sc, 100 * sg, sc / diff if diff > 0 else float("inf"), true))
cl = [d for d in diffs if d[0] == 3]
if cl:
    print("\nclamp-layer nodes: %d; charge difference vs rim-graded max %.3f %% (median %.3f %%); stated/diff min %.2f max %.2f"
          % (len(cl), 100 * max(d[1] for d in cl), 100 * sorted(d[1] for d in cl)[len(cl) // 2],
             min(d[2] / d[1] for d in cl), max(d[2] / d[1] for d in cl)))
PY
