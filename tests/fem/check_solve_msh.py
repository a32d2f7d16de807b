#!/usr/bin/env python3
"""`pvdfkit solve SCENE --mesh film.msh` on the Gmsh mesh `pvdfkit mesh SCENE` wrote equals the
built-in mesh's answer within the two solves' error estimates: every electrode charge and the
deflection under the load, each difference relative to its own scale (the scale of the estimate,
docs/fem.md §6). The first solve of the --mesh run is on the file's cells exactly (its cycle-0 VTU has
the .msh's cell count), and the estimates are small enough for the comparison to mean something.

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
    for r in (builtin, onmsh):
        assert r["status"] == "converged", (r["status"], r["message"])
    assert builtin["mesh"] == "built-in" and onmsh["mesh"] == msh
    assert onmsh["mesh_file_cells"] == mesh["n_cells"], (onmsh["mesh_file_cells"], mesh["n_cells"])
    with open(os.path.join(vtu_dir, "film_cycle0.vtu")) as f:
        head = f.read(4000)
    cycle0_cells = int(re.search(r'NumberOfCells="(\d+)"', head).group(1))
    assert cycle0_cells == mesh["n_cells"], (cycle0_cells, mesh["n_cells"])

    e1, e2 = builtin["estimated_relative_error"], onmsh["estimated_relative_error"]
    allowed = e1 + e2
    assert allowed < 0.02, (e1, e2)
    q1 = [e["charge_C"] for e in builtin["electrodes"]]
    q2 = [e["charge_C"] for e in onmsh["electrodes"]]
    scale_q = max(abs(q) for q in q1)
    charge_diff = max(abs(a - b) for a, b in zip(q1, q2)) / scale_q
    w1, w2 = builtin["deflection_at_load_m"], onmsh["deflection_at_load_m"]
    w_diff = abs(w1 - w2) / abs(w1)
    print("mesh %d quads; built-in: %d cells, estimate %.3g; --mesh: %d cells, estimate %.3g"
          % (mesh["n_cells"], builtin["n_cells"], e1, onmsh["n_cells"], e2))
    print("charges (pC) built-in %s, --mesh %s: max difference %.3g of the largest"
          % (["%.4f" % (q * 1e12) for q in q1], ["%.4f" % (q * 1e12) for q in q2], charge_diff))
    print("deflection at the load %.6g mm vs %.6g mm: difference %.3g; allowed (sum of the estimates) %.3g"
          % (w1 * 1e3, w2 * 1e3, w_diff, allowed))
    assert charge_diff <= allowed, (charge_diff, allowed)
    assert w_diff <= allowed, (w_diff, allowed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
