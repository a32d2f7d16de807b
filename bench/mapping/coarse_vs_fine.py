#!/usr/bin/env python3
"""A coarse map's stated lookup error against its true error, measured on a finer map's solved nodes.

The truth at each point is a finer FEM map's charge at one of its *solved* nodes (status ok,
/provenance without the `interpolated` bit: a direct FEM result, not an interpolant), inside the
coarse map's usable cells, at a force level both maps hold. For each coarse map given, at those
points:

- true error = max_k |Q_coarse,k − Q_fine,k| / max_k |Q_fine,k| (the coarse map's interpolant via
  pvdfkit.Locator.predict, exactly what the lookup reads);
- stated error = max_k e_k / max_k |Q_fine,k|, e = Locator.charge_error (what the lookup carries:
  the node estimates and its error between nodes and levels, or an adaptive map's stored totals);
- effectivity stated / true where the true error exceeds 1e-3: median, share in [0.5, 3], below
  0.5 (under-stated), above 3.

The fine map's own error (its node estimates, ≤ the tolerance) is part of the "truth": a true error
near the fine map's tolerance says little.

Usage: coarse_vs_fine.py FINE.h5 COARSE.h5 [COARSE.h5 ...] [--json FILE]
Exit 2 on an unreadable map or maps without a common force level.
"""
import argparse
import json
import sys

import numpy as np

import h5text  # beside this script
import pvdfkit

INTERPOLATED = 8  # /provenance bit of a node filled from a coarser level (docs/mapping.md)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("fine")
    ap.add_argument("coarse", nargs="+")
    ap.add_argument("--json", default="")
    a = ap.parse_args()
    try:
        fine = pvdfkit.read_map(a.fine)
        coarse = [(path, pvdfkit.read_map(path)) for path in a.coarse]
        shape = (len(fine.forces_N), len(fine.y_m), len(fine.x_m))
        try:
            provenance = np.array(h5text.h5dump(a.fine, "/provenance")).astype(np.int64).reshape(shape)
        except Exception:
            provenance = np.zeros(shape, dtype=np.int64)  # a uniform map: every node solved
    except (pvdfkit.InputError, OSError) as e:
        print(f"coarse_vs_fine.py: {e}", file=sys.stderr)
        return 2
    status = np.array(fine.status)
    charge = np.array(fine.charge_C)
    xx, yy = np.meshgrid(fine.x_m, fine.y_m)
    rows = []
    for path, m in coarse:
        locator = pvdfkit.Locator(m)
        for force in m.forces_N:
            f = int(np.argmin(np.abs(np.array(fine.forces_N) - force)))
            if abs(fine.forces_N[f] - force) > 1e-9 * force:
                continue
            solved = (status[f] == 0) & ((provenance[f] & INTERPOLATED) == 0)
            x, y, truth = xx[solved], yy[solved], charge[f][solved]
            q = locator.predict(x, y, force)
            e = locator.charge_error(x, y, force)
            inside = np.all(np.isfinite(q), axis=1)
            scale = np.abs(truth[inside]).max(axis=1)
            true = np.abs(q[inside] - truth[inside]).max(axis=1) / scale
            stated = np.abs(e[inside]).max(axis=1) / scale
            big = true > 1e-3
            eff = stated[big] / true[big]
            row = dict(map=path, force_N=float(force), points=int(inside.sum()),
                       true_median=float(np.median(true)), true_p90=float(np.percentile(true, 90)), true_max=float(true.max()),
                       stated_median=float(np.median(stated)), stated_p90=float(np.percentile(stated, 90)),
                       stated_max=float(stated.max()), effectivity_median=float(np.median(eff)) if big.any() else None,
                       in_band=float(np.mean((eff >= 0.5) & (eff <= 3))) if big.any() else None,
                       below_half=float(np.mean(eff < 0.5)) if big.any() else None,
                       above_3=float(np.mean(eff > 3)) if big.any() else None)
            rows.append(row)
            print(f"{path} at {force:g} N, {row['points']} solved nodes of {a.fine}:")
            print(f"  true   median {100 * row['true_median']:.2f} %, p90 {100 * row['true_p90']:.2f} %, max {100 * row['true_max']:.2f} %")
            print(f"  stated median {100 * row['stated_median']:.2f} %, p90 {100 * row['stated_p90']:.2f} %, max {100 * row['stated_max']:.2f} %")
            if big.any():
                print(f"  stated/true where true > 1e-3 ({big.sum()} points): median {row['effectivity_median']:.2f}, "
                      f"in [0.5, 3] {100 * row['in_band']:.0f} %, below 0.5 {100 * row['below_half']:.1f} %, "
                      f"above 3 {100 * row['above_3']:.0f} %")
    if not rows:
        print("coarse_vs_fine.py: no force level in common", file=sys.stderr)
        return 2
    if a.json:
        with open(a.json, "w") as out:
            json.dump(dict(fine=a.fine, rows=rows), out, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
