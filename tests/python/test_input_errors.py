"""Every bad argument of the Python API raises pvdfkit.InputError naming the argument (and the value),
never a pybind11 TypeError with a signature dump, never a NaN result (issue 30 item 4, issue 31 item 3).

One table row per case: the call, then text the message must contain (the argument's name as the
message spells it, and where useful the value or the rule). The FEM rows are refused before any
solve starts, so the table runs in about a second.
"""
import os
import subprocess

import numpy as np
import pytest

import pvdfkit
from pvdfkit import restore
from test_maps import analytic_charge_C, analytic_map
from cli_path import pvdfkit_cli

NAN, INF = float("nan"), float("inf")


@pytest.fixture(scope="module")
def amap():
    return analytic_map(spacing=0.002)


@pytest.fixture(scope="module")
def locator(amap):
    return pvdfkit.Locator(amap)


def uniform_scan(n=64, **changes):
    """A valid scan of n samples (0.1 mm apart), with arrays replaced by `changes`."""
    x = np.arange(n) * 1e-4
    arrays = {"x_m": x, "m1_V": np.sin(x * 1e3), "m2_V": np.cos(x * 1e3)}
    arrays.update(changes)
    return arrays


def with_value(array, index, value):
    a = np.array(array, dtype=float)
    a[index] = value
    return a


@pytest.fixture(scope="module")
def scan():
    return restore.Scan(**uniform_scan())


@pytest.fixture(scope="module")
def filt():
    here = os.path.join(os.environ.get("PVDF_SOURCE_DIR", "."), "examples", "restore")
    a = restore.simulate(restore.load_scanner_scene(os.path.join(here, "edge_a.json")))
    b = restore.simulate(restore.load_scanner_scene(os.path.join(here, "edge_b.json")))
    return restore.identify([(a, 0.6, 0.9, -0.0125), (b, 0.2, 1.0, -0.0125)], beta=1e-4, taps=1024)


def a_file(tmp_path):
    path = tmp_path / "a_file.txt"
    path.write_text("x")
    return str(path)


def inconsistent_map():
    """A map whose charge array does not match its axes (assembled in Python, never validated)."""
    m = analytic_map(spacing=0.004)
    m.charge_C = np.zeros(7)
    return m


Q_ROW = analytic_charge_C(0.001, 0.002, 1.0)[None, :]  # one press: (1, 3) C

