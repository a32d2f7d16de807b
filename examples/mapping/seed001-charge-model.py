#!/usr/bin/env python3
"""Seed 001 charge model: the FEM electrode charge against eq. 2 (as printed and corrected).

What it shows: for probe presses at several positions on the seed-001 film, the charge that
`pvdfkit solve` integrates over each electrode, Q = ∫(d31 σ11 + d32 σ22) dA, next to
  * the uniform-stress estimate (d31 σ̄11 + d32 σ̄22)·Se from the electrode's mean stress,
  * the tensor form at the electrode centre, (d31 σ11 + d32 σ22)·Se, from the polar stresses
    σr, σθ about the load, and with σθ = 0 (corrected eq. 2: d31 cos²β + d32 sin²β),
  * seed 001 eq. 2 as printed, (d31 cos β + d32 sin β)·σr·Se  (β folded into [0°, 90°]).
The numbers feed docs/charge-model.md.

Run:    examples/mapping/seed001-charge-model.py PVDFKIT [SCENE] [--json OUT.json]
Expect: a table per load position; eq. 2 as printed overestimates off-axis electrodes.
Takes one FEM solve per load position (several seconds each).
"""
import json
import math
import subprocess
import sys


def main():
    args = [a for a in sys.argv[1:]]
    out_json = None
    if "--json" in args:
        i = args.index("--json")
        out_json = args[i + 1]
        del args[i:i + 2]
    if not args:
        print(__doc__)
        return 2
    pvdfkit = args[0]
    scene_path = args[1] if len(args) > 1 else "examples/scenes/seed001.json"
    scene = json.load(open(scene_path))
    mat = scene["material"]
    d31, d32 = mat["d31_C_per_N"], mat["d32_C_per_N"]
    h = scene["membrane"]["thickness_m"]
    draw = math.radians(mat.get("draw_angle_deg", 0.0))
    electrodes = scene["electrodes"]
    # 1. Load positions: the centre, inside the triangle, and on the far side of it.
    loads = [(0.0, 0.0), (0.004, 0.0), (0.0, -0.006), (-0.012, 0.006), (0.015, -0.010)]
    rows = []
    for (x, y) in loads:
        cmd = [pvdfkit, "solve", scene_path, "--load", "%.9g,%.9g,1" % (x, y), "--json"]
        for e in electrodes:
            cmd += ["--sample", "%.12g,%.12g" % tuple(e["center_m"])]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            print("solve at (%g, %g) failed: %s" % (x, y, r.stderr.strip()), file=sys.stderr)
            continue
        j = json.loads(r.stdout)
        for k, (e, s) in enumerate(zip(j["electrodes"], j["samples"])):
            area = e["area_m2"]
            n11, n22, _ = e["mean_membrane_force_material_N_per_m"]
            q_fem = e["charge_C"]
            q_mean = (d31 * n11 + d32 * n22) / h * area
            nr, nt, _ = s["membrane_force_polar_N_per_m"]
            n11c, n22c, _ = s["membrane_force_material_N_per_m"]
            ex, ey = electrodes[k]["center_m"]
            beta = math.atan2(ey - y, ex - x) - draw  # angle of the load→electrode line from the draw axis
            c, sn = abs(math.cos(beta)), abs(math.sin(beta))
            q_centre = (d31 * n11c + d32 * n22c) / h * area
            q_radial = (d31 * c * c + d32 * sn * sn) * nr / h * area
            q_eq2 = (d31 * c + d32 * sn) * nr / h * area
            rows.append({"load_m": [x, y], "electrode": e["name"], "distance_m": math.hypot(ex - x, ey - y),
                         "beta_deg": math.degrees(math.atan2(sn, c)), "N_r": nr, "N_theta": nt,
                         "charge_fem_C": q_fem, "charge_mean_stress_C": q_mean, "charge_centre_tensor_C": q_centre,
                         "charge_eq2_corrected_C": q_radial, "charge_eq2_printed_C": q_eq2})
    # 2. The table (pC; ratios to the FEM integral).
    print("%-14s %2s %6s %6s %8s %8s %9s %8s %8s %8s %8s" % ("load_mm", "el", "d_mm", "beta", "Nt/Nr", "Q_fem",
          "mean/fem", "ctr/fem", "eq2c/fem", "eq2p/fem", "eq2p/eq2c"))
    for r in rows:
        f = r["charge_fem_C"]
        print("(%5.1f,%5.1f) %2s %6.2f %6.1f %8.3f %8.3f %9.4f %8.4f %8.4f %8.4f %8.4f" % (
            r["load_m"][0] * 1e3, r["load_m"][1] * 1e3, r["electrode"], r["distance_m"] * 1e3, r["beta_deg"],
            r["N_theta"] / r["N_r"], f * 1e12, r["charge_mean_stress_C"] / f, r["charge_centre_tensor_C"] / f,
            r["charge_eq2_corrected_C"] / f, r["charge_eq2_printed_C"] / f,
            r["charge_eq2_printed_C"] / r["charge_eq2_corrected_C"]))
    if out_json:
        json.dump(rows, open(out_json, "w"), indent=1)
    return 0 if rows else 3


if __name__ == "__main__":
    sys.exit(main())
