"""pvdfkit.solve and ProbeSweep against Timoshenko's clamped plate and equilibrium."""
import math

import numpy as np
import pytest

import pvdfkit


def test_the_solver_is_built():
    assert pvdfkit.has_fem, "pvdfkit was built without the FEM modules; ctest registers this file only with them"

A, H, E, NU, C = 0.045, 1e-3, 2e9, 0.3, 4e-3


def plate_scene(force_N=0.01):
    """An isotropic 1 mm plate (bending dominated: the linear plate oracle applies)."""
    return {
        "membrane": {"radius_m": A, "thickness_m": H},
        "material": {"E_Pa": E, "nu": NU, "d31_C_per_N": 6.5e-12, "d32_C_per_N": 6.5e-12},
        "electrodes": [{"name": "ring", "shape": "circle", "center_m": [0.012, 0.0], "radius_m": 0.003},
                       {"name": "mirror", "shape": "circle", "center_m": [-0.012, 0.0], "radius_m": 0.003}],
        "probe": {"radius_m": C},
        "loads": [{"position_m": [0.0, 0.0], "force_N": force_N}],
    }


def timoshenko_disk_load_centre_m(P):
    """Clamped circular plate, load P spread over r < c (Timoshenko & Woinowsky-Krieger §19)."""
    D = E * H**3 / (12 * (1 - NU**2))
    return P / (16 * math.pi * D) * (A**2 - 0.75 * C**2 + C**2 * math.log(C / A))


def test_linear_plate_centre_deflection_matches_timoshenko():
    F = 0.01
    r = 0.004
    samples = [[0, 0], [r, 0], [0, r], [-r, 0], [0, -r]]
    res = pvdfkit.solve(plate_scene(F), samples=samples, model="linear", tolerance=2e-3)
    assert res.ok and res.status in ("converged", "tolerance-not-met")
    exact = timoshenko_disk_load_centre_m(F)
    assert res.deflection_at_load_m == pytest.approx(exact, rel=5e-3)
    # The estimate is honest: the true error is below 3x the estimated one (or below 1e-3).
    true_err = abs(res.deflection_at_load_m - exact) / abs(exact)
    assert true_err < max(3 * res.estimated_relative_error, 1e-3)
    # Shapes and units of the sample fields.
    assert res.sample_position_m.shape == (5, 2)
    assert res.displacement_m.shape == (5, 3)
    assert res.membrane_force_global_N_per_m.shape == (5, 3)
    assert res.deflection_m[0] == pytest.approx(res.deflection_at_load_m, rel=1e-9)
    # Isotropic plate, centred load: w is axisymmetric.
    ring = res.deflection_m[1:]
    assert np.ptp(ring) < 1e-3 * abs(ring.mean())
    # Equilibrium: the clamped rim carries the applied force.
    assert res.rim_reaction_N == pytest.approx(F, rel=1e-6)
    assert res.load_force_N == pytest.approx([F])
    # Linear plate theory leaves the mid-surface unstretched: no membrane force, no charge.
    assert res.electrode_names == ["ring", "mirror"]
    assert res.charge_C.shape == (2,)
    assert np.all(res.charge_C == 0)


def test_loads_argument_and_linearity():
    """A linear model: twice the force gives twice the deflection."""
    one = pvdfkit.solve(plate_scene(), loads=[[0.005, 0.002, 0.01]], model="linear", tolerance=5e-3)
    two = pvdfkit.solve(plate_scene(), loads=[[0.005, 0.002, 0.02]], model="linear", tolerance=5e-3)
    assert one.load_position_m == pytest.approx(np.array([[0.005, 0.002]]))
    assert two.deflection_at_load_m == pytest.approx(2 * one.deflection_at_load_m, rel=1e-2)


def test_bad_arguments_raise_input_errors():
    with pytest.raises(pvdfkit.InputError, match="tolerance"):
        pvdfkit.solve(plate_scene(), tolerance=2.0)
    with pytest.raises(pvdfkit.InputError, match="model"):
        pvdfkit.solve(plate_scene(), model="quadratic")
    with pytest.raises(pvdfkit.InputError, match="n x 3"):
        pvdfkit.solve(plate_scene(), loads=[[0.0, 1.0]])
    with pytest.raises(pvdfkit.InputError, match="n x 2"):
        pvdfkit.solve(plate_scene(), samples=[[0.0, 1.0, 2.0]])