# (id, call(ctx) -> None, texts the message must contain). ctx holds the fixtures.
MAP_CASES = [
    ("locator-map-type", lambda c: pvdfkit.Locator("map.h5"), ["Locator: map = 'map.h5' (str)", "ChargeMap"]),
    ("locator-map-inconsistent", lambda c: pvdfkit.Locator(inconsistent_map()), ["Locator: map: /charge_C has 7 values"]),
    ("locator-map-empty", lambda c: pvdfkit.Locator(pvdfkit.ChargeMap()), ["Locator: map: /grid/x_m"]),
    ("design-map-inconsistent", lambda c: pvdfkit.design(inconsistent_map()), ["design: map: /charge_C has 7 values"]),
    ("locator-min-force-nan", lambda c: pvdfkit.Locator(c.amap, min_force_N=NAN), ["Locator: min_force_N = nan", "finite"]),
    ("locator-min-force-negative", lambda c: pvdfkit.Locator(c.amap, min_force_N=-1.0), ["Locator: min_force_N = -1", "(0, 1e4]"]),
    ("locator-max-force-inf", lambda c: pvdfkit.Locator(c.amap, max_force_N=INF), ["Locator: max_force_N = inf"]),
    ("locator-force-range-order", lambda c: pvdfkit.Locator(c.amap, min_force_N=2.0, max_force_N=1.0),
     ["min_force_N = 2 and max_force_N = 1", "min_force_N < max_force_N"]),
    ("locator-known-force-nan", lambda c: pvdfkit.Locator(c.amap, known_force_N=NAN), ["Locator: known_force_N = nan"]),
    ("locator-known-force-str", lambda c: pvdfkit.Locator(c.amap, known_force_N="1"), ["Locator: known_force_N = '1' (str)", "number"]),
    ("locator-chi2-nan", lambda c: pvdfkit.Locator(c.amap, chi2_limit=NAN), ["Locator: chi2_limit = nan"]),
    ("locator-chi2-negative", lambda c: pvdfkit.Locator(c.amap, chi2_limit=-1.0), ["Locator: chi2_limit = -1", "0 = automatic"]),
    ("locator-snr-nan", lambda c: pvdfkit.Locator(c.amap, no_press_snr=NAN), ["Locator: no_press_snr = nan"]),
    ("locator-snr-negative", lambda c: pvdfkit.Locator(c.amap, no_press_snr=-3.0), ["Locator: no_press_snr = -3", "[0, 1e+06]"]),
    ("locator-max-starts", lambda c: pvdfkit.Locator(c.amap, max_starts=9), ["Locator: max_starts = 9", "[1, 8]"]),
    ("locator-max-starts-float", lambda c: pvdfkit.Locator(c.amap, max_starts=2.0), ["Locator: max_starts = 2.0 (float)", "whole number"]),
    ("locator-max-iterations", lambda c: pvdfkit.Locator(c.amap, max_iterations=0), ["Locator: max_iterations = 0"]),
    ("locator-noise-nan", lambda c: pvdfkit.Locator(c.amap, noise_C=[NAN]), ["Locator: noise_C[0] = nan"]),
    ("locator-noise-count", lambda c: pvdfkit.Locator(c.amap, noise_C=[1e-13, 1e-13]), ["Locator: noise_C has 2 values", "give 1 or 3"]),
    ("locator-calibration-type", lambda c: pvdfkit.Locator(c.amap, use_calibration="no"), ["Locator: use_calibration = 'no'", "True or False"]),
    ("locator-unknown-keyword", lambda c: pvdfkit.Locator(c.amap, chi2=3.0), ["Locator: no argument named 'chi2'", "chi2_limit"]),
    ("locate-nan-charge", lambda c: c.locator.locate(with_value(Q_ROW, (0, 1), NAN)),
     ["Locator.locate: charges_C[0, 1] = nan", "not finite"]),
    ("locate-inf-charge", lambda c: c.locator.locate(with_value(Q_ROW, (0, 0), INF)), ["Locator.locate: charges_C[0, 0] = inf"]),
    ("locate-shape", lambda c: c.locator.locate(np.zeros((4, 2))), ["Locator.locate: charges_C has shape (4, 2)", "A, B, C"]),
    ("locate-str", lambda c: c.locator.locate("1e-11,2e-11,3e-11"), ["Locator.locate: charges_C = '1e-11,2e-11,3e-11' (str)"]),
    ("locate-complex", lambda c: c.locator.locate(Q_ROW.astype(complex)), ["Locator.locate: charges_C", "complex128"]),
    ("locate-ragged", lambda c: c.locator.locate([[1e-11, 2e-11, 3e-11], [1e-11]]), ["Locator.locate: charges_C", "ragged"]),
    ("locate-none", lambda c: c.locator.locate(None), ["Locator.locate: charges_C = None"]),
    ("locate-missing", lambda c: c.locator.locate(), ["Locator.locate: argument 'charges_C' is missing"]),
    ("locate-row-force-nan", lambda c: c.locator.locate(np.vstack([Q_ROW, Q_ROW]), known_force_N=[1.0, NAN]),
     ["Locator.locate: known_force_N[1] = nan"]),
    ("locate-row-force-negative", lambda c: c.locator.locate(Q_ROW, known_force_N=-1.0),
     ["Locator.locate: known_force_N[0] = -1", "(0, 1e4]"]),
    ("predict-array-shown-on-one-line", lambda c: c.locator.predict(np.zeros((2, 2, 2)), [0.0], 1.0),
     ["Locator.predict: x_m has shape (2, 2, 2)"]),
    ("flags-text-array", lambda c: pvdfkit.flags_text(np.zeros((3, 3))), ["flags_text: flags = array([[0., 0., 0.], [0., 0., 0.], [0., 0., 0.]])"]),
    ("predict-nan-x", lambda c: c.locator.predict([NAN], [0.0], 1.0), ["Locator.predict: x_m[0] = nan"]),
    ("predict-force", lambda c: c.locator.predict([0.0], [0.0], 0.0), ["Locator.predict: force_N[0] = 0"]),
    ("predict-lengths", lambda c: c.locator.predict([0.0, 0.001], [0.0], 1.0), ["Locator.predict: x_m has 2 values and y_m 1"]),
    ("flags-text-type", lambda c: pvdfkit.flags_text("ok"), ["flags_text: flags = 'ok' (str)"]),
    ("write-map-type", lambda c: pvdfkit.write_map(str(c.tmp / "m.h5"), "not a map"), ["write_map: map = 'not a map' (str)"]),
    ("write-map-folder", lambda c: pvdfkit.write_map("/nonexistent-folder/m.h5", c.amap), ["write_map: path", "does not exist"]),
    ("write-map-path-type", lambda c: pvdfkit.write_map(123, c.amap), ["write_map: path = 123 (int)"]),
    ("read-map-none", lambda c: pvdfkit.read_map(None), ["read_map: path = None"]),
    ("validate-map-type", lambda c: pvdfkit.validate_map([1, 2]), ["validate_map: map = [1, 2] (list)"]),
    ("read-measurements-names", lambda c: pvdfkit.read_measurements(c.file, "ABC"), ["read_measurements: electrode_names = 'ABC'"]),
    ("synthetic-spacing-nan", lambda c: pvdfkit.synthetic_map(pvdfkit.default_scene(), spacing_m=NAN), ["synthetic_map: spacing_m = nan"]),
    ("synthetic-force-zero", lambda c: pvdfkit.synthetic_map(pvdfkit.default_scene(), force_N=0.0), ["synthetic_map: force_N = 0", "(0, 10000]"]),
    ("synthetic-noise-negative", lambda c: pvdfkit.synthetic_map(pvdfkit.default_scene(), noise_C=-1e-14), ["synthetic_map: noise_C = -1e-14"]),
    ("synthetic-scene-dict-key", lambda c: pvdfkit.synthetic_map({"membran": {}}), ["synthetic_map: scene: ", "membran"]),
    ("synthetic-scene-type", lambda c: pvdfkit.synthetic_map(5), ["synthetic_map: scene = 5 (int)", "Scene"]),
    ("design-force-nan", lambda c: pvdfkit.design(c.amap, force_N=NAN), ["design: force_N = nan"]),
    ("design-adc-one", lambda c: pvdfkit.design(c.amap, adc_bits=1), ["design: adc_bits = 1"]),
    ("design-adc-float", lambda c: pvdfkit.design(c.amap, adc_bits=12.0), ["design: adc_bits = 12.0 (float)"]),
    ("design-target-zero", lambda c: pvdfkit.design(c.amap, target_m=0.0), ["design: target_m = 0", "(0, 1]"]),
    ("design-noise-nan", lambda c: pvdfkit.design(c.amap, noise_C=[NAN]), ["design: noise_C[0] = nan"]),
    ("design-force-range", lambda c: pvdfkit.design(c.amap, min_force_N=2.0, max_force_N=1.0), ["design: min_force_N = 2 and max_force_N = 1"]),
    ("design-flag-type", lambda c: pvdfkit.design(c.amap, force_known=1), ["design: force_known = 1 (int)", "True or False"]),
]


