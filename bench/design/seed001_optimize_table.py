#!/usr/bin/env python3
"""The table of docs/optimize-seed001.md from the outputs of bench/design/seed001_optimize.sh.

Usage: seed001_optimize_table.py OUT_DIR

Reads OUT/opt-seed*/optimize.json (the searches; `verify` where present), OUT/typed-atlas.json and
OUT/typed-fem.json (the typed layouts, maps from the atlas and FEM maps) and OUT/*.time
(/usr/bin/time -v) and prints Markdown: the per-count usable area by the atlas for each seed, its
spread, the FEM verification, the typed layouts, and the cost of every step.
"""
import glob
import json
import os
import re
import sys


def pct(x):
    return "—" if x is None else f"{100 * x:.1f} %"


def mm(x):
    return "unbounded" if x is None else f"{1e3 * x:.2f} mm"


def time_of(path):
    """Wall (s), user CPU (s), peak RSS (GB) of a /usr/bin/time -v file, or None."""
    if not os.path.exists(path):
        return None
    text = open(path).read()
    if "Exit status" not in text:  # still running
        return None
    user = float(re.search(r"User time \(seconds\): ([0-9.]+)", text).group(1))
    wall_s = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([0-9:.]+)", text).group(1)
    wall = 0.0
    for part in wall_s.split(":"):
        wall = 60 * wall + float(part)
    rss = int(re.search(r"Maximum resident set size \(kbytes\): ([0-9]+)", text).group(1)) * 1024 / 1e9
    return wall, user, rss


def partial_verify(out, seed, runs_json):
    """FEM verification entries of OUT/verify-seedS/best-N.json (`design --map` of a winner's FEM map,
    written when `--verify` did not finish), in the form of optimize.json's `verify`."""
    entries = []
    for path in sorted(glob.glob(os.path.join(out, f"verify-seed{seed}", "best-*.json"))):
        n = int(os.path.basename(path)[5:-5])
        lay = json.load(open(path))["layouts"][0]
        count = next(c for c in runs_json["counts"] if c["n_electrodes"] == n)
        entries.append({"n_electrodes": n, "usable_fraction_fem": lay["usable_fraction"],
                        "coverage_fem": lay["coverage"], "usable_fraction_atlas": count["usable_fraction"],
                        "coverage_atlas": count["coverage"], "median_sigma_pos_m_fem": lay["median_sigma_pos_m"]})
    return entries


def main():
    out = sys.argv[1]
    runs = {}
    for path in sorted(glob.glob(os.path.join(out, "opt-seed*", "optimize.json"))):
        j = json.load(open(path))
        runs[j["settings"]["seed"]] = j
    if not runs:
        sys.exit(f"no opt-seed*/optimize.json in {out}")
    seeds = sorted(runs)
    counts = [c["n_electrodes"] for c in runs[seeds[0]]["counts"]]
    first = runs[seeds[0]]
    print(f"Atlas {first.get('atlas', '?')}, budget {first['settings']['budget']} evaluations per count, "
          f"force {'known' if first['settings']['force_known'] else 'unknown'}, target "
          f"{1e3 * first['settings']['target_m']:g} mm.\n")

    print("| electrodes | " + " | ".join(f"usable, seed {s} (atlas)" for s in seeds) +
          " | spread (max − min) | coverage, seed " + str(seeds[0]) + " (atlas) | FEM usable | FEM coverage |")
    print("|---" * (len(seeds) + 5) + "|")
    verified = {}
    for s in seeds:
        for v in runs[s].get("verify") or partial_verify(out, s, runs[s]):
            verified[(s, v["n_electrodes"])] = v
    for n in counts:
        row = [runs[s]["counts"][counts.index(n)] for s in seeds]
        usable = [r.get("usable_fraction") for r in row]
        found = [u for u in usable if u is not None]
        spread = f"{100 * (max(found) - min(found)):.1f} points" if found else "—"
        v = next((verified[(s, n)] for s in seeds if (s, n) in verified), None)
        fem_u = f"{pct(v['usable_fraction_fem'])} (seed {v.get('seed', seeds[0])})" if v else "not run"
        fem_c = pct(v["coverage_fem"]) if v else "not run"
        print(f"| {n} | " + " | ".join(pct(u) for u in usable) +
              f" | {spread} | {pct(row[0].get('coverage'))} | {fem_u} | {fem_c} |")
    long_runs = {}
    for path in sorted(glob.glob(os.path.join(out, "optlong-seed*.json"))):
        j = json.load(open(path))
        long_runs[j["settings"]["seed"]] = j
    if long_runs:
        ls = sorted(long_runs)
        b = long_runs[ls[0]]["settings"]["budget"]
        print(f"\nThe same searches with budget {b} (atlas map; usable / coverage):\n")
        print("| electrodes | " + " | ".join(f"seed {s}" for s in ls) + " | spread (max − min) |")
        print("|---" * (len(ls) + 2) + "|")
        for n in counts:
            row = [long_runs[s]["counts"][counts.index(n)] for s in ls]
            u = [r.get("usable_fraction") for r in row]
            found = [x for x in u if x is not None]
            spread = f"{100 * (max(found) - min(found)):.1f} points" if found else "—"
            print(f"| {n} | " + " | ".join(f"{pct(r.get('usable_fraction'))} / {pct(r.get('coverage'))}" for r in row) +
                  f" | {spread} |")
    ref = first.get("reference")
    if ref:
        print(f"\nThe search's reference (the SCENE's own {ref['n_electrodes']} electrodes, atlas map): usable "
              f"{pct(ref['usable_fraction'])}, coverage {pct(ref['coverage'])}, median σpos {mm(ref['median_sigma_pos_m'])}.")
    nodes = first["counts"][0].get("n_mapped")
    if nodes:
        print(f"Grid nodes the fractions count: {nodes} (one node = {100 / nodes:.2f} points).")

    print("\n| typed layout | usable (atlas map) | coverage (atlas map) | usable (FEM map) | coverage (FEM map) | median σpos (FEM) |")
    print("|---|---|---|---|---|---|")
    typed = {}
    for kind in ("atlas", "fem"):
        path = os.path.join(out, f"typed-{kind}.json")
        if os.path.exists(path):
            for lay in json.load(open(path))["layouts"]:
                label = {"seed001": "triangle", "seed001_four_electrodes": "four"}.get(lay["label"], lay["label"])
                typed.setdefault(label, {})[kind] = lay
    for label in ("triangle", "four"):
        if label not in typed:
            continue
        a = typed[label].get("atlas", {})
        f = typed[label].get("fem", {})
        name = {"triangle": "seed 001's triangle (3)", "four": "four-electrode example's electrodes (4)"}[label]
        print(f"| {name} | {pct(a.get('usable_fraction'))} | {pct(a.get('coverage'))} | "
              f"{pct(f.get('usable_fraction'))} | {pct(f.get('coverage'))} | {mm(f.get('median_sigma_pos_m'))} |")

    print("\n| step | wall | user CPU | peak RSS |")
    print("|---|---|---|---|")
    for path in sorted(glob.glob(os.path.join(out, "*.time"))):
        t = time_of(path)
        if t:
            print(f"| {os.path.basename(path)[:-5]} | {t[0] / 60:.1f} min | {t[1]:.0f} s | {t[2]:.2f} GB |")


if __name__ == "__main__":
    main()
