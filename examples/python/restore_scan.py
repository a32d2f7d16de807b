#!/usr/bin/env python3
"""Restore a scan: identify seed 000's inverse filters from two edges, then restore f_x, f_z and mu.

What it shows
    The cylindrical PVDF scanner of seed 000 is simulated scanning a raised edge twice with known
    forces (examples/restore/edge_a.json, edge_b.json); the 2x2 transfer matrix is identified from
    those scans and inverted with regularization into FIR filters (automatic beta, 1.5 mm target
    resolution, 10 mm low cut); a new surface (two edges and a ridged texture whose friction rises
    from 0.2 to 0.8, examples/restore/scanner.json) is then restored. The figure shows the strip
    signals, the restored normal and shear force per mm of scan against the true forces blurred
    to the same resolution, and the friction coefficient.

Run
    PYTHONPATH=build/python /usr/bin/python3 examples/python/restore_scan.py [--out DIR] [--small]

Expect
    The edges restored at -30 mm and -15 mm, mu close to 0.375 and 0.786 there and rising along
    the texture; out/restore_scan.png and out/forces.csv. About 5 s.
"""
import argparse
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pvdfkit import restore  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "..", "restore")


def blur(force_per_sample, dx_m, fwhm_m):
    """The true forces seen through the filters' target Gaussian (the same resolution)."""
    s = fwhm_m / 2.3548 / dx_m
    k = np.arange(-int(5 * s) - 1, int(5 * s) + 2)
    g = np.exp(-0.5 * (k / s) ** 2)
    return np.convolve(force_per_sample, g / g.sum(), mode="same")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="restore-example")
    p.add_argument("--small", action="store_true", help="shorter filters (CI)")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)

    print("== 1. Scan the two identification edges (x = -12.5 mm) with known forces")
    edge_a = restore.simulate(restore.load_scanner_scene(os.path.join(SCENES, "edge_a.json")))
    edge_b = restore.simulate(restore.load_scanner_scene(os.path.join(SCENES, "edge_b.json")))

    print("== 2. Identify G and design the inverse filters")
    resolution = 1.5e-3
    filt = restore.identify([(edge_a, 0.6, 0.9, -0.0125), (edge_b, 0.2, 1.0, -0.0125)], beta="auto",
                            taps=4096 if a.small else 8192, resolution_m=resolution, low_cut_wavelength_m=0.01)
    print(f"beta ({filt.beta_policy}) = {filt.beta:.3g}, {filt.taps} taps, delay {filt.delay_samples} samples, "
          f"cond(G) median {filt.conditioning['median']:.3g}")
    restore.save_filter(os.path.join(a.out, "filter.json"), filt)

    print("== 3. Scan the test surface and restore it")
    surface = restore.simulate(restore.load_scanner_scene(os.path.join(SCENES, "scanner.json")))
    forces = restore.apply(filt, surface)
    dx = surface.sample_spacing_m
    for x_edge in (-0.03, -0.015):
        near = np.abs(forces.x_m - x_edge) < 0.004
        i = np.flatnonzero(near)[np.argmax(forces.fz_N[near])]
        print(f"edge near {x_edge * 1e3:.0f} mm: restored at {forces.x_m[i] * 1e3:.2f} mm, "
              f"peak f_z {forces.fz_N[i] / dx / 1e3:.3f} N/mm, mu {forces.mu[i]:.3f}")
    with open(os.path.join(a.out, "forces.csv"), "w") as f:
        f.write("x_m,fx_N,fz_N,mu,mu_valid\n")
        for row in zip(forces.x_m, forces.fx_N, forces.fz_N, forces.mu, forces.mu_valid.astype(int)):
            f.write(",".join(f"{v:.9g}" for v in row) + "\n")

    print("== 4. Figure")
    mm = 1e3
    x = forces.x_m * mm
    per_mm = 1 / (dx * mm)  # N per sample -> N per mm of scan
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True, constrained_layout=True)
    ax = axes[0]
    ax.plot(surface.x_m * mm, surface.m1_V, lw=0.7, label="strip 1 ($m_1$)")
    ax.plot(surface.x_m * mm, surface.m2_V, lw=0.7, label="strip 2 ($m_2$)")
    ax.set_ylabel("signal (V)")
    ax.set_title("Simulated scan of the test surface (50 mm/s, 10 kHz)", fontsize=10)
    ax.legend(fontsize=8, loc="upper right")
    ax = axes[1]
    ax.plot(x, blur(surface.fz_N, dx, resolution) * per_mm, "k-", lw=1.6, alpha=0.35, label="true $f_z$ (blurred)")
    ax.plot(x, blur(surface.fx_N, dx, resolution) * per_mm, "-", color="tab:red", lw=1.6, alpha=0.35,
            label="true $f_x$ (blurred)")
    ax.plot(x, forces.fz_N * per_mm, "k-", lw=0.8, label="restored $f_z$ (normal)")
    ax.plot(x, forces.fx_N * per_mm, "-", color="tab:red", lw=0.8, label="restored $f_x$ (shear)")
    ax.set_ylabel("force per scan length (N/mm)")
    ax.set_title(f"Restored forces against the true ones blurred to the filters' {resolution * mm:g} mm "
                 "target resolution", fontsize=10)
    ax.legend(fontsize=8, ncol=2, loc="upper right")
    ax = axes[2]
    valid = forces.mu_valid
    ax.plot(x[valid], forces.mu[valid], ".", ms=2, label=r"restored $\mu = f_x/f_z$")
    ax.plot([-30, -15], [0.3 / 0.8, 0.55 / 0.7], "kD", ms=6, mfc="none", ls="none", label=r"true $\mu$ of the edges")
    ax.plot([0, 30], [0.2, 0.8], "k--", lw=0.8, label=r"true $\mu$ along the texture")
    ax.set_ylim(0, 1.2)
    ax.set_ylabel(r"friction coefficient $\mu$ (–)")
    ax.set_xlabel("scanner position $x$ (mm)")
    ax.set_title(f"Friction where $f_z$ > {forces.mu_threshold_N * per_mm:.3g} N/mm", fontsize=10)
    ax.legend(fontsize=8, loc="upper left")
    for ax in axes:
        ax.grid(alpha=0.3)
    path = os.path.join(a.out, "restore_scan.png")
    fig.savefig(path, dpi=150)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
