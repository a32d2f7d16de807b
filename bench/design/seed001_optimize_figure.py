#!/usr/bin/env python3
"""The figures of docs/optimize-seed001.md from the outputs of bench/design/seed001_optimize.sh.

Usage: seed001_optimize_figure.py OUT_DIR

Writes OUT/optimize_seed001_front.png (usable area and coverage against the electrode count: each
seed's winners by the atlas, the FEM maps of the verified winners, and the two typed layouts by the
atlas and by FEM) and OUT/optimize_seed001_layouts.png (the winners of every seed drawn on the film,
one panel per electrode count, with the two typed layouts for comparison).
"""
import glob
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle, Polygon  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from seed001_optimize_table import partial_verify  # noqa: E402  (one home: the table's reader)

SEED_COLORS = ["#0072b2", "#e69f00", "#009e73", "#cc79a7", "#56b4e9"]


def rect_corners(center, size, angle_deg):
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    w, h = size[0] / 2, size[1] / 2
    return [(1e3 * (center[0] + c * x - s * y), 1e3 * (center[1] + s * x + c * y))
            for x, y in ((-w, -h), (w, -h), (w, h), (-w, h))]


def scene_rects(scene):
    return [rect_corners(e["center_m"], e.get("size_m", [0.002, 0.002]), e.get("angle_deg", 0.0))
            for e in scene["electrodes"]]


def main():
    out = sys.argv[1]
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    runs = {}
    for path in sorted(glob.glob(os.path.join(out, "opt-seed*", "optimize.json"))):
        j = json.load(open(path))
        runs[j["settings"]["seed"]] = (j, os.path.dirname(path))
    seeds = sorted(runs)
    first = runs[seeds[0]][0]
    target_mm = 1e3 * first["settings"]["target_m"]
    budget = first["settings"]["budget"]
    typed = {}
    for kind in ("atlas", "fem"):
        path = os.path.join(out, f"typed-{kind}.json")
        if os.path.exists(path):
            for lay in json.load(open(path))["layouts"]:
                label = {"seed001": "triangle", "seed001_four_electrodes": "four"}.get(lay["label"], lay["label"])
                typed.setdefault(label, {})[kind] = lay

    # Figure 1: the front.
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.6), sharey=True)
    for ax, key, title in ((axes[0], "usable_fraction", f"usable area (σ$_{{pos}}$ ≤ {target_mm:g} mm)"),
                           (axes[1], "coverage", "coverage (σ$_{pos}$ ≤ target, ambiguity not counted)")):
        for k, s in enumerate(seeds):
            j = runs[s][0]
            n = [c["n_electrodes"] for c in j["counts"] if c["found"]]
            v = [100 * c[key] for c in j["counts"] if c["found"]]
            ax.plot([x + 0.06 * (k - 1) for x in n], v, "o-", color=SEED_COLORS[k % len(SEED_COLORS)], ms=5, lw=1.2,
                    label=f"search, seed {s} (atlas map)")
        for s in seeds:
            ver = runs[s][0].get("verify") or partial_verify(out, s, runs[s][0])
            if ver:
                fem_key = "usable_fraction_fem" if key == "usable_fraction" else "coverage_fem"
                ax.plot([v["n_electrodes"] for v in ver], [100 * v[fem_key] for v in ver], "D", mfc="none", mec="k",
                        ms=9, mew=1.5, label=f"seed {s} winners, FEM map")
        for label, n, marker, name in (("triangle", 3, "s", "seed 001's triangle"),
                                       ("four", 4, "^", "four-electrode example")):
            for kind, color, suffix in (("atlas", "#f4a6a6", "atlas map"), ("fem", "#d62728", "FEM map")):
                lay = typed.get(label, {}).get(kind)
                if lay is not None:
                    ax.plot([n], [100 * lay[key]], marker, color=color, ms=9, label=f"{name}, {suffix}")
        ax.set_xticks(sorted({c["n_electrodes"] for c in first["counts"]}))
        ax.set_xlim(2.5, 5.5)
        ax.set_ylim(0, 100)
        ax.set_xlabel("electrodes")
        ax.set_title(title, fontsize=11)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("fraction of the film's grid nodes (%)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.suptitle(f"seed-001 film: best layout per electrode count (budget {budget}), force unknown, "
                 f"0.05 pC, 0.5–2 N", fontsize=12)
    fig.tight_layout(rect=(0, 0.2, 1, 0.96))
    fig.legend(handles, labels, loc="lower center", bbox_to_anchor=(0.5, 0.0), ncol=3, fontsize=9, frameon=False)
    fig.savefig(os.path.join(out, "optimize_seed001_front.png"), dpi=110)
    plt.close(fig)

    # Figure 2: the layouts.
    scene = json.load(open(os.path.join(root, "examples/scenes/seed001.json")))
    radius_mm = 1e3 * scene["membrane"]["radius_m"]
    counts = [c["n_electrodes"] for c in first["counts"]]
    fig, axes = plt.subplots(1, len(counts) + 1, figsize=(4.0 * (len(counts) + 1), 5.2))
    for ax, n in zip(axes, counts):
        ax.add_patch(Circle((0, 0), radius_mm, fill=False, color="k", lw=1))
        for k, s in enumerate(seeds):
            j, d = runs[s]
            c = j["counts"][counts.index(n)]
            if not c["found"]:
                continue
            color = SEED_COLORS[k % len(SEED_COLORS)]
            for r, corners in enumerate(scene_rects(json.load(open(os.path.join(d, f"best-{n}.json"))))):
                ax.add_patch(Polygon(corners, closed=True, fc=color, ec="k", lw=0.6, alpha=0.85,
                                     label=f"seed {s}: {100 * c['usable_fraction']:.1f} %" if r == 0 else None))
        ax.set_title(f"{n} electrodes (usable by the atlas map)", fontsize=10)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=1, fontsize=8.5, frameon=False)
    ax = axes[-1]
    ax.add_patch(Circle((0, 0), radius_mm, fill=False, color="k", lw=1))
    # The four filled grey, the triangle as red outlines on top: both have an electrode at (0, 10) mm.
    for label, path, fc, ec, lw in (("four", "bench/design/seed001_four_electrodes.json", "#9a9a9a", "k", 0.6),
                                    ("triangle", "examples/scenes/seed001.json", "none", "#d62728", 1.8)):
        fem = typed.get(label, {}).get("fem")
        name = {"triangle": "seed 001's triangle", "four": "four-electrode example"}[label]
        for r, corners in enumerate(scene_rects(json.load(open(os.path.join(root, path))))):
            ax.add_patch(Polygon(corners, closed=True, fc=fc, ec=ec, lw=lw,
                                 label=(f"{name}: {100 * fem['usable_fraction']:.1f} % (FEM)" if fem else name)
                                 if r == 0 else None))
    ax.set_title("the typed layouts (usable by the FEM map)", fontsize=10)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=1, fontsize=8.5, frameon=False)
    for ax in axes:
        ax.set_xlim(-radius_mm * 1.05, radius_mm * 1.05)
        ax.set_ylim(-radius_mm * 1.05, radius_mm * 1.05)
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("y (mm)")
    fig.suptitle("seed-001 film (draw along x): the winning layouts of each seed, electrodes to scale", fontsize=12)
    fig.tight_layout(rect=(0, 0.1, 1, 0.95))
    fig.savefig(os.path.join(out, "optimize_seed001_layouts.png"), dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
