#!/usr/bin/env python3
"""Does the lookup's sigma mean what it says? Presses drawn between a map's nodes and force levels,
solved directly by the FEM (the truth), noise added, located on the map.

    PYTHONPATH=build/python bench/mapping/sigma_coverage.py SCENE MAP [--presses N] [--seed S]
        [--noise-C SIGMA] [--refs FILE] [--edge-m B]

Presses: (x, y) uniform over the map's usable cells (all four corner nodes mapped and solved),
F log-uniform between the map's smallest and largest force level (its one level when it has one).
Truth: `pvdfkit.solve(scene, loads=[[x, y, F]])` at the scene's tolerance (its own estimated error
is printed; it is an independent solve of that press, not an interpolation of the map's nodes).
Noise: one Gaussian draw per electrode, 1-sigma = --noise-C (default: the map's noise_C).
Located twice, force unknown and force known (the true F), with `pvdfkit.Locator` on the map.

Reported, for each mode:
- unambiguous answers (one solution, p_best >= 0.95, flags without `ambiguous`): the share whose
  x lies within 2 sigma_x of the truth, and y within 2 sigma_y (Gaussian: 95.4 %; the issue's band
  90-98 %), with the binomial 95 % interval;
- the same with sigma halved and doubled (a band that the reported sigma passes and the scaled ones
  fail is a two-sided result);
- ambiguous answers: p_best binned, against the share whose best answer is the true branch
  (within max(3 sigma, 0.3 mm) of the truth).
--refs caches the direct solves (JSON keyed by scene file, press): rerunning costs seconds.
Exit 0 when every unambiguous coverage lies in [0.90, 0.98], 1 otherwise.
"""
import argparse
import json
import math
import os
import sys
import time

import numpy as np

import pvdfkit


def wilson(k, n, z=1.96):
    if n == 0:
        return (float("nan"), float("nan"))
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return (c - h, c + h)


