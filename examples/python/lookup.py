#!/usr/bin/env python3
"""Ship a lookup: from a charge map to press positions and forces, many presses at once.

What it shows
    A charge map (read with --map, or computed here by the FEM on a coarse grid around the
    electrodes) is turned into a Locator; charges of N presses — the map's own prediction at
    random off-grid positions plus the map's 1-sigma channel noise — go in as one (N, 3) numpy
    array, and positions, forces, 1-sigma values and flags come out as arrays. The figure shows
    true against located positions and the position error against the reported 1-sigma.

Run
    PYTHONPATH=build/python /usr/bin/python3 examples/python/lookup.py [--map MAP.h5] [--out DIR] [--small]

Expect
    Position errors of the order of the reported sigma (tens of um at 0.05 pC noise), a few
    presses flagged (ambiguous near the electrodes, outside_map at the map's edge), out/lookup.png,
    out/lookup.csv and the map out/map.h5. With --small the map is 4 mm over +-12 mm (about 20 s).
"""
import argparse
import csv
import os
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pvdfkit  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default=os.path.join(HERE, "..", "scenes", "seed001.json"))
    p.add_argument("--map", help="charge map (HDF5) from `pvdfkit map` or pvdfkit.generate_map")
    p.add_argument("--out", default="lookup-example")
    p.add_argument("--presses", type=int, default=400)
    p.add_argument("--small", action="store_true", help="coarse 4 mm map, fewer presses (CI)")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    scene = pvdfkit.load_scene(a.scene)

    print("== 1. The charge map")
    if a.map:
        cmap = pvdfkit.read_map(a.map)
    else:
        spacing, half = (0.004, 0.012) if a.small else (0.002, 0.016)
        t0 = time.time()
        cmap, report = pvdfkit.generate_map(scene, spacing_m=spacing, forces_N=[0.5, 1.0, 2.0],
                                            region_m=(-half, half, -half, half), tolerance=0.02 if a.small else 0.01,
                                            n_setup_checks=1 if a.small else 3)
        print(f"computed {report['n_positions']} positions x 3 forces in {time.time() - t0:.1f} s "
              f"({report['n_solved']} solved, {report['n_scaled']} scaled, {report['n_mirrored']} mirrored), "
              f"estimated charge error {report['estimated_relative_error']:.2g}")
        pvdfkit.write_map(os.path.join(a.out, "map.h5"), cmap)
    print(cmap)

    print("== 2. The Locator, and N presses as one array of charges")
    locator = pvdfkit.Locator(cmap)
    rng = np.random.default_rng(1)
    n = 100 if a.small else a.presses
    inner = 0.8 * min(abs(cmap.x_m[0]), cmap.x_m[-1], abs(cmap.y_m[0]), cmap.y_m[-1])
    x_true = rng.uniform(-inner, inner, n)
    y_true = rng.uniform(-inner, inner, n)
    F_true = rng.uniform(0.6, 1.8, n)
    q = locator.predict(x_true, y_true, F_true)                      # (N, 3) C
    q = q + rng.normal(size=q.shape) * locator.noise_C               # the map's 1-sigma noise
    t0 = time.perf_counter()
    out = locator.locate(q)
    dt = time.perf_counter() - t0
    print(f"located {n} presses in {dt * 1e3:.1f} ms ({n / dt:.0f} per second through Python)")
    err = np.hypot(out.x_m - x_true, out.y_m - y_true)
    sigma = np.hypot(out.sigma_x_m, out.sigma_y_m)
    names, counts = np.unique(out.flags_text, return_counts=True)
    print("flags: " + ", ".join(f"{k} {c}" for k, c in zip(names, counts)))
    ok = out.has_position
    print(f"median position error {np.nanmedian(err[ok]) * 1e6:.0f} um, median reported 1-sigma "
          f"{np.nanmedian(sigma[ok]) * 1e6:.0f} um, median force error "
          f"{np.nanmedian(np.abs(out.force_N[ok] / F_true[ok] - 1)) * 100:.2f} %")

    with open(os.path.join(a.out, "lookup.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["x_true_m", "y_true_m", "force_true_N", "x_m", "y_m", "force_N", "sigma_x_m", "sigma_y_m",
                    "sigma_F_N", "flags"])
        for i in range(n):
            w.writerow([x_true[i], y_true[i], F_true[i], out.x_m[i], out.y_m[i], out.force_N[i], out.sigma_x_m[i],
                        out.sigma_y_m[i], out.sigma_F_N[i], out.flags_text[i]])

    print("== 3. Figure")
    mm = 1e3
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.8), constrained_layout=True)
    amb = ok & (out.flags & pvdfkit.FLAGS["ambiguous"] != 0)
    clean = ok & ~amb
    for el in scene.electrode_outlines_m:
        ax1.fill(el[:, 0] * mm, el[:, 1] * mm, color="0.8", ec="k", lw=0.8)
    for name, c in zip(scene.electrode_names, scene.electrode_centroids_m):
        ax1.annotate(name, c * mm, xytext=(5, 5), textcoords="offset points", fontsize=9)
    ax1.plot([x_true[ok] * mm, out.x_m[ok] * mm], [y_true[ok] * mm, out.y_m[ok] * mm], "-", color="0.5", lw=0.6)
    ax1.plot(x_true * mm, y_true * mm, ".", color="k", ms=3, label="true press")
    sc = ax1.scatter(out.x_m[clean] * mm, out.y_m[clean] * mm, c=err[clean] * 1e6, s=14, cmap="plasma",
                     label="located")
    if amb.any():
        ax1.plot(out.x_m[amb] * mm, out.y_m[amb] * mm, "x", color="tab:red", ms=6, label="located, flag ambiguous")
    if (~ok).any():
        ax1.plot(x_true[~ok] * mm, y_true[~ok] * mm, "s", mfc="none", color="tab:blue", ms=6,
                 label="no position (outside_map / no_press)")
    fig.colorbar(sc, ax=ax1, label="position error (µm)")
    ax1.plot([cmap.x_m[0] * mm, cmap.x_m[-1] * mm, cmap.x_m[-1] * mm, cmap.x_m[0] * mm, cmap.x_m[0] * mm],
             [cmap.y_m[0] * mm, cmap.y_m[0] * mm, cmap.y_m[-1] * mm, cmap.y_m[-1] * mm, cmap.y_m[0] * mm],
             "k:", lw=0.8, label="map extent")
    ax1.set_aspect("equal")
    ax1.set_xlabel("$x$ (mm)")
    ax1.set_ylabel("$y$ (mm)")
    ax1.set_title(f"{n} presses, 0.6–1.8 N, noise {locator.noise_C[0] * 1e12:.2f} pC (1σ)", fontsize=10)
    ax1.legend(fontsize=7, loc="lower left", framealpha=0.85)

    lim = [min(np.nanmin(sigma[ok]), np.nanmin(err[ok][err[ok] > 0])) * 1e6 * 0.5,
           max(np.nanmax(sigma[ok]), np.nanmax(err[ok])) * 1e6 * 2]
    ax2.loglog(lim, lim, "k-", lw=0.8, label="error = reported 1σ")
    ax2.loglog(sigma[clean] * 1e6, err[clean] * 1e6, "o", ms=3, alpha=0.7, label="press")
    if amb.any():
        ax2.loglog(sigma[amb] * 1e6, err[amb] * 1e6, "x", color="tab:red", ms=5, label="flag ambiguous")
    ax2.set_xlim(lim)
    ax2.set_ylim(lim)
    ax2.set_xlabel("reported position 1σ, $\\sqrt{\\sigma_x^2+\\sigma_y^2}$ (µm)")
    ax2.set_ylabel("true position error (µm)")
    ax2.set_title("Error against the Locator's own uncertainty", fontsize=10)
    ax2.grid(alpha=0.3, which="both")
    ax2.legend(fontsize=8)
    path = os.path.join(a.out, "lookup.png")
    fig.savefig(path, dpi=150)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