def set_attribute(target, name, value):
    setattr(target, name, value)


CHARGE_MAP_CASES = [
    ("x-nan", "x_m", [0.0, NAN, 0.002], ["ChargeMap.x_m[1] = nan"]),
    ("x-str", "x_m", "abc", ["ChargeMap.x_m = 'abc' (str)"]),
    ("x-empty", "x_m", [], ["ChargeMap.x_m is empty"]),
    ("forces-inf", "forces_N", [1.0, INF], ["ChargeMap.forces_N[1] = inf"]),
    ("noise-nan", "noise_C", [NAN, 1e-13, 1e-13], ["ChargeMap.noise_C[0] = nan"]),
    ("charge-inf", "charge_C", np.full((2, 2), INF), ["ChargeMap.charge_C[0, 0] = inf"]),
    ("charge-object", "charge_C", np.array([None, 1.0], dtype=object), ["ChargeMap.charge_C", "dtype object"]),
    ("mask-two", "mask", [[1, 2]], ["ChargeMap.mask[0, 1] = 2", "[0, 1]"]),
    ("status-fraction", "status", [[[0.5]]], ["ChargeMap.status[0, 0, 0] = 0.5", "not_computed"]),
    ("scene-json-broken", "scene_json", "{not json", ["ChargeMap.scene_json"]),
    ("scene-json-array", "scene_json", "[1, 2]", ["ChargeMap.scene_json must be a JSON object"]),
    ("scene-json-type", "scene_json", {"membrane": {}}, ["ChargeMap.scene_json = {'membrane': {}} (dict)", "str"]),
    ("error-nan", "estimated_relative_error", NAN, ["ChargeMap.estimated_relative_error = nan", "None = unknown"]),
    ("error-negative", "estimated_deflection_relative_error", -0.1, ["ChargeMap.estimated_deflection_relative_error = -0.1"]),
    ("tolerance-nan", "tolerance", NAN, ["ChargeMap.tolerance = nan"]),
    ("rim-margin-negative", "rim_margin_m", -1e-3, ["ChargeMap.rim_margin_m = -0.001"]),
    ("names-str", "electrode_names", "ABC", ["ChargeMap.electrode_names = 'ABC' (str)", "list of str"]),
    ("names-int", "electrode_names", ["A", 2], ["ChargeMap.electrode_names[1] = 2 (int)"]),
    ("centres-nan", "electrode_centers_m", [[0.0, NAN]], ["ChargeMap.electrode_centers_m[0, 1] = nan"]),
    ("centres-shape", "electrode_centers_m", [[0.0, 1.0, 2.0]], ["ChargeMap.electrode_centers_m has shape (1, 3)"]),
    ("model-type", "model", 3, ["ChargeMap.model = 3 (int)"]),
]

