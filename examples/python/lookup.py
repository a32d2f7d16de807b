#!/usr/bin/env python3
"""Ship a lookup: from a charge map to press positions and forces, many presses at once.

What it shows
    A charge map (read with --map, or computed here by the FEM on a coarse grid around the
    electrodes) is turned into a Locator; charges of N presses — the map's own prediction at
    random off-grid positions plus the map's 1-sigma channel noise — go in as one (N, 3) numpy
    array, and positions, forces, 1-sigma values and flags come out as arrays, once with the force
    unknown and once known. The figure shows true against located positions and the position
    error against the reported 1-sigma.

Run
    PYTHONPATH=build/python /usr/bin/python3 examples/python/lookup.py [--map MAP.h5] [--out DIR] [--small]

Expect
    Position errors of the order of the reported sigma (about 10 um at 0.05 pC noise). With the
    force unknown many presses are flagged ambiguous: three charges fit a far, hard press as well as
    a near, soft one, and the truth is then the reported alternative; with the force known (a force
    transducer) nearly all are unique. out/lookup.png, out/lookup.csv and the map out/map.h5.
    With --small the map is 4 mm over +-12 mm (about 20 s); without, 2 mm over +-16 mm (minutes).
"""
import argparse
import csv
import os
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.colors  # noqa: E402
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
    out = locator.locate(q)                                          # force unknown
    dt = time.perf_counter() - t0
    known = locator.locate(q, known_force_N=F_true)                  # force from a transducer
    print(f"located {n} presses in {dt * 1e3:.1f} ms ({n / dt:.0f} per second through Python)")
    for label, r in (("force unknown", out), ("force known", known)):
        err = np.hypot(r.x_m - x_true, r.y_m - y_true)
        names, counts = np.unique(r.flags_text, return_counts=True)
        single = r.has_position & (r.flags & pvdfkit.FLAGS["ambiguous"] == 0)
        print(f"{label}: flags " + ", ".join(f"{k} {c}" for k, c in zip(names, counts)) +
              f"; unambiguous presses: median error {np.nanmedian(err[single]) * 1e6:.0f} um, "
              f"median reported 1-sigma {np.nanmedian(np.hypot(r.sigma_x_m, r.sigma_y_m)[single]) * 1e6:.0f} um")
    # With unknown force, three charges often fit two presses (a far, hard press looks like a near,
    # soft one): the Locator then flags `ambiguous` and reports the other one as an alternative.
    amb = out.has_position & (out.flags & pvdfkit.FLAGS["ambiguous"] != 0)
    cand = np.concatenate([np.stack([out.x_m, out.y_m], 1)[:, None], out.alternatives[:, :, :2]], axis=1)
    dist = np.hypot(cand[..., 0] - x_true[:, None], cand[..., 1] - y_true[:, None])
    best = np.where(np.isnan(dist), np.inf, dist).min(axis=1)
    print(f"ambiguous presses whose truth is the answer or an alternative (< 0.1 mm): "
          f"{np.sum(best[amb] < 1e-4)} of {amb.sum()}")

    with open(os.path.join(a.out, "lookup.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["x_true_m", "y_true_m", "force_true_N", "x_m", "y_m", "force_N", "sigma_x_m", "sigma_y_m",
                    "sigma_F_N", "flags", "x_known_force_m", "y_known_force_m", "flags_known_force"])
        for i in range(n):
            w.writerow([x_true[i], y_true[i], F_true[i], out.x_m[i], out.y_m[i], out.force_N[i], out.sigma_x_m[i],
                        out.sigma_y_m[i], out.sigma_F_N[i], out.flags_text[i], known.x_m[i], known.y_m[i],
                        known.flags_text[i]])

    print("== 3. Figure")
    mm, um = 1e3, 1e6
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11.5, 5), constrained_layout=True)
    for el in scene.electrode_outlines_m:
        ax1.fill(el[:, 0] * mm, el[:, 1] * mm, color="0.8", ec="k", lw=0.8)
    for name, c in zip(scene.electrode_names, scene.electrode_centroids_m):
        ax1.annotate(name, c * mm, xytext=(7, 7), textcoords="offset points", fontsize=9)
    ok = known.has_position
    err_k = np.hypot(known.x_m - x_true, known.y_m - y_true)
    ax1.plot(x_true * mm, y_true * mm, "o", mfc="none", color="k", ms=6, lw=0.5, label="true press")
    norm = matplotlib.colors.LogNorm(vmin=1, vmax=max(1e3, np.nanmax(err_k[ok]) * um))
    sc = ax1.scatter(known.x_m[ok] * mm, known.y_m[ok] * mm, c=err_k[ok] * um, s=12, cmap="viridis", norm=norm,
                     label="located (force known)")
    flagged = ok & (known.flags != 0)  # poor_fit, ambiguous, ...: the lookup warns about these answers
    if flagged.any():
        ax1.plot(known.x_m[flagged] * mm, known.y_m[flagged] * mm, "s", mfc="none", color="tab:red", ms=8, mew=0.8,
                 label="located, with a flag (e.g. poor_fit)")
    far = ok & (err_k > 1e-3)
    if far.any():
        ax1.plot([x_true[far] * mm, known.x_m[far] * mm], [y_true[far] * mm, known.y_m[far] * mm], "r-", lw=0.8)
    if (~ok).any():
        ax1.plot(x_true[~ok] * mm, y_true[~ok] * mm, "x", color="tab:red", ms=7, label="no position (flagged)")
    fig.colorbar(sc, ax=ax1, label="position error, force known (µm)")
    ax1.plot([cmap.x_m[0] * mm, cmap.x_m[-1] * mm, cmap.x_m[-1] * mm, cmap.x_m[0] * mm, cmap.x_m[0] * mm],
             [cmap.y_m[0] * mm, cmap.y_m[0] * mm, cmap.y_m[-1] * mm, cmap.y_m[-1] * mm, cmap.y_m[0] * mm],
             "k:", lw=0.8, label="map extent")
    ax1.set_aspect("equal")
    ax1.set_xlabel("$x$ (mm)")
    ax1.set_ylabel("$y$ (mm)")
    ax1.set_title(f"{n} presses of 0.6–1.8 N, charge noise {locator.noise_C[0] * 1e12:.2f} pC (1σ)\n"
                  f"map step {(cmap.x_m[1] - cmap.x_m[0]) * mm:g} mm; force known", fontsize=10)
    ax1.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3, frameon=False)

    sig_u = np.hypot(out.sigma_x_m, out.sigma_y_m) * um
    err_u = np.hypot(out.x_m - x_true, out.y_m - y_true) * um
    sig_k = np.hypot(known.sigma_x_m, known.sigma_y_m) * um
    single = out.has_position & ~amb
    lim = [0.5, 3e4]
    ax2.loglog(lim, lim, "k-", lw=0.8, label="error = reported 1σ")
    clean = ok & ~flagged
    ax2.loglog(sig_k[clean], np.maximum(err_k[clean] * um, 0.6), "s", ms=3, color="tab:green",
               label="force known, no flag")
    ax2.loglog(sig_k[flagged], np.maximum(err_k[flagged] * um, 0.6), "s", ms=4, mfc="none", color="tab:green",
               label="force known, flagged (poor_fit, ...)")
    ax2.loglog(sig_u[single], np.maximum(err_u[single], 0.6), "o", ms=3, color="tab:blue",
               label="force unknown, one solution")
    ax2.loglog(sig_u[amb], np.maximum(err_u[amb], 0.6), "x", ms=5, color="tab:red",
               label="force unknown, flag ambiguous\n(reported answer; the truth is\nusually its alternative)")
    ax2.set_xlim(lim)
    ax2.set_ylim(lim)
    ax2.set_xlabel("reported position 1σ, $\\sqrt{\\sigma_x^2+\\sigma_y^2}$ (µm)")
    ax2.set_ylabel("true position error (µm)")
    ax2.set_title("Error against the Locator's own uncertainty", fontsize=10)
    ax2.grid(alpha=0.3, which="major")
    ax2.legend(fontsize=7, loc="lower right")
    path = os.path.join(a.out, "lookup.png")
    fig.savefig(path, dpi=150)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
