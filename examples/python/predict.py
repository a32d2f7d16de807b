#!/usr/bin/env python3
"""Predict a sensor before fabrication: the film's deflection and the electrode charges.

What it shows
    The seed-001 sensor (25 um drawn PVDF clamped over a 90 mm hole, three 2 mm electrodes) is
    solved with the finite-element solver for a 1 N probe press at the centre; the deflection is
    sampled on a grid, and a ProbeSweep (one prepared mesh, many presses) gives every electrode's
    charge as the press moves along the x axis. The figure has both, in mm and pC.

Run (after the build; PYTHONPATH is not needed once `cmake --install` has installed pvdfkit)
    PYTHONPATH=build/python /usr/bin/python3 examples/python/predict.py [--scene FILE] [--out DIR] [--small]

Expect
    A centre deflection of about 3.3 mm for 1 N (a membrane, not a plate), charges of a few
    hundred pC growing as the press nears an electrode, out/predict.png and out/predict.csv.
    About 20 s (--small: about 10 s).
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
    p.add_argument("--out", default="predict-example")
    p.add_argument("--small", action="store_true", help="coarser sampling and tolerance (CI)")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)

    print("== 1. Load the scene (the same checks and messages as the command line)")
    scene = pvdfkit.load_scene(a.scene)
    radius = np.abs(scene.film_outline_m).max()
    print(f"{scene.source}: electrodes {scene.electrode_names}, film radius {radius * 1e3:.1f} mm")

    print("== 2. Solve a 1 N probe at the centre, sampling the deflection on a polar grid")
    # Polar sampling is dense where the membrane cone is steep (near the probe).
    n_r, n_t = (14, 36) if a.small else (30, 72)
    r = 0.99 * radius * np.linspace(0, 1, n_r)[1:] ** 1.5
    t = np.linspace(0, 2 * np.pi, n_t, endpoint=False)
    pts = np.vstack([[0.0, 0.0], np.column_stack([np.outer(r, np.cos(t)).ravel(), np.outer(r, np.sin(t)).ravel()])])
    tolerance = 0.02 if a.small else 0.01
    res = pvdfkit.solve(scene, loads=[[0.0, 0.0, 1.0]], samples=pts, tolerance=tolerance)
    s = res.summary
    print(f"{res.status}: model {s['model']}, {s['n_dofs']} DOFs, estimated relative error "
          f"{res.estimated_relative_error:.2g}, {s['wall_s']:.1f} s")
    print(f"deflection at the load {res.deflection_at_load_m * 1e3:.3f} mm; charges "
          + ", ".join(f"{k} {q * 1e12:.1f} pC" for k, q in zip(res.electrode_names, res.charge_C)))
    # For the contour plot only: the clamped rim, where w = 0 is the boundary condition.
    rim = np.column_stack([radius * np.cos(t), radius * np.sin(t)])
    xy = np.vstack([res.sample_position_m, rim])
    w = np.concatenate([res.deflection_m, np.zeros(len(rim))])

    print("== 3. Move the press along x with a ProbeSweep (one mesh, warm-started solves)")
    sweep = pvdfkit.ProbeSweep(scene, tolerance=tolerance, n_setup_checks=1 if a.small else 2)
    xs = np.linspace(-0.02, 0.02, 9 if a.small else 33)
    line = sweep.solve(xs, np.zeros_like(xs), 1.0)
    err = sweep.setup["estimated_relative_error"]
    print(f"sweep: {sweep.setup['n_dofs']} DOFs, estimated charge error {err:.2g}, all ok: {bool(line.ok.all())}")

    with open(os.path.join(a.out, "predict.csv"), "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["x_m", "y_m", "force_N", "deflection_at_load_m"] +
                     [f"charge_{k}_C" for k in scene.electrode_names])
        for i in range(len(line)):
            out.writerow([xs[i], 0.0, 1.0, line.deflection_at_load_m[i]] + list(line.charge_C[i]))

    print("== 4. Figure: deflection field and charge against press position")
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.6), constrained_layout=True)
    mm = 1e3
    cs = ax1.tricontourf(xy[:, 0] * mm, xy[:, 1] * mm, w * mm, levels=16, cmap="viridis")
    ax1.tricontour(xy[:, 0] * mm, xy[:, 1] * mm, w * mm, levels=cs.levels[::3], colors="k", linewidths=0.4)
    fig.colorbar(cs, ax=ax1, label="deflection $w$ (mm)")
    outline = scene.film_outline_m
    ax1.plot(outline[:, 0] * mm, outline[:, 1] * mm, "k-", lw=1)
    for name, el in zip(scene.electrode_names, scene.electrode_outlines_m):
        ax1.fill(el[:, 0] * mm, el[:, 1] * mm, color="w", ec="k", lw=0.8)
        c = el[:-1].mean(axis=0) * mm
        ax1.annotate(name, c, xytext=(4, 4), textcoords="offset points", color="w", fontsize=9)
    ax1.plot(xs * mm, 0 * xs, "--", color="tab:orange", lw=1.2, label="press path of the right panel")
    ax1.plot([0], [0], "r+", ms=10, label="1 N probe")
    ax1.set_aspect("equal")
    ax1.set_xlabel("$x$ (mm)")
    ax1.set_ylabel("$y$ (mm)")
    ax1.set_title(f"Deflection under a 1 N probe at the centre\n(max {abs(res.max_deflection_m) * mm:.2f} mm, "
                  f"estimated relative error {res.estimated_relative_error:.1g})", fontsize=10)
    ax1.legend(loc="lower left", fontsize=8, framealpha=0.8)

    for k, name in enumerate(scene.electrode_names):
        q = line.charge_C[:, k] * 1e12
        (h,) = ax2.plot(xs * mm, q, "o-", ms=3, label=f"electrode {name}")
        ax2.fill_between(xs * mm, q * (1 - err), q * (1 + err), color=h.get_color(), alpha=0.2, lw=0)
    ax2.set_xlabel("press position $x$ (mm)")
    ax2.set_ylabel("electrode charge (pC)")
    ax2.set_title(f"Charge as a 1 N press moves along $y$ = 0\n(band: estimated relative error {err:.2g})",
                  fontsize=10)
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8)
    path = os.path.join(a.out, "predict.png")
    fig.savefig(path, dpi=150)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
