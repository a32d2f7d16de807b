#!/usr/bin/env python3
"""Audit charge maps between their nodes: off-node presses against direct probe solves.

    PYTHONPATH=build/python bench/mapping/audit_off_node.py SCENE MAP1.h5 [MAP2.h5 ...]
        [--center=X,Y] [--radius R] [--box=XMIN,XMAX,YMIN,YMAX] [--n N] [--force F]
        [--tolerance T] [--seed S] [--json OUT]

Draws N presses (default 24) uniformly in the disc of radius R (m, default 0.006) around
--center (m, default electrode B of seed 001), kept inside --box (m; default the disc's square),
at force F (N, default 1, the maps' first level). The references are ProbeSweep solves at
tolerance T (default 0.002) with two setup checks: their own mesh, independent of the maps and
their interpolant. For each map: the lookup's charges (Locator.predict, the map's bicubic
interpolant), the true error max_k |Q_map,k − Q_ref,k| / max_k |Q_ref,k|, and the stated error:
the map's stored per-node errors (/estimated_charge_error_C, totals for an adaptive map) bilinear
in the press's cell, over max_k |Q_ref,k|. For a uniform map that is the node estimate only —
the lookup adds its own interpolation estimate on top (docs/lookup.md §1.10), which this script
does not reproduce. Prints per map: median and largest true error, the count above 1 %, the
median stated error and the effectivity (stated / true where true > 1e-3): median, share in
[0.5, 3], share below 0.5 and the smallest. docs/map-generation.md §10.3 (seed 001, the region
around electrode B, maps made with `pvdfkit map --placement adaptive ...`, the commands there):

    PYTHONPATH=build/python bench/mapping/audit_off_node.py examples/scenes/seed001.json adaptive.h5 uniform2.h5 \\
        --box=-0.015,-0.001,-0.011,0.003

Reads the stored errors with h5dump (hdf5-tools).
"""
import argparse
import json

import numpy as np

import h5text  # beside this script
import pvdfkit


def h5dump(path, dataset, attribute=False):
    return np.array(h5text.h5dump(path, dataset, attribute))


def numbers(text, n):
    v = [float(s) for s in text.split(",")]
    if len(v) != n:
        raise SystemExit(f"expected {n} comma-separated numbers, got '{text}'")
    return v


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("maps", nargs="+")
    ap.add_argument("--center", default="-0.00866025403784439,-0.005")
    ap.add_argument("--radius", type=float, default=0.006)
    ap.add_argument("--box", default="")
    ap.add_argument("--n", type=int, default=24)
    ap.add_argument("--force", type=float, default=1.0)
    ap.add_argument("--tolerance", type=float, default=0.002)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default="")
    a = ap.parse_args()
    cx, cy = numbers(a.center, 2)
    box = numbers(a.box, 4) if a.box else [cx - a.radius, cx + a.radius, cy - a.radius, cy + a.radius]
    rng = np.random.default_rng(a.seed)
    presses = []
    while len(presses) < a.n:
        r, t = a.radius * np.sqrt(rng.random()), 2 * np.pi * rng.random()
        x, y = cx + r * np.cos(t), cy + r * np.sin(t)
        if box[0] < x < box[1] and box[2] < y < box[3]:
            presses.append((x, y, r))
    presses = np.array(presses)
    sweep = pvdfkit.ProbeSweep(a.scene, tolerance=a.tolerance, n_setup_checks=2, forces_N=[a.force])
    ref = np.array(sweep.solve(presses[:, 0], presses[:, 1], a.force).charge_C)
    rows = []
    for path in a.maps:
        m = pvdfkit.read_map(path)
        if abs(m.forces_N[0] - a.force) > 1e-12 * a.force:
            raise SystemExit(f"{path}: first force level {m.forces_N[0]} N, not --force {a.force} N")
        q = np.array(m.charge_C)
        err = h5dump(path, "/estimated_charge_error_C").reshape(q.shape)
        x, y = np.array(m.x_m), np.array(m.y_m)
        predicted = np.array(pvdfkit.Locator(m).predict(presses[:, 0], presses[:, 1], a.force))
        for n, (px, py, r) in enumerate(presses):
            i = min(int(np.searchsorted(x, px)) - 1, len(x) - 2)
            j = min(int(np.searchsorted(y, py)) - 1, len(y) - 2)
            u, v = (px - x[i]) / (x[1] - x[0]), (py - y[j]) / (y[1] - y[0])
            stated = ((1 - u) * (1 - v) * err[0, j, i] + u * (1 - v) * err[0, j, i + 1] + (1 - u) * v * err[0, j + 1, i] +
                      u * v * err[0, j + 1, i + 1])
            largest = np.abs(ref[n]).max()
            rows.append(dict(map=path, x_m=px, y_m=py, distance_m=r, true=float(np.abs(predicted[n] - ref[n]).max() / largest),
                             stated=float(stated.max() / largest)))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    for path in a.maps:
        t = np.array([r["true"] for r in rows if r["map"] == path])
        s = np.array([r["stated"] for r in rows if r["map"] == path])
        big = t > 1e-3
        eff = s[big] / t[big]
        line = (f"{path}: {len(t)} presses, true median {100 * np.median(t):.2f} %, max {100 * t.max():.2f} %, "
                f"above 1 %: {(t > 0.01).sum()}; stated median {100 * np.median(s):.2f} %")
        if big.any():
            line += (f"; effectivity (true > 1e-3: {big.sum()}) median {np.median(eff):.2f}, in [0.5, 3] "
                     f"{100 * np.mean((eff >= 0.5) & (eff <= 3)):.0f} %, below 0.5 {100 * np.mean(eff < 0.5):.0f} %, "
                     f"smallest {eff.min():.2f}")
        print(line)


if __name__ == "__main__":
    main()