RESTORE_CASES = [
    ("scan-x-nan", lambda c: restore.Scan(**uniform_scan(x_m=with_value(uniform_scan()["x_m"], 3, NAN))), ["Scan: x_m[3] = nan"]),
    ("scan-m1-nan", lambda c: restore.Scan(**uniform_scan(m1_V=with_value(uniform_scan()["m1_V"], 17, NAN))),
     ["Scan: m1_V[17] = nan", "not finite"]),
    ("scan-m2-inf", lambda c: restore.Scan(**uniform_scan(m2_V=with_value(uniform_scan()["m2_V"], 0, -INF))), ["Scan: m2_V[0] = -inf"]),
    ("scan-fz-nan", lambda c: restore.Scan(**uniform_scan(), fx_N=np.zeros(64), fz_N=with_value(np.zeros(64), 5, NAN)),
     ["Scan: fz_N[5] = nan"]),
    ("scan-fx-only", lambda c: restore.Scan(**uniform_scan(), fx_N=np.zeros(64)), ["Scan: give both fx_N and fz_N"]),
    ("scan-short", lambda c: restore.Scan(**uniform_scan(10)), ["Scan: x_m has 10 samples", "at least 16"]),
    ("scan-empty", lambda c: restore.Scan([], [], []), ["Scan: x_m is empty"]),
    ("scan-not-uniform", lambda c: restore.Scan(**uniform_scan(x_m=with_value(uniform_scan()["x_m"], 5, 4.5e-4))),
     ["Scan: x_m[5]: position step", "uniformly sampled"]),
    ("scan-decreasing", lambda c: restore.Scan(**uniform_scan(x_m=-uniform_scan()["x_m"])), ["Scan: x_m", "do not increase"]),
    ("scan-2d", lambda c: restore.Scan(**uniform_scan(m1_V=np.zeros((64, 2)))), ["Scan: m1_V has shape (64, 2)", "1-D"]),
    ("scan-str", lambda c: restore.Scan("abc", [0.0], [0.0]), ["Scan: x_m = 'abc' (str)"]),
    ("identify-not-list", lambda c: restore.identify(c.scan), ["identify: scans = ", "list of (Scan, fx_N, fz_N, edge_x_m)"]),
    ("identify-tuple-length", lambda c: restore.identify([(c.scan, 0.6, 0.9)]), ["identify: scans[0] = ", "(Scan, fx_N, fz_N, edge_x_m)"]),
    ("identify-scan-type", lambda c: restore.identify([("a.csv", 0.6, 0.9, 0.0)]), ["identify: scans[0][0] = 'a.csv' (str)"]),
    ("identify-force-nan", lambda c: restore.identify([(c.scan, NAN, 0.9, 0.0), (c.scan, 0.2, 1.0, 0.0)]),
     ["identify: scans[0][1] (fx_N) = nan"]),
    ("identify-edge-inf", lambda c: restore.identify([(c.scan, 0.6, 0.9, INF), (c.scan, 0.2, 1.0, 0.0)]),
     ["identify: scans[0][3] (edge_x_m) = inf"]),
    ("identify-beta-nan", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], beta=NAN), ["identify: beta = nan"]),
    ("identify-beta-word", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], beta="big"), ["identify: beta = 'big'"]),
    ("identify-taps-float", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], taps=1024.5), ["identify: taps = 1024.5 (float)"]),
    ("identify-taps-huge", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], taps=10**30),
     ["identify: taps = 1000000000000000000000000000000 must lie in [64, 4194304]"]),
    ("identify-taps-odd", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], taps=1025), ["identify: taps = 1025 must be even"]),
    ("identify-delay", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], taps=1024, delay_samples=1024),
     ["identify: delay_samples = 1024", "[-1, 1023]"]),
    ("identify-beta-tiny", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], beta=1e-16), ["identify: beta = 1e-16", "[1e-15, 1e+06]"]),
    ("identify-resolution-word", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], resolution_m="fine"),
     ["identify: resolution_m = 'fine' must be 'auto' or a length in m"]),
    ("identify-g-window", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], g_window=62), ["identify: g_window = 62", "even and >= 64"]),
    ("identify-edge-far", lambda c: restore.identify([(c.scan, 0.6, 0.9, 11.0)]), ["identify: scans[0][3] (edge_x_m) = 11", "[-10, 10]"]),
    ("identify-resolution-nan", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], resolution_m=NAN), ["identify: resolution_m = nan"]),
    ("identify-window-type", lambda c: restore.identify([(c.scan, 0.6, 0.9, 0.0)], window=None), ["identify: window = None"]),
    ("apply-scan-type", lambda c: restore.apply(c.filt, "scan.csv"), ["apply: scan = 'scan.csv' (str)"]),
    ("apply-filter-type", lambda c: restore.apply(None, c.scan), ["apply: filter = None"]),
    ("apply-threshold-nan", lambda c: restore.apply(c.filt, c.scan, mu_threshold_N=NAN), ["apply: mu_threshold_N = nan"]),
    ("apply-threshold-huge", lambda c: restore.apply(c.filt, c.scan, mu_threshold_N=1e7), ["apply: mu_threshold_N = 1e+07", "[0, 1e6]"]),
    ("apply-block-negative", lambda c: restore.apply(c.filt, c.scan, block_samples=-1), ["apply: block_samples = -1"]),
    ("save-filter-type", lambda c: restore.save_filter(str(c.tmp / "f.json"), {"h": []}), ["save_filter: filter = {'h': []} (dict)"]),
    ("read-scan-speed-nan", lambda c: restore.read_scan(c.file, speed_m_per_s=NAN), ["read_scan: speed_m_per_s = nan"]),
    ("write-scan-type", lambda c: restore.write_scan(str(c.tmp / "s.csv"), [1, 2, 3]), ["write_scan: scan = [1, 2, 3] (list)"]),
    ("simulate-scene-type", lambda c: restore.simulate(3), ["simulate: scene = 3 (int)"]),
    ("simulate-scene-dict-key", lambda c: restore.simulate({"scann": {}}), ["simulate: scene: ", "scann"]),
    ("simulate-flag-type", lambda c: restore.simulate(restore.default_scanner_scene(), noise="no"), ["simulate: noise = 'no' (str)"]),
    ("scanner-scene-type", lambda c: restore.load_scanner_scene(5), ["load_scanner_scene: scene = 5 (int)"]),
    ("restore-unknown-keyword", lambda c: restore.apply(c.filt, c.scan, block=10), ["restore.apply: no argument named 'block'"]),
]

