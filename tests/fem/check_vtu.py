#!/usr/bin/env python3
"""Runs `pvdfkit solve SCENE --vtu DIR --json` and opens the VTU and PVD with VTK's own readers
(Debian python3-vtk9): one connected mesh of Lagrange quadrilaterals (one per solver cell), named
fields with SI units, displacement_m as a 3-vector, electrode_id as cell data, and values consistent
with the JSON summary."""
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
n_points, n_cells = grid.GetNumberOfPoints(), grid.GetNumberOfCells()
assert n_points > 0 and n_cells > 0
# One VTK cell per solver cell (the scene asks for no refinement: the first mesh is the final one),
# each a degree-2 Lagrange quadrilateral (VTK type 70, 9 nodes) — no sub-cells.
assert n_cells == summary["n_cells"], (n_cells, summary["n_cells"])
types = {grid.GetCellType(c) for c in range(n_cells)}
assert types == {vtk.VTK_LAGRANGE_QUADRILATERAL}, types
assert all(grid.GetCell(c).GetNumberOfPoints() == 9 for c in range(n_cells))
# One connected mesh: no two points at the same place, and VTK's connectivity filter finds one region.
xyz = vtk_to_numpy(grid.GetPoints().GetData()).astype(float)
R = 0.045
keys = set(map(tuple, (xyz / (1e-9 * R)).round().astype(int)))
assert len(keys) == n_points, ("duplicate points", n_points - len(keys))
conn = vtk.vtkConnectivityFilter()
conn.SetInputData(grid)
conn.SetExtractionModeToAllRegions()
conn.Update()
assert conn.GetNumberOfExtractedRegions() == 1, conn.GetNumberOfExtractedRegions()
# Far fewer points than 9 per cell: neighbours share their nodes (a disconnected Q2 mesh has 9 n_cells).
assert n_points < 0.5 * 9 * n_cells, (n_points, n_cells)
# Coordinates in metres: the film of radius 45 mm, in the plane z = 0.
radius = (xyz[:, 0] ** 2 + xyz[:, 1] ** 2) ** 0.5
assert abs(radius.max() - R) < 1e-9 * R and abs(xyz[:, 2]).max() == 0.0, (radius.max(), abs(xyz[:, 2]).max())

pd, cd = grid.GetPointData(), grid.GetCellData()
names = [pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())]
comp = {"global": ["xx", "yy", "xy"], "material": ["11", "22", "12"], "polar": ["rr", "tt", "rt"]}
required = ["displacement_m", "displacement_inplane_m", "w_m", "charge_density_C_per_m2"] + \
    ["N_%s_%s_N_per_m" % (frame, c) for frame, cs in comp.items() for c in cs]
for name in required:
    assert name in names, (name, names)
# Every field carries its SI unit in its name.
for name in names:
    assert name.endswith(("_m", "_N_per_m", "_C_per_m2")), name
assert pd.GetVectors() is not None and pd.GetVectors().GetName() == "displacement_m"
# electrode_id is cell data (one integer per cell), not point data.
assert pd.GetArray("electrode_id") is None
eid = cd.GetArray("electrode_id")
assert eid is not None and eid.GetNumberOfTuples() == n_cells and eid.GetDataType() == vtk.VTK_INT, "electrode_id"

w = vtk_to_numpy(pd.GetArray("w_m"))
assert all(math.isfinite(v) for v in w)
# The largest |w| in the file matches the summary (nodal maxima, same field).
assert abs(abs(w).max() - abs(summary["max_deflection_m"])) <= 1e-6 * abs(summary["max_deflection_m"]) + 1e-12, \
    (abs(w).max(), summary["max_deflection_m"])
uv = vtk_to_numpy(pd.GetArray("displacement_inplane_m"))
assert uv.shape[1] == 3 and all(math.isfinite(v) for v in uv.ravel()) and abs(uv[:, 2]).max() == 0.0
# displacement_m = (u_x, u_y, w): the vector Warp By Vector takes, its parts the other two fields.
d = vtk_to_numpy(pd.GetArray("displacement_m"))
assert d.shape == (n_points, 3), d.shape
assert abs(d[:, :2] - uv[:, :2]).max() == 0.0 and abs(d[:, 2] - w).max() == 0.0
# The largest deflection lies under the centred load; in-plane displacements are far smaller than w.
assert abs(uv).max() < 0.2 * abs(w).max(), (abs(uv).max(), abs(w).max())
centre = ((xyz[:, 0] ** 2 + xyz[:, 1] ** 2) < (0.002) ** 2)
assert abs(w[centre]).max() >= 0.95 * abs(w).max()

# Electrode ids: 0, 1, 2 present (cells whose centre lies on an electrode), -1 for bare film; the
# centroid of every cell marked k lies on electrode k (2 mm squares of the scene).
ids = vtk_to_numpy(eid)
assert set(ids.tolist()) == {-1, 0, 1, 2}, set(ids.tolist())
electrodes = [e["center_m"] for e in scene_json["electrodes"]]
for c in range(n_cells):
    if ids[c] < 0:
        continue
    corners = xyz[[grid.GetCell(c).GetPointId(k) for k in range(4)], :2].mean(axis=0)
    ex, ey = electrodes[ids[c]]
    assert abs(corners[0] - ex) <= 0.001 + 1e-12 and abs(corners[1] - ey) <= 0.001 + 1e-12, (c, ids[c], corners)

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
    # float64 storage in the VTU; round-off of the rotation only.
    assert abs(a - b.astype(float)).max() <= 1e-9 * scale, (k, abs(a - b).max() / scale)
# And the rotation is not the identity here (the check above could not pass by accident).
assert abs(ng[0].astype(float) - nm[0].astype(float)).max() > 1e-2 * scale
# Charge density = (d31 N11 + d32 N22)/h.
q = vtk_to_numpy(pd.GetArray("charge_density_C_per_m2")).astype(float)
expect = (6.5e-12 * nm[0].astype(float) + 0.65e-12 * nm[1].astype(float)) / 25e-6
assert abs(q - expect).max() <= 1e-9 * abs(expect).max(), abs(q - expect).max() / abs(expect).max()
# Polar frame about the centred load: invariants of the tensor equal those of the global one.
npol = frame("polar")
trace_g, trace_p = ng[0] + ng[1], npol[0] + npol[1]
assert abs(trace_g - trace_p).max() <= 1e-9 * scale
det_g = ng[0] * ng[1] - ng[2] ** 2
det_p = npol[0] * npol[1] - npol[2] ** 2
assert abs(det_g - det_p).max() <= 1e-9 * scale ** 2

# The PVD collection opens and names the VTU.
pvd = vtk.vtkPVDReader() if hasattr(vtk, "vtkPVDReader") else None
with open(os.path.join(out, "film.pvd")) as f:
    text = f.read()
assert "film_cycle0.vtu" in text
print("VTU ok:", vtu, n_points, "points,", n_cells, "cells, one region;", names)
