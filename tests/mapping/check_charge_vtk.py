#!/usr/bin/env python3
"""charges.vtk of `pvdfkit isocharge` opened with VTK's own legacy reader (python3-vtk9): grid,
spacing, NaN exactly where the map has no value, and node values equal to an independent
evaluation of the analytic stand-in model (pvdf::mapping::SyntheticModel defaults) in C, fields
named by electrode and force level (`charge_A_C_at_1N`).
Usage: check_charge_vtk.py PVDFKIT WORKDIR"""
import math
import os
import subprocess
import sys

import vtk


def model_C(x, y, k):
    # SyntheticModel defaults (mapping/studies/include/pvdf/mapping/synthetic.hpp), F = 1 N, draw angle 0.
    centres = [(0.0, 0.010), (-0.00866025403784439, -0.005), (0.00866025403784439, -0.005)]
    R, scale, core, expo, aniso, r, rim = 0.045, 6.0e-13, 0.002, 0.8, 1.3, 0.1, 0.5
    u, v = x - centres[k][0], y - centres[k][1]
    a = math.sqrt(aniso)
    rho2 = (u / a) ** 2 + (v * a) ** 2
    piezo = (u * u + r * v * v + 0.5 * (1 + r) * core ** 2) / (u * u + v * v + core ** 2)
    return scale * (1 - rim * (x * x + y * y) / R ** 2) * piezo * (rho2 + core ** 2) ** (-expo / 2)


def main():
    pvdfkit, work = sys.argv[1], sys.argv[2]
    os.makedirs(work, exist_ok=True)
    m = os.path.join(work, "map.h5")
    subprocess.run([pvdfkit, "synthetic-map", "-o", m, "--spacing-m", "0.003"], check=True, capture_output=True)
    subprocess.run([pvdfkit, "isocharge", m, "--out-dir", work], check=True, capture_output=True)
    reader = vtk.vtkStructuredPointsReader()
    reader.SetFileName(os.path.join(work, "charges.vtk"))
    reader.ReadAllScalarsOn()
    reader.Update()
    img = reader.GetOutput()
    nx, ny, nz = img.GetDimensions()
    assert (nx, ny, nz) == (31, 31, 1), img.GetDimensions()
    assert abs(img.GetSpacing()[0] - 0.003) < 1e-12 and abs(img.GetOrigin()[0] + 0.045) < 1e-12
    pd = img.GetPointData()
    mask = pd.GetArray("mask")
    worst = 0.0
    for name, k in (("A", 0), ("B", 1), ("C", 2)):
        arr = pd.GetArray("charge_%s_C_at_1N" % name)
        assert arr is not None and arr.GetNumberOfTuples() == nx * ny, name
        for j in range(ny):
            for i in range(nx):
                p = j * nx + i
                value, inside = arr.GetValue(p), mask.GetValue(p) == 1
                assert inside == (not math.isnan(value)), (name, i, j, value)
                if inside:
                    x, y = img.GetOrigin()[0] + i * 0.003, img.GetOrigin()[1] + j * 0.003
                    worst = max(worst, abs(value / model_C(x, y, k) - 1))
    assert worst < 1e-12, worst
    names = sorted(pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays()))
    assert names == ["charge_A_C_at_1N", "charge_B_C_at_1N", "charge_C_C_at_1N", "mask"], names
    print("charges.vtk read by VTK: %d x %d, NaN outside the mask, max relative deviation %.2g" % (nx, ny, worst))
    return 0


if __name__ == "__main__":
    sys.exit(main())
