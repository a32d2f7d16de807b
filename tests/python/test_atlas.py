"""The charge-density atlas from Python (docs/atlas.md): make_atlas reports what `pvdfkit atlas --json`
prints, key for key (one serializer, pvdf::mapping::atlas_report_json), on a small film."""
import json
import os
import subprocess

import numpy as np
import pytest

import pvdfkit
from cli_path import pvdfkit_cli

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
    return pvdfkit_cli()


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


OPTIMIZE = {"electrodes_min": 3, "electrodes_max": 4, "size_min_m": 0.001, "size_max_m": 0.003, "budget": 30, "seed": 3}


def optimize_flags(atlas):
    return ["--atlas", str(atlas), "--electrodes-min", "3", "--electrodes-max", "4", "--size-min-m", "0.001",
            "--size-max-m", "0.003", "--budget", "30", "--seed", "3"]


def without_timings(j):
    j = json.loads(json.dumps(j))
    j.pop("seconds")
    for c in j["counts"]:
        c.pop("seconds")
    return j


def test_optimize_layouts_is_design_optimize(film):
    """pvdfkit.optimize_layouts on the atlas and `pvdfkit design --optimize --atlas` with the same
    settings and seed: the same JSON key for key (the command adds its files), the same best layout."""
    result = pvdfkit.optimize_layouts(str(film["scene"]), atlas=str(film["atlas"]), **OPTIMIZE)
    out = subprocess.run([cli(), "design", "--optimize", str(film["scene"]), *optimize_flags(film["atlas"]),
                          "--json", "--no-plots", "--quiet"], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    cl = json.loads(out.stdout)
    py = result.to_dict()
    assert set(py) == set(cl) - {"files"}
    assert py["maps"] == cl["maps"] == "atlas" and py["scene"] == cl["scene"] == str(film["scene"])
    cl.pop("files")
    assert without_timings(py) == without_timings(cl)  # every layout, figure and count, bit for bit
    # The arrays: the best count's layout is the JSON's, in SI units (angles in rad).
    best = result.best_n_electrodes
    assert best == cl["best_n_electrodes"] and best in (3, 4)
    k = list(result.n_electrodes).index(best)
    rects = cl["counts"][k]["layout"]
    expected = np.array([[r["center_m"][0], r["center_m"][1], r["size_m"][0], r["size_m"][1],
                          np.radians(r["angle_deg"])] for r in rects])
    assert result.best_layout.shape == (best, 5)
    assert np.allclose(result.best_layout, expected, rtol=1e-12, atol=1e-15)
    assert result.found.dtype == bool and result.found.all()
    assert np.array_equal(result.usable_fraction, [c["usable_fraction"] for c in cl["counts"]])
    summary = result.summaries[k]
    assert summary.maps["sigma_pos_m"].shape == (summary.y_m.size, summary.x_m.size)
    assert summary.figure_of_merit == result.usable_fraction[k] > 0
    # The winner is a scene that maps from the same atlas.
    winner = pvdfkit.map_from_atlas(result.best_scene, str(film["atlas"]))
    assert winner.n_electrodes == best
    # Another seed, another search path (the seed is honoured).
    other = pvdfkit.optimize_layouts(str(film["scene"]), atlas=str(film["atlas"]), **{**OPTIMIZE, "seed": 4})
    assert not np.array_equal(other.layouts[0], result.layouts[0])


def test_optimize_layouts_refuses_as_the_command(film, tmp_path):
    """Bad settings raise InputError with the command's rule, the option spelled as the keyword."""
    scene = str(film["scene"])
    cases = [
        ({"synthetic": True, "electrodes_min": 2}, ["--synthetic", "--electrodes-min", "2"], "electrodes_min = 2",
         "must be >= 3 (a press has three unknowns x, y, F)"),
        ({"synthetic": True, "electrodes_min": 5, "electrodes_max": 4}, ["--synthetic", "--electrodes-min", "5",
                                                                   "--electrodes-max", "4"],
         "electrodes_max = 4", "is below"),
        ({"synthetic": True, "min_gap_m": -0.001}, ["--synthetic", "--min-gap-m", "-0.001"], "min_gap_m = -0.001", "must be >= 0 (m)"),
        ({"synthetic": True, "budget": 0}, ["--synthetic", "--budget", "0"], "budget = 0", "must lie in [1, 1000000]"),
        ({"atlas": str(tmp_path / "missing.atlas.h5")}, ["--atlas", str(tmp_path / "missing.atlas.h5")],
         "missing.atlas.h5", "no such file"),
        ({}, [], "atlas = FILE", "(a charge-density atlas of the film"),
        ({"atlas": str(film["atlas"]), "synthetic": True}, ["--atlas", str(film["atlas"]), "--synthetic"],
         "synthetic = True", "give one of them"),
        # A clamp margin inside the atlas's keep-out band (1 mm by default): refused before the search.
        ({"atlas": str(film["atlas"]), "clamp_margin_m": 0.0005}, ["--atlas", str(film["atlas"]), "--clamp-margin-m", "0.0005"],
         "clamp_margin_m = 0.0005", "inside the keep-out band"),
    ]
    for kwargs, flags, named, rule in cases:
        with pytest.raises(pvdfkit.InputError) as e:
            pvdfkit.optimize_layouts(scene, **kwargs)
        assert str(e.value).startswith("optimize_layouts: ") and named in str(e.value) and rule in str(e.value), str(e.value)
        out = subprocess.run([cli(), "design", "--optimize", scene, *flags, "--quiet", "--no-plots"],
                             capture_output=True, text=True, timeout=60)
        assert out.returncode == 2 and rule in out.stderr, (flags, out.stderr)
    with pytest.raises(pvdfkit.InputError, match="optimize_layouts: seed"):
        pvdfkit.optimize_layouts(scene, synthetic=True, seed=-1)
    with pytest.raises(pvdfkit.InputError, match="optimize_layouts: spacing_m"):
        pvdfkit.optimize_layouts(scene, atlas=str(film["atlas"]), spacing_m=0.001)


def test_make_atlas_refuses_as_the_command(tmp_path):
    """Each argument by the rule of `pvdfkit atlas`'s flag, refused before any solve."""
    path = str(tmp_path / "refused.atlas.h5")
    cases = [
        ({"spacing_m": 2.0}, "make_atlas: spacing_m = 2", "--spacing-m", "2.0"),
        ({"cell_m": 0.0}, "make_atlas: cell_m = 0", "--cell-m", "0"),
        ({"tolerance": 0.7}, "make_atlas: tolerance = 0.7", "--tolerance", "0.7"),
        ({"forces_N": [1.0, 1.0]}, "make_atlas: forces_N", "--forces-N", "1,1"),
        ({"threads": -1}, "make_atlas: threads = -1", "--threads", "-1"),
        ({"n_setup_checks": 4}, "make_atlas: n_setup_checks = 4", "--setup-checks", "4"),
        ({"keep_out_m": 0.5}, "make_atlas: keep_out_m = 0.5", "--keep-out-m", "0.5"),
    ]
    scene_path = tmp_path / "film.json"
    scene_path.write_text(json.dumps(FILM))
    for kwargs, message, flag, value in cases:
        with pytest.raises(pvdfkit.InputError, match=message.replace(".", r"\.")):
            pvdfkit.make_atlas(FILM, path, **kwargs)
        out = subprocess.run([cli(), "atlas", str(scene_path), "-o", path, flag, value, "--quiet"],
                             capture_output=True, text=True, timeout=60)
        assert out.returncode == 2, (flag, out.stderr)
    assert not os.path.exists(path)
