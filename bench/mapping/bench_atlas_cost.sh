#!/usr/bin/env bash
# bench_atlas_cost: the Must-show "Cost" of issue 32 — a film's charge-density atlas against an
# ordinary map of that film at the same probe spacing, same binary, one thread each, one after the
# other (docs/atlas.md §6), then one layout's map read from the atlas (`map --atlas`).
#   - user + sys CPU, wall and peak RSS of each whole run (/usr/bin/time), and the load (uptime)
#     before each: on a shared machine CPU is the comparable figure, wall is not;
#   - the ratio atlas CPU / map CPU (the issue asks <= 1.5) and the `map --atlas` wall (<= 5 s).
# Usage: bench/mapping/bench_atlas_cost.sh [PVDFKIT (default build/app/pvdfkit)] [SCENE (default
#        examples/scenes/seed001.json)] [SPACING_M (default 0.004)] [extra `atlas` flags...]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
pvdfkit=${1:-$root/build/app/pvdfkit}
scene=${2:-$root/examples/scenes/seed001.json}
spacing=${3:-0.004}
shift $(( $# < 3 ? $# : 3 ))
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

uptime
/usr/bin/time -f '%e %U %S %M' "$pvdfkit" map "$scene" -o "$tmp/map.h5" --spacing-m "$spacing" --threads 1 --json \
  --no-checkpoint --quiet > "$tmp/map.json" 2> "$tmp/map.time"
uptime
/usr/bin/time -f '%e %U %S %M' "$pvdfkit" atlas "$scene" -o "$tmp/film.atlas.h5" --spacing-m "$spacing" --threads 1 \
  --json --quiet "$@" > "$tmp/atlas.json" 2> "$tmp/atlas.time"
uptime
/usr/bin/time -f '%e %U %S %M' "$pvdfkit" map "$scene" --atlas "$tmp/film.atlas.h5" -o "$tmp/from-atlas.h5" \
  > /dev/null 2> "$tmp/read.time"
python3 - "$tmp" <<'PY'
import json, sys
t = sys.argv[1]
def cost(name):
    wall, user, sys_, rss = open(f"{t}/{name}.time").read().split()[-4:]
    return float(wall), float(user) + float(sys_), float(rss) / 1e6
mw, mc, mr = cost("map"); aw, ac, ar = cost("atlas"); rw, rc, rr = cost("read")
a = json.load(open(f"{t}/atlas.json")); m = json.load(open(f"{t}/map.json"))
print(f"map:   {mc:8.1f} CPU s, {mw:8.1f} s wall, {mr:5.2f} GB peak; {m['n_solved']} solved, {m['n_dofs']} DOFs")
print(f"atlas: {ac:8.1f} CPU s, {aw:8.1f} s wall, {ar:5.2f} GB peak; {a['n_solved_positions']} solved, {a['n_dofs']} DOFs, "
      f"FE {a['fe_size_m']*1e3:g} mm, {a['n_rim_solves']} rim-model presses, largest estimate {a['estimated_relative_error']:.3g}")
print(f"atlas / map CPU = {ac / mc:.2f} (issue: <= 1.5)")
print(f"map --atlas: {rw:.2f} s wall, {rc:.2f} CPU s (issue: <= 5 s)")
PY
