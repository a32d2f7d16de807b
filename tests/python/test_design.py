"""pvdfkit.design against the Cramér–Rao bound computed here from the analytic field itself."""
import numpy as np
import pytest

import pvdfkit
from test_maps import NOISE_C, analytic_charge_C, analytic_map


def cramer_rao_sigma_pos_m(x, y, F, force_known):
    """sqrt(C_xx + C_yy) of (J^T J / sigma^2)^-1, J by central differences of the analytic field."""
    h = 1e-6
    dqdx = (analytic_charge_C(x + h, y, F) - analytic_charge_C(x - h, y, F)) / (2 * h)
    dqdy = (analytic_charge_C(x, y + h, F) - analytic_charge_C(x, y - h, F)) / (2 * h)
    dqdl = (analytic_charge_C(x, y, F * np.exp(1e-4)) - analytic_charge_C(x, y, F * np.exp(-1e-4))) / 2e-4
    J = np.column_stack([dqdx, dqdy] if force_known else [dqdx, dqdy, dqdl])
    cov = np.linalg.inv(J.T @ J / NOISE_C**2)
    return np.sqrt(cov[0, 0] + cov[1, 1])


def test_bounds_match_the_analytic_cramer_rao_bound():
    amap = analytic_map(spacing=0.001)
    d = pvdfkit.design(amap, force_N=1.0, adc_bits=0, min_force_N=0.5, max_force_N=2.0, check_ambiguity=False)
    assert d.status == "ok"
    maps = d.maps
    assert maps["sigma_pos_m"].shape == (amap.ny, amap.nx)
    assert maps["charge_C"].shape == (amap.ny, amap.nx, 3)
    assert d.summary["status"] == "ok"
    checked = 0
    for x, y in [(0.003, 0.002), (-0.005, -0.001), (0.0, -0.006), (0.007, 0.007)]:
        i = int(np.argmin(abs(amap.x_m - x)))
        j = int(np.argmin(abs(amap.y_m - y)))
        assert maps["evaluated"][j, i]
        for key, known in (("sigma_pos_unknown_force_m", False), ("sigma_pos_known_force_m", True)):
            oracle = cramer_rao_sigma_pos_m(amap.x_m[i], amap.y_m[j], 1.0, known)
            assert maps[key][j, i] == pytest.approx(oracle, rel=0.03), (x, y, key)
            checked += 1
    assert checked == 8
    # Knowing the force can only help.
    ev = maps["evaluated"]
    assert np.all(maps["sigma_pos_known_force_m"][ev] <= maps["sigma_pos_unknown_force_m"][ev] * (1 + 1e-9))


def test_design_refuses_bad_options():
    amap = analytic_map(spacing=0.002)
    with pytest.raises(pvdfkit.InputError):
        pvdfkit.design(amap, min_force_N=2.0, max_force_N=1.0)
    with pytest.raises(pvdfkit.InputError):
        pvdfkit.design(amap, noise_C=[-1.0])


def test_design_options_refused_alike_by_python_and_the_command(tmp_path):
    """One rule (pvdf::mapping::check_design_options) behind `pvdfkit.design` and `pvdfkit design`:
    values the command's flag parser lets through are refused by both with the same rule text, the
    command with exit 2 and the flag, Python with InputError and the keyword."""
    import subprocess
    from cli_path import pvdfkit_cli
    cli = pvdfkit_cli()
    amap = analytic_map(spacing=0.002)
    path = tmp_path / "analytic.h5"
    pvdfkit.write_map(str(path), amap)
    cases = [  # (Python keywords, command flags, the rule's words, Python's name, the command's name)
        (dict(noise_C=2e-6), ["--noise-C", "2e-6"], "must lie in (0, 1e-6) C", "design: noise_C = 2e-06",
         "--noise-C 2e-06"),
        (dict(min_force_N=3.0, max_force_N=1.0), ["--force-range-N", "3,1"], "need 0 < min_force_N < max_force_N",
         "design: min_force_N = 3", "--force-range-N MIN 3"),
        (dict(min_force_N=0.0, max_force_N=1.0), ["--force-range-N", "0,1"], "must lie in (0, 1e4] N",
         "design: min_force_N = 0", "--force-range-N MIN 0"),
        (dict(adc_bits=1), ["--adc-bits", "1"], "use 0 (ideal) or 2..32 bits", "design: adc_bits = 1", "--adc-bits 1"),
    ]
    for keywords, flags, rule, py_name, flag_name in cases:
        with pytest.raises(pvdfkit.InputError) as e:
            pvdfkit.design(amap, **keywords)
        assert rule in str(e.value) and py_name in str(e.value), str(e.value)
        out = subprocess.run([cli, "design", "--map", str(path), "--no-plots", "--quiet"] + flags,
                             capture_output=True, text=True, timeout=120)
        assert out.returncode == 2, (flags, out.returncode, out.stderr)
        assert rule in out.stderr and flag_name in out.stderr, out.stderr