SCENE_CASES = [
    ("load-scene-type", lambda c: pvdfkit.load_scene(42), ["load_scene: scene = 42 (int)"]),
    ("load-scene-empty-path", lambda c: pvdfkit.load_scene(""), ["load_scene: scene = ''", "non-empty"]),
    ("load-scene-unknown-keyword", lambda c: pvdfkit.load_scene({}, src="x"), ["load_scene:", "'src'"]),
    ("probe-load-nan", lambda c: pvdfkit.default_scene().with_probe_load(NAN, 0.0, 1.0), ["Scene.with_probe_load: x_m = nan"]),
    ("probe-load-force", lambda c: pvdfkit.default_scene().with_probe_load(0.0, 0.0, 2e4), ["Scene.with_probe_load: force_N = 20000"]),
    ("probe-load-rim", lambda c: pvdfkit.default_scene().with_probe_load(0.5, 0.0, 1.0), ["Scene.with_probe_load: (x_m, y_m) = (0.5, 0)"]),
    ("grid-points-nan", lambda c: pvdfkit.grid_points([0.0, NAN], [0.0]), ["grid_points: x_m[1] = nan"]),
    ("grid-points-empty", lambda c: pvdfkit.grid_points([], [0.0]), ["grid_points: x_m is empty"]),
]

