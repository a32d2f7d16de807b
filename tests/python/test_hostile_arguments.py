"""A sweep of hostile values through every argument of every public function and class of pvdfkit:
each call either works or raises pvdfkit.InputError with one line naming the argument (issue 30 item 4).
Never a TypeError with pybind11's signature dump, never another exception type.

Each entry gives a call with valid arguments; every argument in turn is replaced by each value of
HOSTILE. Calls that would start an FEM solve or an identification when a hostile value happens to be
acceptable get a `sentinel`: one argument given a bad value that is checked after all the others, so
the call is refused (naming the sentinel) before any work starts.
"""
import os

import numpy as np
import pytest

import pvdfkit
from pvdfkit import restore
from test_maps import analytic_charge_C, analytic_map

NAN, INF = float("nan"), float("inf")


class Opaque:
    def __repr__(self):
        return "<opaque>"


HOSTILE = {
    "nan": NAN, "inf": INF, "-inf": -INF, "None": None, "str": "abc", "empty-str": "", "bytes": b"x",
    "empty-list": [], "ragged": [[1.0], [1.0, 2.0]], "complex": 1 + 2j, "bool": True, "object": Opaque(),
    "dict": {"a": 1}, "nan-array": np.array([NAN]), "3d-array": np.zeros((2, 2, 2)), "minus-one": -1,
    "zero": 0, "huge-int": 10**400, "str-array": np.array(["a"]), "huge-float": 1e300,
}