def test_rank_designs_orders_as_the_command_rule():
    """Two layouts whose usable areas differ by construction: a finer noise gives the larger usable
    fraction, so it ranks first whatever the order given; bad input raises InputError."""
    amap = analytic_map(spacing=0.001)
    quiet = pvdfkit.design(amap, noise_C=NOISE_C / 10, adc_bits=0, check_ambiguity=False)
    noisy = pvdfkit.design(amap, noise_C=NOISE_C * 10, adc_bits=0, check_ambiguity=False)
    assert quiet.figure_of_merit > noisy.figure_of_merit
    assert pvdfkit.rank_designs([noisy, quiet]) == [1, 0]
    assert pvdfkit.rank_designs([quiet, noisy]) == [0, 1]
    assert pvdfkit.rank_designs([quiet, quiet]) == [0, 1]  # ties keep their order
    with pytest.raises(pvdfkit.InputError, match="DesignSummary"):
        pvdfkit.rank_designs([quiet, 3])
    with pytest.raises(pvdfkit.InputError, match="list"):
        pvdfkit.rank_designs("quiet")


def test_summary_is_the_command_line_json(tmp_path):
    """DesignSummary.summary and a layout of `pvdfkit design --map FILE --json` on the same map and
    settings: the same keys (the command adds its ranking and file keys) and the same values; one
    serializer (pvdf::mapping::design_summary_json) behind both."""
    import json
    import os
    import subprocess
    from cli_path import pvdfkit_cli
    cli = pvdfkit_cli()
    amap = analytic_map(spacing=0.002)
    path = tmp_path / "analytic.h5"
    pvdfkit.write_map(str(path), amap)
    d = pvdfkit.design(pvdfkit.read_map(str(path)), force_N=1.5, min_force_N=0.5, max_force_N=3.0, noise_C=NOISE_C,
                       target_m=0.4e-3, adc_bits=10)
    out = subprocess.run([cli, "design", "--map", str(path), "--force-N", "1.5", "--force-range-N", "0.5,3",
                          "--noise-C", repr(NOISE_C), "--target-mm", "0.4", "--adc-bits", "10", "--json", "--no-plots",
                          "--quiet"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    layouts = json.loads(out.stdout)["layouts"]
    assert len(layouts) == 1
    cl, py = layouts[0], d.summary
    command_keys = {"rank", "label", "source", "map_source", "map_file", "refined"}
    assert set(py) == set(cl) - command_keys, set(py) ^ (set(cl) - command_keys)
    assert py == {k: v for k, v in cl.items() if k not in command_keys}
    assert py["status"] == "ok" and 0 < py["usable_fraction"] <= 1 and len(py["electrodes"]) == 3


def test_design_result_is_the_command_line_json_key_for_key(tmp_path):
    """The whole object `pvdfkit design --map A --map B --json` prints, rebuilt from the Python package:
    its settings, every layout (pvdfkit.design's summary plus rank, label, source and map keys) in the
    order of pvdfkit.rank_designs, best and figures; key for key at every depth (the command's
    memory keys aside). Both go through the library's design_study_json and design_summary_json."""
    import json
    import subprocess
    from cli_path import pvdfkit_cli
    from same_json import assert_same_json
    cli = pvdfkit_cli()
    small, large = tmp_path / "small.h5", tmp_path / "large.h5"
    pvdfkit.write_map(str(small), analytic_map(spacing=0.002, half=0.010))  # its usable share is larger: ranks first
    pvdfkit.write_map(str(large), analytic_map(spacing=0.002))
    out = subprocess.run([cli, "design", "--map", str(large), "--map", str(small), "--force-N", "1.5", "--force-range-N",
                          "0.5,3", "--noise-C", repr(NOISE_C), "--target-mm", "0.4", "--adc-bits", "10", "--json",
                          "--no-plots", "--quiet"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    cl = json.loads(out.stdout)
    paths = [str(large), str(small)]
    designs = [pvdfkit.design(pvdfkit.read_map(p), force_N=1.5, min_force_N=0.5, max_force_N=3.0, noise_C=NOISE_C,
                              target_m=0.4e-3, adc_bits=10) for p in paths]
    order = pvdfkit.rank_designs(designs)
    assert order == [1, 0]  # the ranking reorders the command line's layouts
    layouts = []
    for rank, i in enumerate(order, start=1):
        layout = dict(designs[i].summary)
        label = paths[i].rsplit("/", 1)[1][:-3]
        layout.update(rank=rank, label=label, source=paths[i], map_source="file", map_file=paths[i], refined=False)
        layouts.append(layout)
    expected = {"synthetic": False, "noise_C": [NOISE_C], "target_m": 0.4e-3, "force_N": 1.5, "force_range_N": [0.5, 3.0],
                "force_known": False, "adc_bits": 10, "preview_spacing_m": 0.003, "layouts": layouts,
                "best": layouts[0]["label"], "figures": []}
    assert set(cl) - {"peak_resident_bytes", "memory"} == set(expected)
    assert_same_json(expected, {k: v for k, v in cl.items() if k in expected}, rel=0)


def test_optimize_layouts_synthetic_is_design_optimize(tmp_path):
    """pvdfkit.optimize_layouts(synthetic=True) and `pvdfkit design --optimize --synthetic` with the same
    settings and seed: the same JSON key for key (the command adds its files), the same best layout
    (the atlas case, with FEM maps, is tests/python/test_atlas.py)."""
    import json
    import os
    import subprocess
    from cli_path import pvdfkit_cli
    cli = pvdfkit_cli()
    film = {
        "membrane": {"shape": "circle", "radius_m": 0.012, "thickness_m": 25e-6},
        "material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "G12_Pa": 0.58e9, "nu12": 0.35, "draw_angle_deg": 0.0,
                     "d31_C_per_N": 6.5e-12, "d32_C_per_N": 0.65e-12},
        "electrodes": [{"name": "A", "center_m": [0.0, 0.004], "size_m": [0.002, 0.002]},
                       {"name": "B", "center_m": [-0.0035, -0.002], "size_m": [0.002, 0.002]},
                       {"name": "C", "center_m": [0.0035, -0.002], "size_m": [0.002, 0.002]}],
        "probe": {"radius_m": 0.00075},
    }
    path = tmp_path / "film.json"
    path.write_text(json.dumps(film))
    r = pvdfkit.optimize_layouts(str(path), synthetic=True, spacing_m=0.0015, electrodes_min=3, electrodes_max=4,
                                 budget=40, seed=5, square=True)
    out = subprocess.run([cli, "design", "--optimize", str(path), "--synthetic", "--spacing-m", "0.0015",
                          "--electrodes-min", "3", "--electrodes-max", "4", "--budget", "40", "--seed", "5", "--square",
                          "--json", "--no-plots", "--quiet"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    cl = json.loads(out.stdout)
    py = r.to_dict()
    assert set(py) == set(cl) - {"files"}
    for j in (py, cl):
        j.pop("seconds", None)
        j.pop("files", None)
        for c in j["counts"]:
            c.pop("seconds")
    assert py == cl
    assert py["maps"] == "synthetic" and "atlas" not in py
    best = r.best_n_electrodes
    assert best == cl["best_n_electrodes"]
    layout = r.best_layout
    assert layout.shape == (best, 5) and np.allclose(layout[:, 2], layout[:, 3])  # squares
    assert r.scenes[list(r.n_electrodes).index(best)] == r.best_scene
    assert isinstance(r.reference, pvdfkit.DesignSummary)