FEM_CASES = [
    ("solve-tolerance-range", lambda c: pvdfkit.solve(c.scene, tolerance=0.7),
     ["solve: tolerance = 0.7 must lie in [1e-08, 0.5]", "model.tolerance"]),
    ("solve-tolerance-nan", lambda c: pvdfkit.solve(c.scene, tolerance=NAN), ["solve: tolerance = nan"]),
    ("solve-tolerance-str", lambda c: pvdfkit.solve(c.scene, tolerance="0.01"), ["solve: tolerance = '0.01' (str)", "number"]),
    ("solve-tolerance-huge-int", lambda c: pvdfkit.solve(c.scene, tolerance=10**400), ["solve: tolerance = 1000", "too large"]),
    ("solve-tolerance-complex", lambda c: pvdfkit.solve(c.scene, tolerance=0.01 + 0j), ["solve: tolerance = (0.01+0j) (complex)", "real number"]),
    ("solve-loads-empty", lambda c: pvdfkit.solve(c.scene, loads=np.zeros((0, 3))), ["solve: loads is empty", "leave loads out"]),
    ("solve-loads-nan", lambda c: pvdfkit.solve(c.scene, loads=[[0.0, 0.0, NAN]]), ["solve: loads[0, 2] = nan"]),
    ("solve-loads-shape", lambda c: pvdfkit.solve(c.scene, loads=[[0.0, 1.0]]), ["solve: loads has shape (1, 2)", "n x 3"]),
    ("solve-loads-dtype", lambda c: pvdfkit.solve(c.scene, loads=[["a", "b", "c"]]), ["solve: loads", "dtype <U1"]),
    ("solve-loads-force", lambda c: pvdfkit.solve(c.scene, loads=[[0.0, 0.0, 2e4]]), ["solve: loads[0] = [0, 0, 20000]", "[-1e4, 1e4]"]),
    ("solve-loads-rim", lambda c: pvdfkit.solve(c.scene, loads=[[0.5, 0.0, 1.0]]), ["solve: loads[0] = [0.5, 0, 1]"]),
    ("solve-samples-inf", lambda c: pvdfkit.solve(c.scene, samples=[[INF, 0.0]]), ["solve: samples[0, 0] = inf"]),
    ("solve-samples-outside", lambda c: pvdfkit.solve(c.scene, samples=[[1.0, 0.0]]), ["solve: samples[0] = [1, 0]", "outside the film"]),
    ("solve-model-type", lambda c: pvdfkit.solve(c.scene, model=3), ["solve: model = 3 (int)"]),
    ("solve-model-name", lambda c: pvdfkit.solve(c.scene, model="quadratic"), ["solve: model", "quadratic"]),
    ("solve-refinements-float", lambda c: pvdfkit.solve(c.scene, max_refinements=2.5), ["solve: max_refinements = 2.5 (float)"]),
    ("solve-refinements-negative", lambda c: pvdfkit.solve(c.scene, max_refinements=-1), ["solve: max_refinements = -1", "[0, 20]"]),
    ("solve-check-type", lambda c: pvdfkit.solve(c.scene, check="yes"), ["solve: check = 'yes' (str)"]),
    ("solve-scene-type", lambda c: pvdfkit.solve(42), ["solve: scene = 42 (int)"]),
    ("solve-vtu-file", lambda c: pvdfkit.solve(c.scene, vtu_dir=c.file), ["solve: vtu_dir", "existing file"]),
    ("solve-unknown-keyword", lambda c: pvdfkit.solve(c.scene, tol=0.1), ["solve:", "'tol'"]),
    ("sweep-tolerance-range", lambda c: pvdfkit.ProbeSweep(c.scene, tolerance=0.7), ["ProbeSweep: tolerance = 0.7 must lie in [1e-08, 0.5]"]),
    ("sweep-setup-checks", lambda c: pvdfkit.ProbeSweep(c.scene, n_setup_checks=5), ["ProbeSweep: n_setup_checks = 5"]),
    ("sweep-forces-nan", lambda c: pvdfkit.ProbeSweep(c.scene, forces_N=[NAN]), ["ProbeSweep: forces_N[0] = nan"]),
    ("sweep-rim-negative", lambda c: pvdfkit.ProbeSweep(c.scene, rim_margin_m=-1.0), ["ProbeSweep: rim_margin_m = -1"]),
    ("sweep-scene-type", lambda c: pvdfkit.ProbeSweep(None), ["ProbeSweep: scene = None"]),
    ("map-spacing-zero", lambda c: pvdfkit.generate_map(c.scene, spacing_m=0.0), ["generate_map: spacing_m = 0 must lie in [1e-05, 0.1]"]),
    ("map-forces-empty", lambda c: pvdfkit.generate_map(c.scene, forces_N=[]), ["generate_map: forces_N is empty"]),
    ("map-forces-negative", lambda c: pvdfkit.generate_map(c.scene, forces_N=[-1.0]), ["generate_map: forces_N[0] = -1"]),
    ("map-region-order", lambda c: pvdfkit.generate_map(c.scene, region_m=(0.01, 0.0, 0.0, 0.01)), ["generate_map: region_m", "xmin < xmax"]),
    ("map-region-nan", lambda c: pvdfkit.generate_map(c.scene, region_m=(0.0, NAN, 0.0, 0.01)), ["generate_map: region_m[1] = nan"]),
    ("map-tolerance-range", lambda c: pvdfkit.generate_map(c.scene, tolerance=0.7), ["generate_map: tolerance = 0.7"]),
    ("map-setup-checks", lambda c: pvdfkit.generate_map(c.scene, n_setup_checks=4), ["generate_map: n_setup_checks = 4", "[0, 3]"]),
    ("map-noise-count", lambda c: pvdfkit.generate_map(c.scene, noise_C=[1e-13]), ["generate_map: noise_C has 1 values for 3"]),
    ("map-threads", lambda c: pvdfkit.generate_map(c.scene, threads=-1), ["generate_map: threads = -1"]),
    ("map-too-large", lambda c: pvdfkit.generate_map(c.scene, spacing_m=1e-5), ["generate_map: spacing_m = 1e-05", "limit"]),
    ("map-checkpoint-folder", lambda c: pvdfkit.generate_map(c.scene, checkpoint_path="/nonexistent-folder/m.ckpt"),
     ["generate_map: checkpoint_path", "does not exist"]),
]


