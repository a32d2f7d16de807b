#!/usr/bin/env python3
"""Audit a charge map's values and per-node error estimates against direct FEM solves at its nodes.

    bench/mapping/audit_map.py PVDFKIT SCENE MAP [--interior-stride N] [--band-m B] [--band-nodes K]
                               [--tolerance T] [--model M] [--jobs J] [--refs FILE] [--x-min X]

Nodes: every N-th mapped node (default 6) farther than B (default 5 mm) from the edge of the
served region (the film minus the map's rim margin), plus K nodes (default 20) evenly spread in
angle among the mapped nodes within B of that edge; --x-min keeps only nodes with x >= X (e.g. 0
for a map mirrored about the y axis, whose other half is a copy). At each node, at the map's
first force level, runs `PVDFKIT solve SCENE --load X,Y,F --tolerance T --model M --json` (the
reference: default tolerance 0.001, model large-rotation, which keeps bending) and prints per node:
position, distance to the served edge, the model that solved the node in the map (/model: 0 cheap,
1 rim), the true charge error max_k |Q_map,k - Q_ref,k| / max_k |Q_ref,k|, the map's estimate
max_k /estimated_charge_error_C[k] / max_k |Q_map,k|, their ratio (effectivity), the deflection
error and the reference's own estimate. Then the verdicts: every true error <= the map's
tolerance; effectivity within [0.5, 3] wherever the true error exceeds 1e-3. Exit 0 when both
hold, 1 otherwise. --refs caches the reference solves (JSON; reused when the key matches).
Reads the map with h5py when present, else h5dump (hdf5-tools). docs/map-generation.md §9:

    bench/mapping/audit_map.py build/app/pvdfkit examples/scenes/seed001.json seed001_2mm.h5 --x-min 0
"""
import argparse
import json
import math
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import h5text  # beside this script


h5dump = h5text.h5dump


def read_map(path):
    """Grid, mask, first-level charges, estimates, model codes, deflection, status and attributes."""
    m = {}
    m["x"], m["y"] = h5dump(path, "/grid/x_m"), h5dump(path, "/grid/y_m")
    nx, ny = len(m["x"]), len(m["y"])
    m["force"] = h5dump(path, "/forces_N")[0]
    m["tolerance"] = h5dump(path, "/tolerance", attribute=True)[0]
    m["rim_margin"] = h5dump(path, "/rim_margin_m", attribute=True)[0]
    m["ne"] = ne = len(h5dump(path, "/electrodes/noise_C"))
    n = nx * ny
    m["mask"] = h5dump(path, "/grid/mask")
    m["status"] = h5dump(path, "/status")[:n]
    m["q"] = h5dump(path, "/charge_C")[: n * ne]
    m["w"] = h5dump(path, "/deflection_at_load_m")[:n]
    try:
        m["err"] = h5dump(path, "/estimated_charge_error_C")[: n * ne]
    except subprocess.CalledProcessError:
        m["err"] = None  # format 1: no per-node estimate
    try:
        m["model"] = h5dump(path, "/model")[:n]
    except subprocess.CalledProcessError:
        m["model"] = None
    return m


def served_edge_distance(scene, x, y, margin):
    """Distance from (x, y) to the edge of the served region (film minus the rim margin), circles only."""
    shape = scene["membrane"]
    if shape.get("shape", "circle") != "circle":
        raise SystemExit("error: audit_map.py handles circular films only (membrane.shape = circle)")
    return shape["radius_m"] - margin - math.hypot(x, y)


