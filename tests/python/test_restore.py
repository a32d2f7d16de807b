"""pvdfkit.restore: simulate seed 000's two-edge identification, restore a surface with known forces."""
import numpy as np
import pytest

from pvdfkit import restore
import pvdfkit


@pytest.fixture(scope="module")
def identified(request):
    import os
    here = os.path.join(os.environ.get("PVDF_SOURCE_DIR", "."), "examples", "restore")
    a = restore.simulate(restore.load_scanner_scene(os.path.join(here, "edge_a.json")))
    b = restore.simulate(restore.load_scanner_scene(os.path.join(here, "edge_b.json")))
    f = restore.identify([(a, 0.6, 0.9, -0.0125), (b, 0.2, 1.0, -0.0125)], beta="auto", taps=4096,
                         resolution_m=1.5e-3, low_cut_wavelength_m=0.01)
    return a, b, f


def test_identified_filter_shapes(identified):
    a, _, f = identified
    assert f.h.shape == (2, 2, 4096)
    assert f.taps == 4096 and f.beta_policy == "predicted"
    assert f.sample_spacing_m == pytest.approx(a.sample_spacing_m)
    assert f.conditioning["force_condition_number"] > 1


def edge_scene(x_m, fx_N, fz_N, seed):
    return {
        "scan": {"x_start_m": -0.05, "x_end_m": 0.05, "speed_m_per_s": 0.05},
        "acquisition": {"seed": seed},
        "surface": {"edges": [{"x_m": x_m, "fx_N": fx_N, "fz_N": fz_N}]},
    }


@pytest.mark.parametrize("x_m, fx_N, fz_N, seed", [(0.01, 0.35, 0.7, 21), (-0.02, 0.1, 1.2, 22), (0.03, 0.5, 0.6, 23)])
def test_restores_unseen_edges_at_their_position_force_and_friction(identified, x_m, fx_N, fz_N, seed):
    """Edges the filter never saw (other positions, forces, noise). The filters aim at the true force
    blurred by a Gaussian of FWHM resolution_m, so a single edge of force F must come back as a
    peak of F * dx / (s * sqrt(2 pi)) per sample (s = FWHM / 2.3548) at its position, lowered by the
    filter's own prediction of how far its beta blurs beyond that target (peak_fraction, from G's
    frequency response alone, never from a restored scan), with mu = fx/fz."""
    _, _, f = identified
    scan = restore.simulate(restore.load_scanner_scene(edge_scene(x_m, fx_N, fz_N, seed)))
    out = restore.apply(f, scan)
    assert out.x_m.shape == out.fz_N.shape == (len(scan),)
    s = f.resolution_m / 2.3548
    assert 0.5 < f.peak_fraction <= 1.0
    peak_per_N = f.peak_fraction * scan.sample_spacing_m / (s * np.sqrt(2 * np.pi))
    i = int(np.argmax(out.fz_N))
    assert abs(out.x_m[i] - x_m) < 0.1e-3
    assert out.fz_N[i] == pytest.approx(fz_N * peak_per_N, rel=0.03)
    assert out.fx_N[i] == pytest.approx(fx_N * peak_per_N, rel=0.1)
    assert out.mu_valid[i] and out.mu[i] == pytest.approx(fx_N / fz_N, abs=0.05)


def test_streaming_equals_offline(identified):
    a, _, f = identified
    off = restore.apply(f, a)
    streamed = restore.apply(f, a, block_samples=500)
    assert np.allclose(streamed.fz_N, off.fz_N, atol=1e-9 * np.abs(off.fz_N).max())


