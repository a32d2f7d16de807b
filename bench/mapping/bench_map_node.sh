#!/bin/sh
# The cost of a map node (issue 34, Must show item 2), two pvdfkit binaries interleaved: the main
# job's map (seed 001, 4 mm over the electrode triangle, 1 N: 169 positions, 91 solved) with
# `--threads 1`, user + sys of the whole command (/usr/bin/time), and from `map --json` the CPU
# seconds per solve, the estimates' share and the probe meshes' time; then how far the two maps'
# charges and stored estimates differ (h5dump at 17 digits).
#
#   bench/mapping/bench_map_node.sh BEFORE_EXE AFTER_EXE [REPEATS]      (run from the repository root)
#
# The machine is shared: CPU time, not wall; both binaries run alternately in the same loop.
set -eu
before=$1 after=$2 n=${3:-2}
out=$(mktemp -d)
for i in $(seq "$n"); do for tag in before after; do
  eval "exe=\$$tag"
  /usr/bin/time -f "%U %S %M" -o "$out/$tag.$i.time" "$exe" map examples/scenes/seed001.json -o "$out/$tag.$i.h5" \
    --spacing-m 0.004 --region=-0.024,0.024,-0.024,0.024 --forces-N 1 --threads 1 --no-checkpoint --quiet --json \
    > "$out/$tag.$i.json"
done; done
printf '| binary | run | command CPU-s | CPU-s per solve | estimates (s) | probe meshes (s) | clamp layer (s) | peak RSS (MB) |\n|---|---:|---:|---:|---:|---:|---:|---:|\n'
for tag in before after; do for i in $(seq "$n"); do
  python3 - "$out" "$tag" "$i" <<'PY'
import json, sys
out, tag, i = sys.argv[1:4]
u, s, m = open(f"{out}/{tag}.{i}.time").read().split()[-3:]
d = json.load(open(f"{out}/{tag}.{i}.json"))
print(f"| {tag} | {i} | {float(u) + float(s):.1f} | {d['cpu_s_per_solve']:.3f} | {d['estimate_s']:.2f} | "
      f"{d['probe_mesh_s']:.2f} | {d['clamp_layer_s']:.2f} | {int(m) / 1024:.0f} |")
PY
done; done
for ds in /charge_C /estimated_charge_error_C; do
  h5dump -m %.17g -d "$ds" "$out/before.1.h5" | grep -o '[-0-9.e]\{8,\}' > "$out/a.txt"
  h5dump -m %.17g -d "$ds" "$out/after.1.h5" | grep -o '[-0-9.e]\{8,\}' > "$out/b.txt"
  python3 - "$out" "$ds" <<'PY'
import sys
out, ds = sys.argv[1:3]
a = [float(x) for x in open(f"{out}/a.txt")]
b = [float(x) for x in open(f"{out}/b.txt")]
largest = max(abs(x) for x in a)
print(f"{ds}: {len(a)} values, largest |after - before| = {max(abs(x - y) for x, y in zip(a, b)) / largest:.2e} of the largest value, "
      f"{sum(x == y for x, y in zip(a, b))} bitwise equal")
PY
done
echo "raw files: $out"
