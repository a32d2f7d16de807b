"""Scenes from files and dicts: the C++ reader's validation and messages, seen from Python."""
import json
import math
import os
import subprocess

import numpy as np
import pytest

import pvdfkit


def test_import_exposes_the_api():
    for name in ("load_scene", "solve", "read_map", "write_map", "Locator", "design", "InputError",
                 "NumericalError", "restore"):
        assert hasattr(pvdfkit, name), name
    assert issubclass(pvdfkit.InputError, ValueError)
    assert issubclass(pvdfkit.NumericalError, RuntimeError)
    assert pvdfkit.__version__.count(".") == 2


def test_file_and_dict_give_the_same_scene(scenes):
    path = scenes / "seed001.json"
    raw = json.loads(path.read_text())
    from_file = pvdfkit.load_scene(path)
    from_dict = pvdfkit.load_scene(raw, source="seed001")
    assert from_file.electrode_names == [e["name"] for e in raw["electrodes"]]
    assert from_dict.to_dict() == from_file.to_dict()
    # The normalized dict loads again to the same scene (all defaults filled in).
    again = pvdfkit.load_scene(from_file.to_dict())
    assert again.to_dict() == from_file.to_dict()
    # Centroids in metres, as written in the file (rectangles are centred on center_m).
    centres = np.array([e["center_m"] for e in raw["electrodes"]])
    assert np.allclose(from_file.electrode_centroids_m, centres, atol=1e-12)


def test_default_scene_is_seed001(scenes):
    raw = json.loads((scenes / "seed001.json").read_text())
    s = pvdfkit.default_scene()
    assert s.electrode_names == [e["name"] for e in raw["electrodes"]]
    assert s.thickness_m == pytest.approx(raw["membrane"]["thickness_m"])
    outline = s.film_outline_m
    assert outline.shape[1] == 2
    assert np.allclose(np.hypot(outline[:, 0], outline[:, 1]), raw["membrane"]["radius_m"])
    assert s.film_area_m2 == pytest.approx(math.pi * raw["membrane"]["radius_m"] ** 2)


def test_bad_value_is_an_input_error_naming_key_value_and_rule(scenes):
    raw = json.loads((scenes / "seed001.json").read_text())
    raw["membrane"]["thickness_m"] = -2.5e-5
    with pytest.raises(pvdfkit.InputError) as e:
        pvdfkit.load_scene(raw, source="bad.json")
    text = str(e.value)
    assert text.startswith("bad.json: membrane.thickness_m")
    assert "-2.5e-05" in text and "must" in text
    with pytest.raises(ValueError):  # the same error caught as a ValueError
        pvdfkit.load_scene(raw)


def test_typo_and_nan_are_refused(scenes):
    raw = json.loads((scenes / "seed001.json").read_text())
    raw["membrane"]["thicknes_m"] = raw["membrane"].pop("thickness_m")
    with pytest.raises(pvdfkit.InputError, match="thicknes_m"):
        pvdfkit.load_scene(raw)
    raw = json.loads((scenes / "seed001.json").read_text())
    raw["membrane"]["thickness_m"] = float("nan")
    with pytest.raises(pvdfkit.InputError, match="finite"):
        pvdfkit.load_scene(raw)
    with pytest.raises(pvdfkit.InputError, match="missing|No such|cannot"):
        pvdfkit.load_scene("/nonexistent/scene.json")


def test_messages_equal_the_command_line(scenes, tmp_path):
    """The same bad file gives the same one-line message in Python as `pvdfkit solve` on stderr."""
    binary = os.environ.get("PVDF_BINARY_DIR")
    pvdfkit_cli = os.path.join(binary, "app", "pvdfkit") if binary else None
    if not pvdfkit_cli or not os.path.exists(pvdfkit_cli):
        pytest.fail("PVDF_BINARY_DIR/app/pvdfkit not found: run through ctest (tests/python/CMakeLists.txt)")
    raw = json.loads((scenes / "seed001.json").read_text())
    raw["electrodes"][1]["size_m"] = [0.002, -0.001]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(raw))
    with pytest.raises(pvdfkit.InputError) as e:
        pvdfkit.load_scene(bad)
    run = subprocess.run([pvdfkit_cli, "solve", str(bad)], capture_output=True, text=True)
    assert run.returncode == 2
    assert run.stderr.strip().splitlines()[-1] == "error: " + str(e.value)


def test_with_probe_load_replaces_the_loads():
    s = pvdfkit.default_scene().with_probe_load(0.003, -0.002, 0.5)
    loads = s.to_dict()["loads"]
    assert len(loads) == 1
    assert loads[0]["position_m"] == pytest.approx([0.003, -0.002])
    assert loads[0]["force_N"] == pytest.approx(0.5)