def test_scan_from_arrays_and_bad_input(identified, tmp_path):
    a, _, f = identified
    copy = restore.Scan(a.x_m, a.m1_V, a.m2_V)
    assert np.array_equal(restore.apply(f, copy).fz_N, restore.apply(f, a).fz_N)
    restore.write_scan(str(tmp_path / "a.csv"), a)
    back = restore.read_scan(str(tmp_path / "a.csv"))
    assert np.allclose(back.m1_V, a.m1_V, rtol=1e-15)
    with pytest.raises(pvdfkit.InputError, match="must have as many"):
        restore.Scan([0.0, 1.0], [0.0], [0.0, 1.0])
    with pytest.raises(pvdfkit.InputError, match="beta"):
        restore.identify([(a, 0.6, 0.9, -0.0125)], beta=-1.0)
    with pytest.raises(pvdfkit.InputError):
        restore.load_scanner_scene({"scan": {"speed_m_per_s": -1}})
    with pytest.raises(pvdfkit.InputError):
        restore.identify([(a, 0.6, 0.9, -0.0125)], beta=1e-4)  # one scan cannot identify a 2x2 G
    with pytest.raises(pvdfkit.InputError, match="regularization"):
        restore.identify([(a, 0.6, 0.9, -0.0125), (_, 0.2, 1.0, -0.0125)], regularization="lasso")


def test_regularization_choice(identified):
    """The default is the isotropic regularization (as the command); Tikhonov on request. Isotropic keeps
    less of an isolated feature's force near it than Tikhonov at the same beta (long wavelengths damped as
    the weak direction's), and both say how much."""
    a, b, f = identified
    assert f.regularization == "isotropic"
    scans = [(a, 0.6, 0.9, -0.0125), (b, 0.2, 1.0, -0.0125)]
    iso = restore.identify(scans, beta=1e-4, taps=4096, resolution_m=1.5e-3, low_cut_wavelength_m=0.01)
    tik = restore.identify(scans, beta=1e-4, taps=4096, resolution_m=1.5e-3, low_cut_wavelength_m=0.01,
                           regularization="tikhonov")
    assert tik.regularization == "tikhonov"
    assert 0 < iso.lobe_force_fraction < tik.lobe_force_fraction <= 1.05


def test_identify_defaults_equal_the_command(identified, tmp_path):
    """restore.identify with its defaults and `pvdfkit restore identify` without options make the same
    filter (auto beta, auto resolution and low cut, 8192 taps, isotropic): one set of defaults."""
    import os
    import subprocess
    cli = os.path.join(os.environ.get("PVDF_BINARY_DIR", ""), "app", "pvdfkit")
    if not os.path.exists(cli):
        pytest.fail("PVDF_BINARY_DIR/app/pvdfkit not found: run through ctest (tests/python/CMakeLists.txt)")
    a, b, _ = identified
    restore.write_scan(str(tmp_path / "a.csv"), a)
    restore.write_scan(str(tmp_path / "b.csv"), b)
    run = subprocess.run([cli, "restore", "identify", "--scan", str(tmp_path / "a.csv"), "--force", "0.6,0.9",
                          "--scan", str(tmp_path / "b.csv"), "--force", "0.2,1.0", "--edge-x-m=-0.0125",
                          "--edge-x-m=-0.0125", "-o", str(tmp_path / "f.json")], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    cl = restore.load_filter(str(tmp_path / "f.json"))
    py = restore.identify([(restore.read_scan(str(tmp_path / "a.csv")), 0.6, 0.9, -0.0125),
                           (restore.read_scan(str(tmp_path / "b.csv")), 0.2, 1.0, -0.0125)])
    assert (py.taps, py.beta_policy, py.regularization, py.window) == (cl.taps, cl.beta_policy, cl.regularization, cl.window)
    assert py.resolution_m == pytest.approx(cl.resolution_m, rel=1e-9) and py.resolution_m > 0  # 'auto', not 0
    assert py.low_cut_wavelength_m == pytest.approx(cl.low_cut_wavelength_m, rel=1e-9) and py.low_cut_wavelength_m > 0
    assert py.beta == pytest.approx(cl.beta, rel=1e-9)
    assert np.allclose(py.h, cl.h, rtol=0, atol=1e-9 * np.abs(cl.h).max())
