"""The charge-density atlas from Python (docs/atlas.md): make_atlas reports what `pvdfkit atlas --json`
prints, key for key (one serializer, pvdf::mapping::atlas_report_json), on a small film."""
import json
import os
import subprocess

import numpy as np
import pytest

import pvdfkit

# A 16 mm film with three 2 mm electrodes (their layout plays no part in the atlas); a coarse
# probe grid (13 positions, 6 solved, the rest mirror images): about 20 s per atlas.
FILM = {
    "membrane": {"shape": "circle", "radius_m": 0.008, "thickness_m": 25e-6},
    "material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "G12_Pa": 0.58e9, "nu12": 0.35,
                 "draw_angle_deg": 0.0, "d31_C_per_N": 6.5e-12, "d32_C_per_N": 0.65e-12},
    "electrodes": [{"name": "A", "center_m": [0.0, 0.003], "size_m": [0.002, 0.002]},
                   {"name": "B", "center_m": [-0.0026, -0.0015], "size_m": [0.002, 0.002]},
                   {"name": "C", "center_m": [0.0026, -0.0015], "size_m": [0.002, 0.002]}],
    "probe": {"radius_m": 0.00075},
    "model": {"kinematics": "auto", "tolerance": 0.04, "max_refinements": 0},
}
ATLAS_FLAGS = ["--spacing-m", "0.003", "--tolerance", "0.04", "--threads", "1", "--setup-checks", "1"]


def cli():
    binary = os.environ.get("PVDF_BINARY_DIR")
    path = os.path.join(binary, "app", "pvdfkit") if binary else None
    if not path or not os.path.exists(path):
        pytest.fail("PVDF_BINARY_DIR/app/pvdfkit not found: run through ctest (tests/python/CMakeLists.txt)")
    return path


@pytest.fixture(scope="module")
def film(tmp_path_factory):
    """The film's scene file, its atlas made by pvdfkit.make_atlas and that call's report."""
    folder = tmp_path_factory.mktemp("atlas")
    scene_path = folder / "film.json"
    scene_path.write_text(json.dumps(FILM))
    atlas_path = folder / "film.atlas.h5"
    report = pvdfkit.make_atlas(FILM, str(atlas_path), spacing_m=0.003, tolerance=0.04, threads=1, n_setup_checks=1)
    return {"folder": folder, "scene": scene_path, "atlas": atlas_path, "report": report}


def test_make_atlas_report_is_the_command_line_json(film):
    """make_atlas's dict and `pvdfkit atlas --json` for the same film and settings: the same keys and,
    timings aside, the same values (the sweep is deterministic)."""
    cli_atlas = film["folder"] / "cli.atlas.h5"
    out = subprocess.run([cli(), "atlas", str(film["scene"]), "-o", str(cli_atlas), *ATLAS_FLAGS, "--quiet", "--json"],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    cl = json.loads(out.stdout)
    py = film["report"]
    assert set(py) == set(cl)
    assert py["output"] == str(film["atlas"]) and cl["output"] == str(cli_atlas)
    for key in set(cl) - {"output", "setup_s", "wall_s"}:
        if isinstance(cl[key], float):
            assert py[key] == pytest.approx(cl[key], rel=1e-9), key
        else:
            assert py[key] == cl[key], key
    assert py["n_failed"] == 0 and py["n_positions"] == 13 and py["n_solved_positions"] < py["n_positions"]
    assert py["setup_s"] > 0 and py["wall_s"] >= py["setup_s"]
    # The two files hold the same charges: a layout read from either is the same map (NaN off the film).
    a = pvdfkit.map_from_atlas(FILM, str(film["atlas"]))
    b = pvdfkit.map_from_atlas(FILM, str(cli_atlas))
    assert np.array_equal(a.charge_C, b.charge_C, equal_nan=True) and np.nanmax(np.abs(a.charge_C)) > 0
