#!/bin/sh
# Cold single solves, two pvdfkit binaries interleaved (issue 34): CPU seconds (user + sys, from
# /usr/bin/time) of the whole `solve --json` command, DOFs, Newton iterations, load steps, and for
# the isotropic centre case the error against the axisymmetric Green-Lagrange oracle
# (w0 = 3.258430 mm, electrode A mean [N11, N22] = [64.022, 191.234] N/m: docs/bench-fem.md,
# computed by bench_fem from tests/fem/oracles/axisymmetric_plate.hpp).
#
#   bench/fem/bench_cold_solve.sh BEFORE_EXE AFTER_EXE [REPEATS]      (run from the repository root)
#
# The machine is shared: CPU time, not wall; both binaries run alternately in the same loop.
# The fixed cost of the command (dynamic loader, scene) is `pvdfkit --version`, also interleaved.
set -eu
before=$1 after=$2 n=${3:-3}
out=$(mktemp -d)
cases="seed001-centre|examples/scenes/seed001.json|
iso-centre|bench/fem/seed001_isotropic.json|
seed001-offcentre|examples/scenes/seed001.json|--load 0.00466,-0.005,1"
printf '| case | binary | DOFs | Newton it. | load steps | CPU s (median of %s) | w0 (mm) | err w0 | err A (N11,N22) |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n' "$n"
for tag in before after; do eval "exe=\$$tag"; for i in $(seq "$n"); do
  /usr/bin/time -f "%U %S" -o "$out/$tag.version.$i" "$exe" --version > /dev/null; done; done
echo "$cases" | while IFS='|' read -r name scene extra; do
  for i in $(seq "$n"); do for tag in before after; do
    eval "exe=\$$tag"
    # shellcheck disable=SC2086
    /usr/bin/time -f "%U %S" -o "$out/$name.$tag.$i.time" "$exe" solve "$scene" $extra --json > "$out/$name.$tag.$i.json" || true
  done; done
  for tag in before after; do
    python3 - "$out" "$name" "$tag" "$n" <<'PY'
import json, statistics, sys
out, name, tag, n = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
cpu = []
for i in range(1, n + 1):
    u, s = open(f"{out}/{name}.{tag}.{i}.time").read().split()[-2:]
    cpu.append(float(u) + float(s))
d = json.load(open(f"{out}/{name}.{tag}.1.json"))
w0 = d["loads"][0]["deflection_m"] * 1e3
A = d["electrodes"][0]["mean_membrane_force_material_N_per_m"]
err_w = err_a = "—"
if name.startswith("iso"):
    err_w = "%.2e" % abs(w0 / 3.258430 - 1)
    err_a = "%.2e" % (((A[0] - 64.022) ** 2 + (A[1] - 191.234) ** 2) ** 0.5 / (64.022 ** 2 + 191.234 ** 2) ** 0.5)
print(f"| {name} | {tag} | {d['n_dofs']} | {d['newton_iterations']} | {d['load_steps']} | {statistics.median(cpu):.2f} | {w0:.6f} | {err_w} | {err_a} |")
PY
  done
done
for tag in before after; do python3 -c "
import statistics,sys
v=[sum(map(float,open(f).read().split()[-2:])) for f in sys.argv[2:]]
print('| pvdfkit --version (fixed cost) | %s | | | | %.2f | | | |' % (sys.argv[1], statistics.median(v)))" "$tag" "$out"/$tag.version.*; done
echo "raw files: $out"
