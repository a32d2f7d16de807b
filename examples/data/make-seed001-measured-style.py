#!/usr/bin/env python3
"""Writes examples/data/seed001-measured-style.csv: SYNTHETIC "measured" charges for seed 001.

Seed 001 prints its measured charges only as figures (Figs 6-8, 12), which the text version of
the paper does not contain, so nothing here is digitized from the paper. Instead every row is
an FEM solve of the seed-001 scene (`pvdfkit solve --load X,Y,1`) perturbed by the two error
sources the paper itself estimates (§4):
  * probe mispositioning: the press is solved 0.5 mm away from the position written in the
    CSV, in a pseudo-random direction;
  * chart-recorder reading: each charge is multiplied by (1 + e), e ~ N(0, 0.05).
The random numbers come from Python's random.Random(1) (fixed seed): the file is reproducible.
Positions: along rays from electrode B at 45°, 65° and 85° from the draw direction (the angles
of seed 001 Fig. 12) at 4, 7, 10, 14 and 18 mm, plus a few presses near A and C.

Run:    examples/data/make-seed001-measured-style.py PVDFKIT [SCENE] > examples/data/seed001-measured-style.csv
Takes one FEM solve per row (about 20).
"""
import json
import math
import random
import subprocess
import sys


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    pvdfkit = sys.argv[1]
    scene_path = sys.argv[2] if len(sys.argv) > 2 else "examples/scenes/seed001.json"
    scene = json.load(open(scene_path))
    names = [e["name"] for e in scene["electrodes"]]
    centres = {e["name"]: e["center_m"] for e in scene["electrodes"]}
    draw = math.radians(scene["material"].get("draw_angle_deg", 0.0))
    rng = random.Random(1)
    points = []
    bx, by = centres["B"]
    for beta in (45.0, 65.0, 85.0):
        for d_mm in (4.0, 7.0, 10.0, 14.0, 18.0):
            t = draw + math.radians(beta)
            points.append((bx + d_mm * 1e-3 * math.cos(t), by + d_mm * 1e-3 * math.sin(t)))
    ax, ay = centres["A"]
    cx, cy = centres["C"]
    points += [(ax + 0.004, ay - 0.003), (ax - 0.006, ay + 0.002), (cx - 0.004, cy + 0.004), (cx + 0.005, cy - 0.006),
               (0.0, 0.0)]
    print("# SYNTHETIC measured-style charges for the seed-001 sensor (NOT measured, NOT digitized from the paper).")
    print("# Each row: pvdfkit solve of %s with a 1 N probe 0.5 mm from (x_m, y_m) in a pseudo-random" % scene_path)
    print("# direction (seed 001 §4 mispositioning), each charge times (1 + e), e ~ N(0, 0.05) (chart reading).")
    print("# Generator: examples/data/make-seed001-measured-style.py (random.Random(1)). Columns: docs/seed001-reproduction.md")
    print("x_m,y_m,force_N," + ",".join("charge_%s_C" % n for n in names))
    for (x, y) in points:
        phi = rng.uniform(0.0, 2.0 * math.pi)
        xs, ys = x + 0.5e-3 * math.cos(phi), y + 0.5e-3 * math.sin(phi)
        r = subprocess.run([pvdfkit, "solve", scene_path, "--load", "%.9g,%.9g,1" % (xs, ys), "--json"],
                           capture_output=True, text=True)
        if r.returncode != 0:
            print("solve at (%g, %g) failed: %s" % (xs, ys, r.stderr.strip()), file=sys.stderr)
            return 3
        j = json.loads(r.stdout)
        q = {e["name"]: e["charge_C"] for e in j["electrodes"]}
        row = ["%.6g" % x, "%.6g" % y, "1"] + ["%.6g" % (q[n] * (1.0 + rng.gauss(0.0, 0.05))) for n in names]
        print(",".join(row))
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