def test_physical_bounds_refuse_before_any_work():
    """Issue 30 item 2: absurd films and presses are refused naming the key, the value and the fix
    (docs/scene.md "Physical bounds"), before a solve starts."""
    def patched(**sections):
        s = plate_scene()
        for key, value in sections.items():
            s[key] = {**s[key], **value} if isinstance(value, dict) else value
        return s
    cases = [
        (dict(material={"E_Pa": 1e-30}), r"material\.E_Pa .*check the unit"),
        (dict(material={"E_Pa": 2e3}), r"material\.E_Pa"),                      # MPa written as Pa
        (dict(material={"nu": -0.99}), r"material\.nu"),                         # compliance nearly singular
        (dict(membrane={"radius_m": A, "thickness_m": H, "pretension_N_per_m": -1e9}), r"pretension_N_per_m"),
        (dict(loads=[{"position_m": [0.0, 0.0], "force_N": 1e-300}]), r"loads\[0\]\.force_N"),
        (dict(probe={"radius_m": A}), r"probe\.radius_m"),                        # a probe as large as the film
    ]
    for sections, message in cases:
        with pytest.raises(pvdfkit.InputError, match=message):
            pvdfkit.solve(patched(**sections))
    # A press too small for a stiff, thick film: its deflection would be lost to rounding.
    stiff = patched(membrane={"radius_m": A, "thickness_m": 0.01}, material={"E_Pa": 1e12, "nu": 0.3})
    with pytest.raises(pvdfkit.InputError, match=r"lost to rounding\); use a force >="):
        pvdfkit.solve(stiff, loads=[[0.0, 0.0, 1e-6]])
    # A press outside the film, and one whose footprint touches the rim.
    with pytest.raises(pvdfkit.InputError, match=r"loads\[0\]"):
        pvdfkit.solve(plate_scene(), loads=[[0.06, 0.0, 0.01]])
    with pytest.raises(pvdfkit.InputError, match=r"loads\[0\]"):
        pvdfkit.solve(plate_scene(), loads=[[0.0, A - C, 0.01]])


def test_probe_sweep_equals_direct_solves_within_its_estimate():
    scene = pvdfkit.default_scene()
    sweep = pvdfkit.ProbeSweep(scene, tolerance=0.02, n_setup_checks=1)
    setup = sweep.setup
    assert setup["n_dofs"] > 0 and 0 < setup["estimated_relative_error"] < 0.1
    x = np.array([0.0, 0.004, -0.004])
    y = np.array([0.0, 0.003, 0.003])
    out = sweep.solve(x, y, 1.0)
    assert len(out) == 3 and out.ok.all()
    assert out.charge_C.shape == (3, 3)
    assert out.rim_reaction_N == pytest.approx(np.ones(3), rel=1e-6)
    # Seed 001 is mirror-symmetric about x = 0 (draw along x, A on the axis, B and C mirrored):
    # a press at (-x, y) gives A the same charge and swaps B and C.
    tol = 2 * max(setup["estimated_relative_error"], 0.005)
    mirrored = out.charge_C[2][[0, 2, 1]]
    assert np.abs(mirrored - out.charge_C[1]).max() < tol * np.abs(out.charge_C[1]).max()
    assert out.charge_C[0, 1] == pytest.approx(out.charge_C[0, 2], rel=tol)
    direct = pvdfkit.solve(scene, loads=[[x[1], y[1], 1.0]], tolerance=0.01)
    scale = np.abs(direct.charge_C).max()
    err = np.abs(out.charge_C[1] - direct.charge_C).max() / scale
    assert err < 3 * max(setup["estimated_relative_error"], 0.01)
    with pytest.raises(pvdfkit.InputError):
        sweep.solve([0.0, 0.0], [0.0, 0.0, 0.0], 1.0)


