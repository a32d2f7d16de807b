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
os.makedirs(out)
# An oblique draw direction, so that a wrong rotation into the material axes (sign, transpose,
# degrees for radians) shows: at 0 the material and global frames coincide and any rotation passes.
DRAW_ANGLE_DEG = 35.0
with open(scene) as f:
    scene_json = json.load(f)
scene_json["material"]["draw_angle_deg"] = DRAW_ANGLE_DEG
scene = os.path.join(out, "scene_drawn.json")
with open(scene, "w") as f:
    json.dump(scene_json, f)
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
comp = {"global": ["xx", "yy", "xy"], "material": ["11", "22", "12"], "polar": ["rr", "tt", "rt"]}
required = ["displacement_inplane_m", "w_m", "charge_density_C_per_m2"] + \
    ["N_%s_%s_N_per_m" % (frame, c) for frame, cs in comp.items() for c in cs]
for name in required:
    assert name in names, (name, names)
# deal.II writes cell data as patch-wise constant point data.
eid = cd.GetArray("electrode_id") or pd.GetArray("electrode_id")
assert eid is not None, "electrode_id missing"

w = vtk_to_numpy(pd.GetArray("w_m"))
assert all(math.isfinite(v) for v in w)
# The largest |w| in the file matches the summary (nodal maxima, same field).
assert abs(abs(w).max() - abs(summary["max_deflection_m"])) <= 1e-6 * abs(summary["max_deflection_m"]) + 1e-12, \
    (abs(w).max(), summary["max_deflection_m"])
uv = vtk_to_numpy(pd.GetArray("displacement_inplane_m"))
assert uv.shape[1] in (2, 3) and all(math.isfinite(v) for v in uv.ravel())

# Electrode ids: 0, 1, 2 present (cells whose centre lies on an electrode), -1 for bare film.
ids = set(int(round(v)) for v in vtk_to_numpy(eid))
assert {-1, 0, 1, 2} <= ids, ids

def frame(name):
    return [vtk_to_numpy(pd.GetArray("N_%s_%s_N_per_m" % (name, c))) for c in comp[name]]
ng, nm = frame("global"), frame("material")
# Membrane force in material axes is the global one rotated by the draw angle θ: with the draw
# direction e1 = (cos θ, sin θ) and e2 = (−sin θ, cos θ), N11 = e1·N·e1, N22 = e2·N·e2, N12 = e1·N·e2.
scale = max(abs(x).max() for x in ng)
c, s = math.cos(math.radians(DRAW_ANGLE_DEG)), math.sin(math.radians(DRAW_ANGLE_DEG))
nxx, nyy, nxy = (x.astype(float) for x in ng)
rotated = [c * c * nxx + s * s * nyy + 2 * c * s * nxy,
           s * s * nxx + c * c * nyy - 2 * c * s * nxy,
           c * s * (nyy - nxx) + (c * c - s * s) * nxy]
for k, (a, b) in enumerate(zip(rotated, nm)):
    # float32 storage in the VTU: ~1e-7 of the largest force.
    assert abs(a - b.astype(float)).max() <= 1e-5 * scale, (k, abs(a - b).max() / scale)
# And the rotation is not the identity here (the check above could not pass by accident).
assert abs(ng[0].astype(float) - nm[0].astype(float)).max() > 1e-2 * scale
# Charge density = (d31 N11 + d32 N22)/h (the VTU stores 32-bit floats: ~1e-7 relative).
q = vtk_to_numpy(pd.GetArray("charge_density_C_per_m2")).astype(float)
expect = (6.5e-12 * nm[0].astype(float) + 0.65e-12 * nm[1].astype(float)) / 25e-6
assert abs(q - expect).max() <= 1e-5 * abs(expect).max(), abs(q - expect).max() / abs(expect).max()
# Polar frame about the centred load: invariants of the tensor equal those of the global one.
npol = frame("polar")
trace_g, trace_p = ng[0] + ng[1], npol[0] + npol[1]
assert abs(trace_g - trace_p).max() <= 1e-5 * scale
det_g = ng[0] * ng[1] - ng[2] ** 2
det_p = npol[0] * npol[1] - npol[2] ** 2
assert abs(det_g - det_p).max() <= 1e-5 * scale ** 2

# The PVD collection opens and names the VTU.
pvd = vtk.vtkPVDReader() if hasattr(vtk, "vtkPVDReader") else None
with open(os.path.join(out, "film.pvd")) as f:
    text = f.read()
assert "film_cycle0.vtu" in text
print("VTU ok:", vtu, grid.GetNumberOfPoints(), "points;", names)
