#!/usr/bin/env python3
"""The VTU of `pvdfkit solve --vtu` in ParaView itself (Debian's `paraview` + `python3-paraview`, run
by `pvbatch` offscreen under Xvfb): it opens as ONE connected mesh (Connectivity: one region), Warp
By Vector takes `displacement_m` as it is (no Calculator), `electrode_id` is cell data, and a PNG is
rendered of the warped film coloured by w.

Usage: paraview_vtu.py PVDFKIT SCENE OUTDIR
Exit 77 (ctest SKIP_RETURN_CODE) with a message when ParaView (pvbatch) or Xvfb (its offscreen X
server) is absent: `scripts/install-deps` installs them (not with --no-paraview)."""
import json
import os
import shutil
import subprocess
import sys
import textwrap
import time

SKIP = 77


def skip(why):
    print("SKIPPED: " + why + "; scripts/install-deps installs ParaView (Debian paraview python3-paraview "
          "xvfb xauth) unless given --no-paraview")
    sys.exit(SKIP)


# Runs inside pvbatch (ParaView's Python); prints one JSON line of what ParaView saw.
PARAVIEW_SCRIPT = textwrap.dedent(r'''
    import json, sys
    from paraview.simple import *
    from vtkmodules.vtkIOImage import vtkPNGReader
    from vtkmodules.util.numpy_support import vtk_to_numpy
    vtu, png = sys.argv[1], sys.argv[2]
    reader = XMLUnstructuredGridReader(FileName=[vtu])
    reader.UpdatePipeline()
    info = reader.GetDataInformation()
    conn = Connectivity(Input=reader)
    conn.UpdatePipeline()
    region_range = conn.PointData["RegionId"].GetRange()
    w_range = reader.PointData["w_m"].GetRange()
    disp = reader.PointData["displacement_m"]
    scale = 5.0  # w is ~1/20 of the radius: exaggerate it for the picture
    warp = WarpByVector(Input=reader)
    warp.Vectors = ["POINTS", "displacement_m"]
    warp.ScaleFactor = scale
    warp.UpdatePipeline()
    bounds = warp.GetDataInformation().GetBounds()
    view = GetActiveViewOrCreate("RenderView")
    view.ViewSize = [900, 600]
    view.OrientationAxesVisibility = 0
    shown = Show(warp, view)
    ColorBy(shown, ("POINTS", "w_m"))
    shown.SetRepresentationType("Surface With Edges")
    shown.SetScalarBarVisibility(view, True)
    view.CameraPosition = [0.09, -0.12, 0.10]
    view.CameraFocalPoint = [0.0, 0.0, -0.002]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.ResetCamera()
    view.GetActiveCamera().Dolly(1.8)
    Render(view)
    SaveScreenshot(png, view, ImageResolution=[900, 600])
    image = vtkPNGReader()
    image.SetFileName(png)
    image.Update()
    pixels = vtk_to_numpy(image.GetOutput().GetPointData().GetScalars())
    background = pixels[0]
    differs = (abs(pixels[:, :3].astype(int) - background[:3].astype(int)).sum(axis=1) > 30).mean()
    print("PVRESULT " + json.dumps({
        "n_points": info.GetNumberOfPoints(), "n_cells": info.GetNumberOfCells(),
        "regions": list(region_range), "w_range": list(w_range),
        "displacement_components": disp.GetNumberOfComponents(),
        "cell_arrays": list(reader.CellData.keys()), "point_arrays": list(reader.PointData.keys()),
        "warped_z": [bounds[4], bounds[5]], "scale": scale,
        "image_size": list(image.GetOutput().GetDimensions()), "share_not_background": float(differs)}))
''')


def start_xvfb(xvfb):
    """An Xvfb on the first free display from :80; waits until its socket exists (60 s at most)."""
    for n in range(80, 200):
        if os.path.exists("/tmp/.X%d-lock" % n) or os.path.exists("/tmp/.X11-unix/X%d" % n):
            continue
        # -noreset: by default the server resets when its last client leaves, and pvbatch, which
        # connects more than once, then failed about half the time with "bad X server connection".
        server = subprocess.Popen([xvfb, ":%d" % n, "-screen", "0", "1280x1024x24", "-nolisten", "tcp", "-noreset"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        for _ in range(600):
            if os.path.exists("/tmp/.X11-unix/X%d" % n):
                return ":%d" % n, server
            if server.poll() is not None:
                break  # lost the display to another server: try the next one
            time.sleep(0.1)
        if server.poll() is None:
            server.terminate()
            server.wait(timeout=30)
    raise AssertionError("could not start Xvfb on any display :80..:199")


def main():
    pvdfkit, scene, out = sys.argv[1], sys.argv[2], sys.argv[3]
    pvbatch = shutil.which("pvbatch")
    if pvbatch is None:
        skip("ParaView's pvbatch is not on PATH")
    # Debian's ParaView renders through X (no EGL/OSMesa build): an Xvfb of our own provides one
    # offscreen (started here rather than by xvfb-run, which gives no -noreset).
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        skip("no Xvfb for ParaView's offscreen rendering")
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    run = subprocess.run([pvdfkit, "solve", scene, "--vtu", out, "--json"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    vtu = os.path.join(out, "film_cycle0.vtu")
    png = os.path.join(out, "film_warped.png")
    script = os.path.join(out, "paraview_script.py")
    with open(script, "w") as f:
        f.write(PARAVIEW_SCRIPT)
    display, server = start_xvfb(xvfb)
    try:
        env = dict(os.environ, DISPLAY=display)
        pv = subprocess.run([pvbatch, script, vtu, png], capture_output=True, text=True, timeout=300, env=env)
    finally:
        server.terminate()
        server.wait(timeout=30)
    lines = [l for l in pv.stdout.splitlines() if l.startswith("PVRESULT ")]
    assert pv.returncode == 0 and lines, "pvbatch failed (exit %d):\n%s\n%s" % (pv.returncode, pv.stdout, pv.stderr[-3000:])
    seen = json.loads(lines[-1][len("PVRESULT "):])
    print("ParaView saw:", json.dumps(seen))
    # One connected mesh: the Connectivity filter numbers a single region (RegionId 0 everywhere).
    assert seen["regions"] == [0.0, 0.0], seen["regions"]
    assert seen["n_cells"] == summary["n_cells"], (seen["n_cells"], summary["n_cells"])
    assert seen["n_points"] < 0.5 * 9 * seen["n_cells"], seen["n_points"]
    assert seen["displacement_components"] == 3
    assert "electrode_id" in seen["cell_arrays"] and "electrode_id" not in seen["point_arrays"]
    # Warp By Vector moved the points by scale x displacement_m: the warped z extent is scale x w's range.
    w_lo, w_hi = seen["w_range"]
    assert abs(max(abs(w_lo), abs(w_hi)) - abs(summary["max_deflection_m"])) <= 1e-9, (seen["w_range"], summary)
    z_lo, z_hi = seen["warped_z"]
    s = seen["scale"]
    tol = 1e-6 * s * max(abs(w_lo), abs(w_hi))
    assert abs(z_lo - s * w_lo) <= tol and abs(z_hi - s * w_hi) <= tol, (seen["warped_z"], seen["w_range"])
    # A picture was rendered: the film covers a good part of it.
    assert seen["image_size"][:2] == [900, 600], seen["image_size"]
    assert seen["share_not_background"] > 0.1, seen["share_not_background"]
    print("ParaView: one connected region, %d points, %d Lagrange cells, warped by displacement_m; %s"
          % (seen["n_points"], seen["n_cells"], png))
    return 0


if __name__ == "__main__":
    sys.exit(main())