def test_generate_map_agrees_with_direct_solves(tmp_path):
    """A small FEM map: its charges at a grid node equal a direct solve there within the estimates."""
    scene = pvdfkit.default_scene()
    cmap, report = pvdfkit.generate_map(scene, spacing_m=0.006, forces_N=[1.0], region_m=(-0.006, 0.006, -0.006, 0.006),
                                        tolerance=0.02, n_setup_checks=1, threads=1)
    assert (cmap.nx, cmap.ny, cmap.nf, cmap.n_electrodes) == (3, 3, 1, 3)
    assert report["n_failed"] == 0 and report["n_positions"] == 9
    assert cmap.charge_C.shape == (1, 3, 3, 3) and (cmap.status == 0).all()
    i, j = 2, 1  # node (6 mm, 0)
    assert (cmap.x_m[i], cmap.y_m[j]) == pytest.approx((0.006, 0.0))
    direct = pvdfkit.solve(scene, loads=[[0.006, 0.0, 1.0]], tolerance=0.01)
    q_map = cmap.charge_C[0, j, i]
    tol = 3 * max(cmap.estimated_relative_error, direct.estimated_relative_error, 0.005)
    assert np.abs(q_map - direct.charge_C).max() < tol * np.abs(direct.charge_C).max()
    assert cmap.deflection_at_load_m[0, j, i] == pytest.approx(direct.deflection_at_load_m, rel=0.05)
    path = tmp_path / "fem.h5"
    pvdfkit.write_map(str(path), cmap)
    back = pvdfkit.read_map(str(path))
    assert np.array_equal(back.charge_C, cmap.charge_C) and back.model == cmap.model
    # `pvdfkit map` with the same settings: the report has the keys of its --json (setup_s is the one
    # key the command does not print; output and mesh are the command's own), the same counts and charges.
    import json
    import os
    import subprocess
    cli = os.path.join(os.environ.get("PVDF_BINARY_DIR", ""), "app", "pvdfkit")
    if not os.path.exists(cli):
        pytest.fail("PVDF_BINARY_DIR/app/pvdfkit not found: run through ctest (tests/python/CMakeLists.txt)")
    scene_path = tmp_path / "scene.json"
    scene_path.write_text(json.dumps(scene.to_dict()))
    out = subprocess.run([cli, "map", str(scene_path), "-o", str(tmp_path / "cli.h5"), "--spacing-m", "0.006",
                          "--forces-N", "1", "--region", "-0.006,0.006,-0.006,0.006", "--tolerance", "0.02",
                          "--setup-checks", "1", "--threads", "1", "--no-checkpoint", "--quiet", "--json"],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    cl = json.loads(out.stdout)
    # peak_resident_bytes is the command process's memory, not a property of the map: not in Python's report
    assert set(report) - {"setup_s"} == set(cl) - {"output", "mesh", "peak_resident_bytes"}
    # Every key of both (times, the rates derived from them and the checkpoint's file hash aside) has the same value.
    from same_json import assert_same_json
    timing = {k for k in report if k.endswith("_s")} | {"estimate_share", "cpu_s_per_solve", "checkpoint_hash"}
    assert_same_json({k: v for k, v in report.items() if k not in timing | {"setup_s"}},
                     {k: cl[k] for k in report if k not in timing | {"setup_s"}}, rel=1e-9)
    cli_map = pvdfkit.read_map(str(tmp_path / "cli.h5"))
    assert np.allclose(cli_map.charge_C, cmap.charge_C, rtol=1e-9, atol=0)


def test_to_dict_is_the_command_line_json(tmp_path):
    """SolveResult.to_dict() and `pvdfkit solve --json` on the same scene, load and samples: the same
    keys and the same numbers (the solver is deterministic; timings and the command's mesh keys aside).
    A key added to one and not the other, or a field copied wrongly, fails here."""
    import json
    import os
    import subprocess
    binary = os.environ.get("PVDF_BINARY_DIR")
    cli = os.path.join(binary, "app", "pvdfkit") if binary else None
    if not cli or not os.path.exists(cli):
        pytest.fail("PVDF_BINARY_DIR/app/pvdfkit not found: run through ctest (tests/python/CMakeLists.txt)")
    scene = plate_scene(0.5)
    scene["membrane"]["thickness_m"] = 50e-6  # membrane-dominated: non-zero charges and estimates
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    result = pvdfkit.solve(scene, samples=[[0.004, 0.0]], tolerance=0.02)
    py = result.to_dict()
    out = subprocess.run([cli, "solve", str(path), "--sample", "0.004,0", "--tolerance", "0.02", "--json"],
                         capture_output=True, text=True, check=True)
    cl = json.loads(out.stdout)
    assert set(py) == set(cl) - {"mesh", "mesh_file_cells", "peak_resident_bytes"}  # the command process's memory
    assert py["status"] == cl["status"] == "converged"
    assert py["estimated_model_error"] >= 0 and "estimated_discretization_error" in py
    for a in py["electrodes"]:
        assert abs(a["charge_C"]) > 0
    # Every key at every depth, every value (the timings aside): one serializer, pvdf::fem::result_json.
    from same_json import assert_same_json
    assert_same_json(py, {k: v for k, v in cl.items() if k in py})
    # result.summary is result_json's solver keys plus final_residual_norm, the one key the command
    # does not print (time_breakdown_s.assembly, not assembly_s).
    summary = result.summary
    assert set(summary) - {"final_residual_norm"} <= set(cl), set(summary) - set(cl)
    assert set(summary["time_breakdown_s"]) == set(cl["time_breakdown_s"]) == {"setup", "assembly", "linear_solve"}
    assert not {"assembly_s", "linear_solve_s", "setup_s"} & set(summary)
    assert_same_json({k: v for k, v in summary.items() if k != "final_residual_norm"}, {k: cl[k] for k in summary if k in cl})
    assert_same_json({k: v for k, v in summary.items() if k != "final_residual_norm"}, {k: py[k] for k in summary if k in py},
                     skip=set(), rel=0)  # the same object as to_dict's, timings included
    assert summary["final_residual_norm"] >= 0


def test_atlas_functions_refuse_bad_input_before_any_work(tmp_path):
    """make_atlas / map_from_atlas (docs/atlas.md) are exported and refuse bad paths at once (their
    agreement with direct maps is tests/atlas/test_atlas_vs_maps, in C++)."""
    scene = pvdfkit.default_scene()
    missing = str(tmp_path / "no-such.atlas.h5")
    with pytest.raises(pvdfkit.InputError, match="no-such.atlas.h5"):
        pvdfkit.map_from_atlas(scene, missing)
    with pytest.raises(pvdfkit.InputError, match="make_atlas: path"):
        pvdfkit.make_atlas(scene, str(tmp_path / "no-such-folder" / "film.atlas.h5"))