def choose_nodes(m, scene, a):
    nx, ny = len(m["x"]), len(m["y"])
    interior, band = [], []
    for j in range(ny):
        for i in range(nx):
            p = j * nx + i
            if not m["mask"][p] or m["status"][p] != 0 or m["x"][i] < a.x_min - 1e-12:
                continue
            d = served_edge_distance(scene, m["x"][i], m["y"][j], m["rim_margin"])
            if d <= a.band_m + 1e-12:
                band.append((math.atan2(m["y"][j], m["x"][i]), i, j))
            elif i % a.interior_stride == (nx // 2) % a.interior_stride and j % a.interior_stride == (ny // 2) % a.interior_stride:
                interior.append((i, j))
    band.sort()
    step = max(1, len(band) / max(1, a.band_nodes))
    chosen_band = [band[int(k * step)][1:] for k in range(min(a.band_nodes, len(band)))]
    return interior + chosen_band


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pvdfkit")
    ap.add_argument("scene")
    ap.add_argument("map")
    ap.add_argument("--interior-stride", type=int, default=6)
    ap.add_argument("--band-m", type=float, default=0.005)
    ap.add_argument("--band-nodes", type=int, default=20)
    ap.add_argument("--x-min", type=float, default=-math.inf)
    ap.add_argument("--tolerance", type=float, default=0.001)
    ap.add_argument("--model", default="large-rotation")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--refs", default="")
    a = ap.parse_args()
    with open(a.scene) as f:
        scene = json.load(f)
    m = read_map(a.map)
    nx, ne = len(m["x"]), m["ne"]
    nodes = choose_nodes(m, scene, a)
    refs = {}
    if a.refs and os.path.exists(a.refs):
        with open(a.refs) as f:
            refs = json.load(f)

    def key(i, j):
        return f"{m['x'][i]:.6f},{m['y'][j]:.6f},{m['force']:g},{a.tolerance:g},{a.model}"

    def reference(node):
        i, j = node
        k = key(i, j)
        if k in refs:
            return k, refs[k]
        r = subprocess.run([a.pvdfkit, "solve", a.scene, "--load", f"{m['x'][i]},{m['y'][j]},{m['force']}",
                            "--tolerance", str(a.tolerance), "--model", a.model, "--json"], capture_output=True, text=True)
        try:
            return k, json.loads(r.stdout)
        except ValueError:
            return k, {"status": "failed", "message": r.stderr.strip()[:120]}

    with ThreadPoolExecutor(a.jobs) as pool:
        for k, s in pool.map(reference, nodes):
            refs[k] = s
            if a.refs:
                with open(a.refs + ".tmp", "w") as f:
                    json.dump(refs, f)
                os.replace(a.refs + ".tmp", a.refs)

    rows = []
    for i, j in nodes:
        s = refs[key(i, j)]
        p = j * nx + i
        q = m["q"][p * ne:(p + 1) * ne]
        if "electrodes" not in s:
            rows.append((m["x"][i], m["y"][j], math.nan, -1, math.nan, math.nan, math.nan, s.get("status", "?"), math.nan))
            continue
        ref = [e["charge_C"] for e in s["electrodes"]]
        true = max(abs(u - v) for u, v in zip(q, ref)) / max(abs(v) for v in ref)
        est = math.nan
        if m["err"] is not None:
            est = max(m["err"][p * ne:(p + 1) * ne]) / max(abs(v) for v in q)
        dw = m["w"][p] / s["deflection_at_load_m"] - 1 if s["deflection_at_load_m"] else math.nan
        d = served_edge_distance(scene, m["x"][i], m["y"][j], m["rim_margin"])
        model = int(m["model"][p]) if m["model"] is not None else -1
        rows.append((m["x"][i], m["y"][j], d, model, true, est, dw, s["status"], s.get("estimated_relative_error", math.nan)))
    rows.sort(key=lambda r: (r[2] if r[2] == r[2] else 1e9))
    print(f"{'x_mm':>6} {'y_mm':>6} {'edge_mm':>7} {'model':>5} {'true_err_%':>10} {'est_%':>7} {'est/true':>8} "
          f"{'defl_err_%':>10} {'ref_status':>11} {'ref_est_%':>9}")
    for x, y, d, model, true, est, dw, st, rest in rows:
        eff = est / true if true > 0 else math.nan
        print(f"{x*1e3:6.1f} {y*1e3:6.1f} {d*1e3:7.1f} {model:5d} {true*100:10.3f} {est*100:7.3f} {eff:8.2f} "
              f"{dw*100:10.2f} {st:>11} {rest*100:9.3f}")
    good = [r for r in rows if r[4] == r[4]]
    tol = m["tolerance"]
    n_band = sum(1 for r in good if r[2] <= a.band_m + 1e-12)
    above = [r for r in good if r[4] > tol]
    judged = [r for r in good if r[4] > 1e-3]
    outside = [r for r in judged if not (0.5 <= r[5] / r[4] <= 3)]
    worst = max(good, key=lambda r: r[4]) if good else None
    print(f"\n{len(good)} nodes ({n_band} within {a.band_m*1e3:g} mm of the served edge), {len(rows) - len(good)} failed references")
    if worst:
        print(f"true charge error: worst {worst[4]*100:.3f} % at ({worst[0]*1e3:.0f}, {worst[1]*1e3:.0f}) mm; "
              f"above the map's tolerance {tol*100:.3g} %: {len(above)}")
    effs = sorted(r[5] / r[4] for r in judged)
    if effs:
        print(f"effectivity est/true where true > 0.1 %: {len(judged)} nodes, min {effs[0]:.2f}, max {effs[-1]:.2f}, "
              f"outside [0.5, 3]: {len(outside)}")
    ok = bool(good) and not above and not outside and len(rows) == len(good)
    print("verdict:", "PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