SOURCE = os.environ.get("PVDF_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))


def edge_scan(name):
    return restore.simulate(restore.load_scanner_scene(os.path.join(SOURCE, "examples", "restore", name)))


class Fixtures:
    """Valid objects the calls are built from (made once)."""

    def __init__(self, tmp):
        self.tmp = tmp
        self.amap = analytic_map(spacing=0.004)
        self.locator = pvdfkit.Locator(self.amap)
        self.q = analytic_charge_C(np.array([0.001, -0.002]), np.array([0.002, 0.0]), 1.0)
        self.scene = pvdfkit.default_scene()
        self.scan_a, self.scan_b = edge_scan("edge_a.json"), edge_scan("edge_b.json")
        self.filter = restore.identify([(self.scan_a, 0.6, 0.9, -0.0125), (self.scan_b, 0.2, 1.0, -0.0125)],
                                       beta=1e-4, taps=1024)
        self.map_path = str(tmp / "map.h5")
        pvdfkit.write_map(self.map_path, self.amap)


@pytest.fixture(scope="module")
def fx(tmp_path_factory):
    return Fixtures(tmp_path_factory.mktemp("hostile"))


def entries(f):
    """(label, function, valid keyword arguments, sentinel (name, value) or None)."""
    scans = [(f.scan_a, 0.6, 0.9, -0.0125), (f.scan_b, 0.2, 1.0, -0.0125)]
    e = [
        ("Locator", pvdfkit.Locator, dict(map=f.amap, noise_C=None, use_calibration=True, known_force_N=None,
                                          min_force_N=None, max_force_N=None, chi2_limit=0.0, max_starts=6,
                                          max_iterations=40, no_press_snr=3.0), None),
        ("Locator.locate", f.locator.locate, dict(charges_C=f.q, known_force_N=None), None),
        ("Locator.predict", f.locator.predict, dict(x_m=[0.0], y_m=[0.0], force_N=1.0), None),
        ("design", pvdfkit.design, dict(map=f.amap, force_N=1.0, min_force_N=0.25, max_force_N=4.0, noise_C=None,
                                        target_m=5e-4, force_known=False, adc_bits=12, full_scale_C=0.0,
                                        check_ambiguity=False), None),
        ("synthetic_map", pvdfkit.synthetic_map, dict(scene=f.scene, spacing_m=0.004, force_N=1.0, noise_C=5e-14), None),
        ("read_map", pvdfkit.read_map, dict(path=f.map_path), None),
        ("write_map", pvdfkit.write_map, dict(path=str(f.tmp / "out.h5"), map=f.amap), None),
        ("validate_map", pvdfkit.validate_map, dict(map=f.amap, source="map"), None),
        ("flags_text", pvdfkit.flags_text, dict(flags=0), None),
        ("load_scene", pvdfkit.load_scene, dict(scene=os.path.join(SOURCE, "examples", "scenes", "seed001.json"), source=None), None),
        ("grid_points", pvdfkit.grid_points, dict(x_m=[0.0, 0.001], y_m=[0.0]), None),
        ("Scene.with_probe_load", f.scene.with_probe_load, dict(x_m=0.0, y_m=0.0, force_N=1.0), None),
        ("Scan", restore.Scan, dict(x_m=f.scan_a.x_m, m1_V=f.scan_a.m1_V, m2_V=f.scan_a.m2_V, fx_N=None, fz_N=None), None),
        ("restore.apply", restore.apply, dict(filter=f.filter, scan=f.scan_a, mu_threshold_N=-1.0, block_samples=0), None),
        ("restore.save_filter", restore.save_filter, dict(path=str(f.tmp / "f.json"), filter=f.filter), None),
        ("restore.load_filter", restore.load_filter, dict(path=str(f.tmp / "f.json")), None),
        ("restore.write_scan", restore.write_scan, dict(path=str(f.tmp / "s.csv"), scan=f.scan_a, comment=""), None),
        ("restore.read_scan", restore.read_scan, dict(path=str(f.tmp / "s.csv"), speed_m_per_s=0.0), None),
        ("restore.simulate", restore.simulate, dict(scene=restore.default_scanner_scene(), noise=True, adc=True,
                                                    moving_average=True), None),
        ("restore.identify", restore.identify, dict(scans=scans, beta=1e-4, beta_policy="", taps=1024, delay_samples=-1,
                                                    g_window=0, resolution_m=0.0, low_cut_wavelength_m=0.0,
                                                    corner_wavelength_m=0.0, window="tukey", regularization="isotropic"),
         ("scans", [(f.scan_a, 0.6, 0.9, NAN)])),
    ]
    if pvdfkit.has_fem:
        e += [
            ("solve", pvdfkit.solve, dict(scene=f.scene, loads=[[0.0, 0.0, 1.0]], samples=[[0.0, 0.0]], model="auto",
                                          tolerance=0.01, max_refinements=2, vtu_dir=None), ("check", "sentinel")),
            ("ProbeSweep", pvdfkit.ProbeSweep, dict(scene=f.scene, tolerance=0.01, model="auto", forces_N=[1.0],
                                                    n_setup_checks=3), ("rim_margin_m", "sentinel")),
            ("generate_map", pvdfkit.generate_map, dict(scene=f.scene, spacing_m=0.004, forces_N=[1.0],
                                                        region_m=(-0.004, 0.004, -0.004, 0.004), rim_margin_m=0.0,
                                                        model="auto", tolerance=0.01, n_setup_checks=3, threads=1,
                                                        use_symmetry=True, use_force_scaling=True, noise_C=None,
                                                        description=""), ("checkpoint_path", "/nonexistent-folder/x.ckpt")),
        ]
    return e


CALLS = ["Locator", "Locator.locate", "Locator.predict", "design", "synthetic_map", "read_map", "write_map",
         "validate_map", "flags_text", "load_scene", "grid_points", "Scene.with_probe_load", "Scan", "restore.apply",
         "restore.save_filter", "restore.load_filter", "restore.write_scan", "restore.read_scan", "restore.simulate",
         "restore.identify"] + (["solve", "ProbeSweep", "generate_map"] if pvdfkit.has_fem else [])


@pytest.mark.parametrize("label", CALLS)
def test_every_argument_refuses_hostile_values(label, fx):
    (entry,) = [e for e in entries(fx) if e[0] == label]
    _, function, valid, sentinel = entry
    n_refused = n_accepted = 0
    problems = []
    for name in valid:
        for value_name, value in HOSTILE.items():
            kwargs = dict(valid)
            kwargs[name] = value
            if sentinel:
                kwargs[sentinel[0]] = sentinel[1]
            try:
                function(**kwargs)
                n_accepted += 1
                if sentinel:
                    problems.append(f"{name}={value_name}: accepted although {sentinel[0]} is bad")
            except pvdfkit.InputError as e:
                message = str(e)
                n_refused += 1
                if "\n" in message or "incompatible" in message:
                    problems.append(f"{name}={value_name}: message not one line: {message!r}")
                named = name in message or (sentinel and sentinel[0] in message) or \
                    (isinstance(value, str) and value and value in message)
                if not named:
                    problems.append(f"{name}={value_name}: message does not name the argument: {message!r}")
            except Exception as e:  # noqa: BLE001 (the point of the test)
                problems.append(f"{name}={value_name}: {type(e).__name__}: {str(e)[:200]}")
    print(f"{label}: {n_refused} refused, {n_accepted} accepted")
    assert not problems, f"{label}: {len(problems)} problems:\n" + "\n".join(problems)
    assert n_refused > 0


CHARGE_MAP_FIELDS = ["scene_json", "pvdfkit_version", "model", "description", "tolerance", "rim_margin_m", "estimated_relative_error",
                     "estimated_deflection_relative_error", "electrode_names", "electrode_centers_m", "x_m", "y_m",
                     "forces_N", "noise_C", "mask", "charge_C", "deflection_at_load_m", "status"]


@pytest.mark.parametrize("field", CHARGE_MAP_FIELDS)
def test_every_charge_map_field_refuses_hostile_values(field):
    """Each assignment is kept or refused naming ChargeMap.<field>; a refused one leaves the field as it was."""
    m = analytic_map(spacing=0.004)
    problems = []
    for value_name, value in HOSTILE.items():
        before = repr(getattr(m, field))
        try:
            setattr(m, field, value)
        except pvdfkit.InputError as e:
            if f"ChargeMap.{field}" not in str(e) or "\n" in str(e):
                problems.append(f"{value_name}: {str(e)!r}")
            if repr(getattr(m, field)) != before:
                problems.append(f"{value_name}: refused but the field changed")
        except Exception as e:  # noqa: BLE001
            problems.append(f"{value_name}: {type(e).__name__}: {str(e)[:200]}")
        m = analytic_map(spacing=0.004)
    assert not problems, f"ChargeMap.{field}:\n" + "\n".join(problems)
