#!/usr/bin/env python3
"""Compare with a bench: charges from a press CSV against the FEM prediction at the same presses.

What it shows
    A bench CSV (`x_m,y_m,force_N,charge_<electrode>_C`, one row per press) is read with the same
    reader as `pvdfkit calibrate`, every press is solved with a ProbeSweep (or looked up in a
    charge map with --map), and the two are compared electrode by electrode, as seed 001 Fig. 12
    does: predicted against bench charge, and the % difference against the distance from the
    electrode. The default CSV, examples/data/seed001-measured-style.csv, is SYNTHETIC (FEM solves
    perturbed by 0.5 mm mispositioning and 5 % reading noise; its header says how it was made),
    so the figure calls it "bench CSV (synthetic)", never "measured".

Run
    PYTHONPATH=build/python /usr/bin/python3 examples/python/compare_bench.py [--csv FILE] [--map MAP.h5] [--out DIR] [--small]

Expect
    Differences of a few % (the CSV's own 5 % noise and mispositioning), larger close to an
    electrode where the charge changes fastest; out/compare_bench.png and compare_bench.csv.
    About 20 s (--small: 8 presses).
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pvdfkit  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default=os.path.join(HERE, "..", "scenes", "seed001.json"))
    p.add_argument("--csv", default=os.path.join(HERE, "..", "data", "seed001-measured-style.csv"))
    p.add_argument("--map", help="charge map (HDF5) to predict from instead of solving")
    p.add_argument("--out", default="compare-example")
    p.add_argument("--small", action="store_true", help="first 8 presses, looser tolerance (CI)")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)

    print("== 1. Read the scene and the bench CSV")
    scene = pvdfkit.load_scene(a.scene)
    names = scene.electrode_names
    bench = pvdfkit.read_measurements(a.csv, names)
    n = min(8, len(bench["x_m"])) if a.small else len(bench["x_m"])
    x, y, F, q_bench = (bench[k][:n] for k in ("x_m", "y_m", "force_N", "charge_C"))
    print(f"{n} presses from {a.csv}")

    print("== 2. Predict the charges at the same presses")
    if a.map:
        locator = pvdfkit.Locator(pvdfkit.read_map(a.map))
        q_pred = locator.predict(x, y, F)
        err = 0.0
        source = f"map {os.path.basename(a.map)}"
    else:
        sweep = pvdfkit.ProbeSweep(scene, tolerance=0.02 if a.small else 0.01, forces_N=sorted(set(F)),
                                   n_setup_checks=1 if a.small else 2)
        sol = sweep.solve(x, y, F)
        if not sol.ok.all():
            print("some presses did not converge:", [m for m in sol.message if m])
        q_pred = sol.charge_C
        err = sweep.setup["estimated_relative_error"]
        source = f"FEM (ProbeSweep, est. error {err:.1%})"
    diff_pct = 100 * (q_bench - q_pred) / q_pred
    centres = scene.electrode_centroids_m
    dist = np.hypot(x[:, None] - centres[:, 0], y[:, None] - centres[:, 1])
    rms = np.sqrt(np.nanmean(diff_pct**2))
    print(f"bench - prediction: RMS {rms:.1f} %, per electrode " +
          ", ".join(f"{k} {np.sqrt(np.nanmean(diff_pct[:, i] ** 2)):.1f} %" for i, k in enumerate(names)))

    with open(os.path.join(a.out, "compare_bench.csv"), "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["x_m", "y_m", "force_N"] + [f"predicted_{k}_C" for k in names] +
                     [f"difference_{k}_percent" for k in names])
        for i in range(n):
            out.writerow([x[i], y[i], F[i]] + list(q_pred[i]) + list(diff_pct[i]))

    print("== 3. Figure: predicted against bench charge, and the difference against distance")
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.6), constrained_layout=True)
    pc = 1e12
    lim = [0, 1.1 * max(np.nanmax(q_bench), np.nanmax(q_pred)) * pc]
    ax1.plot(lim, lim, "k-", lw=0.8, label="equal")
    ax1.fill_between(lim, [v * 0.95 for v in lim], [v * 1.05 for v in lim], color="0.85", label="±5 %")
    markers = "osd^v<>"
    for i, k in enumerate(names):
        ax1.plot(q_pred[:, i] * pc, q_bench[:, i] * pc, markers[i % 7], ms=5, label=f"electrode {k}")
        ax2.plot(dist[:, i] * 1e3, diff_pct[:, i], markers[i % 7], ms=5, label=f"electrode {k}")
    ax1.set_xlim(lim)
    ax1.set_ylim(lim)
    ax1.set_aspect("equal")
    ax1.set_xlabel(f"predicted charge (pC), {source}")
    ax1.set_ylabel("bench CSV charge (pC), synthetic")
    ax1.set_title(f"{n} presses, force {', '.join(f'{v:g}' for v in sorted(set(F)))} N", fontsize=10)
    ax1.legend(fontsize=8, loc="upper left")
    ax1.grid(alpha=0.3)
    ax2.axhline(0, color="k", lw=0.8)
    ax2.axhspan(-5, 5, color="0.85", zorder=0, label="±5 % (the CSV's reading noise)")
    ax2.set_xlabel("distance from the electrode centre (mm)")
    ax2.set_ylabel("(bench − predicted) / predicted (%)")
    ax2.set_title(f"Difference per electrode (RMS {rms:.1f} %)", fontsize=10)
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    path = os.path.join(a.out, "compare_bench.png")
    fig.savefig(path, dpi=150)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