def usable_cells(m):
    nx, ny, nf = m.nx, m.ny, m.nf
    status = np.asarray(m.status).reshape(nf, ny, nx)
    mask = np.asarray(m.mask).reshape(ny, nx)
    ok = (mask == 1) & np.all(status == 0, axis=0)  # PointStatus ok = 0 at every level
    cells = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            if ok[j, i] and ok[j, i + 1] and ok[j + 1, i] and ok[j + 1, i + 1]:
                cells.append((i, j))
    return cells


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("map")
    ap.add_argument("--presses", type=int, default=300)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--noise-C", type=float, default=0.0)
    ap.add_argument("--refs", default="")
    a = ap.parse_args()

    m = pvdfkit.read_map(a.map)
    scene = pvdfkit.load_scene(a.scene)
    x = np.asarray(m.x_m)
    y = np.asarray(m.y_m)
    forces = np.asarray(m.forces_N)
    noise = np.asarray(m.noise_C, dtype=float) if a.noise_C <= 0 else np.full(m.n_electrodes, a.noise_C)
    cells = usable_cells(m)
    if not cells:
        sys.exit(f"error: {a.map}: no cell with four mapped nodes")
    rng = np.random.default_rng(a.seed)
    refs = {}
    if a.refs and os.path.exists(a.refs):
        refs = json.load(open(a.refs))
    presses = []
    for _ in range(a.presses):
        i, j = cells[rng.integers(len(cells))]
        px = x[i] + rng.random() * (x[i + 1] - x[i])
        py = y[j] + rng.random() * (y[j + 1] - y[j])
        F = float(forces[0]) if len(forces) == 1 else float(math.exp(rng.uniform(math.log(forces[0]), math.log(forces[-1]))))
        presses.append((float(px), float(py), F))

    t0 = time.process_time()
    truth = []
    solved = 0
    worst_ref = 0.0
    for k, (px, py, F) in enumerate(presses):
        key = f"{os.path.basename(a.scene)}:{px:.9f},{py:.9f},{F:.9f}"
        if key not in refs:
            r = pvdfkit.solve(scene, loads=[[px, py, F]], check=False)
            refs[key] = {"ok": bool(r.ok), "charge_C": [float(q) for q in r.charge_C] if r.ok else [],
                         "estimated_relative_error": float(r.estimated_relative_error) if r.ok else None,
                         "status": str(r.status)}
            solved += 1
            if a.refs and solved % 10 == 0:
                json.dump(refs, open(a.refs, "w"))
            print(f"  solve {k + 1}/{len(presses)}: ({1e3 * px:.2f}, {1e3 * py:.2f}) mm, {F:.3f} N, "
                  f"status {refs[key]['status']}, est {refs[key]['estimated_relative_error']}", file=sys.stderr)
        truth.append(refs[key])
        if refs[key]["ok"]:
            worst_ref = max(worst_ref, refs[key]["estimated_relative_error"])
    if a.refs:
        json.dump(refs, open(a.refs, "w"))
    solve_cpu = time.process_time() - t0

    good = [k for k in range(len(presses)) if truth[k]["ok"]]
    q_true = np.array([truth[k]["charge_C"] for k in good])
    q_noisy = q_true + rng.normal(size=q_true.shape) * noise
    P = np.array([presses[k] for k in good])
    print(f"{a.map}: {len(presses)} presses, {len(good)} solved directly ({solved} new, {solve_cpu:.0f} CPU-s), "
          f"largest estimated error of the direct solves {100 * worst_ref:.2f} %; noise {1e12 * noise.max():.3g} pC; "
          f"forces {forces.tolist()} N")
    all_in = True
    summary = {}
    for mode in ("force unknown", "force known"):
        loc = pvdfkit.Locator(m, noise_C=noise)
        known = P[:, 2] if mode == "force known" else None
        r = loc.locate(q_noisy, known_force_N=known)
        n_sol = np.asarray(r.n_solutions)
        prob = np.asarray(r.probability)
        has = np.asarray(r.has_position, dtype=bool)
        flags_text = list(r.flags_text)
        sx, sy = np.asarray(r.sigma_x_m), np.asarray(r.sigma_y_m)
        ex, ey = np.abs(np.asarray(r.x_m) - P[:, 0]), np.abs(np.asarray(r.y_m) - P[:, 1])
        unamb = has & (n_sol == 1) & (prob >= 0.95) & np.array(["ambiguous" not in f for f in flags_text])
        n = int(unamb.sum())
        print(f"\n{mode}: {len(good)} presses located, {int(has.sum())} with a position, {n} unambiguous")
        print("  sigma x   | x within 2 sigma_x (95 % CI)  | y within 2 sigma_y (95 % CI)")
        row = {}
        for scale in (0.5, 1.0, 2.0):
            kx = int(np.sum(ex[unamb] <= 2 * scale * sx[unamb]))
            ky = int(np.sum(ey[unamb] <= 2 * scale * sy[unamb]))
            lx, hx = wilson(kx, n)
            ly, hy = wilson(ky, n)
            print(f"  {scale:<9} | {kx / max(n, 1):.3f} ({lx:.3f}-{hx:.3f})          | {ky / max(n, 1):.3f} ({ly:.3f}-{hy:.3f})")
            row[str(scale)] = [kx / max(n, 1), ky / max(n, 1)]
            if scale == 1.0:
                all_in &= n > 0 and 0.90 <= kx / n <= 0.98 and 0.90 <= ky / n <= 0.98
        amb = has & ~unamb
        if amb.any():
            right = np.hypot(ex, ey) <= np.maximum(3 * np.hypot(sx, sy), 0.3e-3)
            print("  ambiguous: p_best bin | presses | mean p | best answer is the truth")
            for lo, hi in ((0.0, 0.5), (0.5, 0.7), (0.7, 0.9), (0.9, 1.01)):
                b = amb & (prob >= lo) & (prob < hi)
                if b.any():
                    print(f"    [{lo:.1f}, {min(hi, 1.0):.1f}) | {int(b.sum()):7d} | {prob[b].mean():.3f}  | {right[b].mean():.3f}")
        summary[mode] = {"unambiguous": n, "coverage_2sigma": row}
    print(json.dumps(summary))
    return 0 if all_in else 1


if __name__ == "__main__":
    sys.exit(main())