class Context:
    pass


@pytest.fixture
def ctx(request, tmp_path):
    c = Context()
    c.tmp = tmp_path
    c.file = a_file(tmp_path)
    c.scene = pvdfkit.default_scene()
    for name in request.fixturenames:
        if name in ("amap", "locator", "scan", "filt"):
            setattr(c, name, request.getfixturevalue(name))
    return c


def refused(call, ctx, texts):
    with pytest.raises(pvdfkit.InputError) as e:
        call(ctx)
    message = str(e.value)
    for text in texts:
        assert text in message, f"{text!r} not in {message!r}"
    assert "\n" not in message and "incompatible function arguments" not in message
    return message


@pytest.mark.parametrize("case, call, texts", MAP_CASES, ids=[c[0] for c in MAP_CASES])
def test_map_and_lookup_arguments(case, call, texts, ctx, amap, locator):
    refused(call, ctx, texts)


@pytest.mark.parametrize("case, attribute, value, texts", CHARGE_MAP_CASES, ids=[c[0] for c in CHARGE_MAP_CASES])
def test_charge_map_fields(case, attribute, value, texts):
    m = analytic_map(spacing=0.004)
    before = getattr(m, attribute)
    with pytest.raises(pvdfkit.InputError) as e:
        setattr(m, attribute, value)
    for text in texts:
        assert text in str(e.value), f"{text!r} not in {str(e.value)!r}"
    after = getattr(m, attribute)  # a refused assignment leaves the field as it was
    if isinstance(before, np.ndarray):
        assert np.array_equal(after, before, equal_nan=before.dtype.kind == "f")
    else:
        assert after == before or (before != before and after != after)


@pytest.mark.parametrize("case, call, texts", RESTORE_CASES, ids=[c[0] for c in RESTORE_CASES])
def test_restore_arguments(case, call, texts, ctx, scan, filt):
    refused(call, ctx, texts)


@pytest.mark.parametrize("case, call, texts", SCENE_CASES, ids=[c[0] for c in SCENE_CASES])
def test_scene_arguments(case, call, texts, ctx):
    refused(call, ctx, texts)


@pytest.mark.skipif(not pvdfkit.has_fem, reason="built without the FEM modules")
@pytest.mark.parametrize("case, call, texts", FEM_CASES, ids=[c[0] for c in FEM_CASES])
def test_fem_arguments_refused_before_any_work(case, call, texts, ctx):
    refused(call, ctx, texts)


@pytest.mark.parametrize("name", ["Scene", "Locations", "DesignSummary", "restore.InverseFilter", "restore.ScannerScene",
                                  "restore.RestoredForces"] + (["SolveResult", "ProbeSolutions"] if pvdfkit.has_fem else []))
def test_result_classes_say_where_they_come_from(name):
    """Classes without a constructor: InputError saying which function makes them (not "No constructor defined!")."""
    cls = pvdfkit
    for part in name.split("."):
        cls = getattr(cls, part)
    with pytest.raises(pvdfkit.InputError, match=cls.__name__ + " cannot be made directly; it comes from "):
        cls()


def test_charge_map_arrays_are_read_only_copies():
    """An in-place edit raises instead of being discarded silently; a whole assignment is kept."""
    m = analytic_map(spacing=0.004)
    q = m.charge_C
    assert not q.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        m.charge_C[0, 0, 0, 0] = 1.0
    for name in ("x_m", "y_m", "forces_N", "noise_C", "mask", "status", "deflection_at_load_m", "electrode_centers_m"):
        assert not getattr(m, name).flags.writeable, name
    changed = q.copy()
    changed[0, 0, 0, 0] = 1.5e-11
    m.charge_C = changed
    assert m.charge_C[0, 0, 0, 0] == 1.5e-11
    assert np.array_equal(m.charge_C, changed)


