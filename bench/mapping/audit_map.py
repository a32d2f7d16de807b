#!/usr/bin/env python3
"""Audit a charge map against direct adaptive FEM solves at its own nodes.

    bench/mapping/audit_map.py PVDFKIT SCENE MAP [--stride N] [--tolerance T] [--model M] [--jobs J]

For every mapped node on a lattice of every N-th node (default 2), at the map's first force level,
runs `PVDFKIT solve SCENE --load X,Y,F --tolerance T --model M --json` and prints the node, the
charge error max_k |dQ_k| / max_k |Q_k| of the map against that solve, the deflection error and the
solve's own error estimate, worst first; then the median and worst charge error and how many nodes
exceed the map's tolerance. Reads the map with h5dump (hdf5-tools). Used for docs/map-generation.md
section 9: `bench/mapping/audit_map.py build/app/pvdfkit examples/scenes/seed001.json
seed001_4mm.h5 --stride 2 --tolerance 0.002 --model large-rotation`.
"""
import argparse
import json
import math
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor


def h5(path, dataset, start=None, count=None, attribute=False):
    cmd = ["h5dump", "-a" if attribute else "-d", dataset]
    if start is not None:
        cmd += ["-s", start, "-c", count]
    out = subprocess.run(cmd + [path], capture_output=True, text=True, check=True).stdout
    values = []
    for line in out.splitlines():
        m = re.match(r"\s*\(([\d,]+)\):\s*(.*)", line)
        if m and '"' not in m.group(2):
            values += [float(v) for v in m.group(2).rstrip(",").split(",") if v.strip()]
    return values


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pvdfkit")
    ap.add_argument("scene")
    ap.add_argument("map")
    ap.add_argument("--stride", type=int, default=2)
    ap.add_argument("--tolerance", type=float, default=0.002)
    ap.add_argument("--model", default="large-rotation")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    xs, ys = h5(a.map, "/grid/x_m"), h5(a.map, "/grid/y_m")
    force = h5(a.map, "/forces_N")[0]
    map_tol = h5(a.map, "/tolerance", attribute=True)
    ne = len(h5(a.map, "/electrodes/noise_C"))
    nodes = [(i, j) for j in range(0, len(ys), a.stride) for i in range(0, len(xs), a.stride)]

    def audit(node):
        i, j = node
        if h5(a.map, "/status", f"0,{j},{i}", "1,1,1")[0] != 0:
            return None  # masked or not ok
        q = h5(a.map, "/charge_C", f"0,{j},{i},0", f"1,1,1,{ne}")
        w = h5(a.map, "/deflection_at_load_m", f"0,{j},{i}", "1,1,1")[0]
        r = subprocess.run([a.pvdfkit, "solve", a.scene, "--load", f"{xs[i]},{ys[j]},{force}", "--tolerance",
                            str(a.tolerance), "--model", a.model, "--json"], capture_output=True, text=True)
        try:
            s = json.loads(r.stdout)
        except ValueError:
            return (xs[i], ys[j], float("nan"), float("nan"), "solve failed: " + r.stderr.strip()[:80], float("nan"))
        ref = [e["charge_C"] for e in s["electrodes"]]
        dq = max(abs(u - v) for u, v in zip(q, ref)) / max(abs(v) for v in ref)
        dw = w / s["deflection_at_load_m"] - 1 if s["deflection_at_load_m"] else float("nan")
        return (xs[i], ys[j], dq, dw, s["status"], s.get("estimated_relative_error", float("nan")))

    with ThreadPoolExecutor(a.jobs) as pool:
        rows = [r for r in pool.map(audit, nodes) if r]
    rows.sort(key=lambda r: -r[2] if r[2] == r[2] else 0)
    print(f"{'x_mm':>8} {'y_mm':>8} {'charge_err_%':>13} {'deflection_err_%':>17} {'solve_status':>14} {'solve_est_%':>12}")
    for x, y, dq, dw, st, est in rows:
        print(f"{x*1e3:8.1f} {y*1e3:8.1f} {dq*100:13.3f} {dw*100:17.2f} {st:>14} {est*100:12.3f}")
    good = sorted(r[2] for r in rows if r[2] == r[2])
    if good:
        tol = map_tol[0] if map_tol else float("nan")
        print(f"\n{len(good)} nodes: charge error median {good[len(good)//2]*100:.2f} %, worst {good[-1]*100:.2f} %; "
              f"above the map's tolerance {tol*100:.2g} %: {sum(v > tol for v in good)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
