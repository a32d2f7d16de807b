#!/usr/bin/env python3
"""`pvdfkit solve SCENE --mesh film.msh` on the Gmsh mesh `pvdfkit mesh SCENE` wrote against the
built-in mesh's answer, compared with the two solves' error estimates on the quantities the estimate
is defined on (docs/fem.md §6): the electrodes' mean membrane forces (material axes, relative to the
largest) and the deflection under the load; the charges are printed beside them. The first solve of
the --mesh run is on the file's cells exactly (its cycle-0 VTU has the .msh's cell count).

The two solves use the same model, so their difference is discretization error alone: each output
(the charges, relative to the largest, and the deflection under the load) must agree within the sum
of the two solves' estimated discretization errors (`estimated_discretization_error`, the largest
relative dual-weighted-residual estimate over those outputs). On the file's mesh, whose cells are
unrefined (no patches for the Q3 extrapolation of the adjoint), the adjoint is solved in Q3 itself.
The electrodes' mean membrane forces are printed beside them (not an estimated quantity).

Usage: check_solve_msh.py PVDFKIT SCENE OUTDIR"""
import json
import os
import re
import shutil
import subprocess
import sys


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, (cmd, r.returncode, r.stderr)
    return r.stdout


def main():
    pvdfkit, scene, out = sys.argv[1], sys.argv[2], sys.argv[3]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    msh = os.path.join(out, "film.msh")
    mesh = json.loads(run([pvdfkit, "mesh", scene, "-o", msh, "--json", "--no-preview"]))
    with open(msh) as f:
        assert f.readline().strip() == "$MeshFormat" and f.readline().split()[0] == "4.1"
    builtin = json.loads(run([pvdfkit, "solve", scene, "--json"]))
    vtu_dir = os.path.join(out, "vtu")
    onmsh = json.loads(run([pvdfkit, "solve", scene, "--mesh", msh, "--json", "--vtu", vtu_dir]))
    for name, r in (("builtin.json", builtin), ("msh.json", onmsh)):
        with open(os.path.join(out, name), "w") as f:
            json.dump(r, f, indent=1)
    for r in (builtin, onmsh):
        assert r["status"] == "converged", (r["status"], r["message"])
    assert builtin["mesh"] == "built-in" and onmsh["mesh"] == msh
    assert onmsh["mesh_file_cells"] == mesh["n_cells"], (onmsh["mesh_file_cells"], mesh["n_cells"])
    with open(os.path.join(vtu_dir, "film_cycle0.vtu"), "rb") as f:
        head = f.read(4000).decode("ascii", errors="replace")  # XML header, then raw binary
    cycle0_cells = int(re.search(r'NumberOfCells="(\d+)"', head).group(1))
    assert cycle0_cells == mesh["n_cells"], (cycle0_cells, mesh["n_cells"])

    e1, e2 = builtin["estimated_discretization_error"], onmsh["estimated_discretization_error"]
    assert 0 < e1 < 2e-3 and 0 < e2 < 2e-3, ("each solve must carry a discretization estimate", e1, e2)
    allowed = e1 + e2
    f1 = [x for e in builtin["electrodes"] for x in e["mean_membrane_force_material_N_per_m"]]
    f2 = [x for e in onmsh["electrodes"] for x in e["mean_membrane_force_material_N_per_m"]]
    force_diff = max(abs(a - b) for a, b in zip(f1, f2)) / max(abs(a) for a in f1)
    q1 = [e["charge_C"] for e in builtin["electrodes"]]
    q2 = [e["charge_C"] for e in onmsh["electrodes"]]
    charge_diff = max(abs(a - b) for a, b in zip(q1, q2)) / max(abs(q) for q in q1)
    w1, w2 = builtin["deflection_at_load_m"], onmsh["deflection_at_load_m"]
    w_diff = abs(w1 - w2) / abs(w1)
    print("mesh %d quads; built-in: %d cells, discretization estimate %.3g; --mesh: %d cells, estimate %.3g"
          % (mesh["n_cells"], builtin["n_cells"], e1, onmsh["n_cells"], e2))
    print("charges (pC) built-in %s, --mesh %s: max difference %.3g of the largest"
          % (["%.4f" % (q * 1e12) for q in q1], ["%.4f" % (q * 1e12) for q in q2], charge_diff))
    print("deflection at the load %.6g mm vs %.6g mm: difference %.3g" % (w1 * 1e3, w2 * 1e3, w_diff))
    print("electrode mean forces: max difference %.3g of the largest (not estimated)" % force_diff)
    print("difference / (sum of the discretization estimates %.3g): charges %.2f, deflection %.2f (allowed 1)"
          % (allowed, charge_diff / allowed, w_diff / allowed))
    for what, d in (("charges", charge_diff), ("deflection", w_diff)):
        assert d <= allowed, (what, d, allowed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