def test_scan_arrays_are_read_only(scan):
    with pytest.raises(ValueError, match="read-only"):
        scan.m1_V[0] = 1.0


def test_unknown_errors_round_trip(tmp_path):
    """estimated errors: None (unknown) reads back as None, through the HDF5 file too."""
    m = analytic_map(spacing=0.004)
    m.estimated_relative_error = None
    assert m.estimated_relative_error is None
    m.estimated_relative_error = 0.01
    assert m.estimated_relative_error == 0.01
    m.estimated_relative_error = None
    pvdfkit.write_map(str(tmp_path / "m.h5"), m)
    assert pvdfkit.read_map(str(tmp_path / "m.h5")).estimated_relative_error is None


def test_empty_batches_give_empty_results(locator):
    """Zero rows of charges are a batch of no presses (not an error): the result has length 0."""
    out = locator.locate(np.zeros((0, 3)))
    assert len(out) == 0 and out.x_m.shape == (0,)


def test_locate_refuses_nan_instead_of_flagging(locator):
    """Before: a NaN charge gave flags and NaN positions. Now the whole call is refused, naming the row."""
    q = np.vstack([Q_ROW, Q_ROW, with_value(Q_ROW, (0, 2), NAN)])
    with pytest.raises(pvdfkit.InputError, match=r"charges_C\[2, 2\] = nan"):
        locator.locate(q)


def cli():
    return pvdfkit_cli()


@pytest.mark.skipif(not pvdfkit.has_fem, reason="built without the FEM modules")
@pytest.mark.parametrize("python_call, command, rule", [
    (lambda s: pvdfkit.solve(s, tolerance=0.7), ["solve", "SCENE", "--tolerance", "0.7"],
     "0.7 must lie in [1e-08, 0.5] (the rule of the scene key model.tolerance), e.g. 0.01"),
    (lambda s: pvdfkit.solve(s, tolerance=1e-9), ["solve", "SCENE", "--tolerance", "1e-9"], "1e-09 must lie in [1e-08, 0.5]"),
    (lambda s: pvdfkit.solve(s, max_refinements=21), ["solve", "SCENE", "--max-refinements", "21"], "21 must lie in [0, 20]"),
    (lambda s: pvdfkit.generate_map(s, tolerance=0.7), ["map", "SCENE", "-o", "OUT", "--tolerance", "0.7"],
     "0.7 must lie in [1e-08, 0.5]"),
    (lambda s: pvdfkit.generate_map(s, n_setup_checks=4), ["map", "SCENE", "-o", "OUT", "--setup-checks", "4"],
     "4 must lie in [0, 3]"),
    (lambda s: pvdfkit.generate_map(s, spacing_m=0.2), ["map", "SCENE", "-o", "OUT", "--spacing-m", "0.2"],
     "0.2 must lie in [1e-05, 0.1]"),
], ids=["solve-tolerance", "solve-tolerance-small", "solve-max-refinements", "map-tolerance", "map-setup-checks", "map-spacing"])
def test_python_refuses_what_the_command_refuses(python_call, command, rule, scenes, tmp_path):
    """The same value is refused by the command (exit 2) and by Python, with the same rule text."""
    scene_path = str(scenes / "seed001.json")
    args = [scene_path if a == "SCENE" else str(tmp_path / "out.h5") if a == "OUT" else a for a in command]
    run = subprocess.run([cli()] + args, capture_output=True, text=True, timeout=60)
    assert run.returncode == 2, run.stderr
    assert rule in run.stderr, run.stderr
    with pytest.raises(pvdfkit.InputError) as e:
        python_call(pvdfkit.load_scene(scene_path))
    assert rule in str(e.value)


@pytest.mark.skipif(not pvdfkit.has_fem, reason="built without the FEM modules")
def test_setup_check_defaults_equal_the_map_command():
    """ProbeSweep and generate_map default to the setup checks `pvdfkit map` defaults to (3)."""
    run = subprocess.run([cli(), "map", "--help"], capture_output=True, text=True, timeout=60)
    assert "default 3" in run.stdout and "--setup-checks" in run.stdout
    import re
    for doc in (pvdfkit.ProbeSweep.__init__.__doc__, pvdfkit.generate_map.__doc__):
        assert re.search(r"n_setup_checks: \w+ = 3\b", doc), doc.splitlines()[0]
    # No tolerance given: the scene's model.tolerance, as `map` without --tolerance.
    assert re.search(r"tolerance: \w+ = None", pvdfkit.generate_map.__doc__)
