"""Charge maps through the HDF5 reader/writer and the lookup over numpy arrays, on a map built in
Python from an analytic charge field (the truth is known, so the lookup's answers can be checked)."""
import numpy as np
import pytest

import pvdfkit

CENTRES = np.array([[0.0, 0.010], [-0.00866, -0.005], [0.00866, -0.005]])
NOISE_C = 0.05e-12


def analytic_charge_C(x, y, F):
    """A smooth, membrane-like field: Q_k = F^(2/3) * 40 pC * (1 + (d_k / 2 mm)^2)^-0.4."""
    x, y, F = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float), np.asarray(F, float))
    d2 = (x[..., None] - CENTRES[:, 0]) ** 2 + (y[..., None] - CENTRES[:, 1]) ** 2
    return F[..., None] ** (2 / 3) * 40e-12 * (1 + d2 / 0.002**2) ** -0.4


def analytic_map(spacing=0.0005, half=0.016, forces=(0.5, 1.0, 2.0)):
    m = pvdfkit.ChargeMap()
    axis = np.arange(-half, half + spacing / 2, spacing)
    m.x_m = axis
    m.y_m = axis
    m.forces_N = list(forces)
    m.electrode_names = ["A", "B", "C"]
    m.electrode_centers_m = CENTRES
    m.noise_C = [NOISE_C] * 3
    m.model = "analytic-test-field"
    m.scene_json = "{}"
    m.allocate()
    X, Y = np.meshgrid(axis, axis)
    m.mask = np.ones_like(X, dtype=np.uint8)
    F = np.asarray(forces)[:, None, None]
    m.charge_C = analytic_charge_C(X[None], Y[None], F)
    m.deflection_at_load_m = np.broadcast_to(-3e-3 * F ** (1 / 3), (len(forces),) + X.shape)
    m.status = np.zeros((len(forces),) + X.shape, dtype=np.uint8)
    return m


@pytest.fixture(scope="module")
def amap():
    return analytic_map()


@pytest.fixture(scope="module")
def locator(amap):
    return pvdfkit.Locator(amap)


def test_write_read_round_trip(amap, tmp_path):
    path = tmp_path / "analytic.h5"
    pvdfkit.write_map(str(path), amap)
    back = pvdfkit.read_map(str(path))
    assert back.charge_C.shape == (3, amap.ny, amap.nx, 3)
    assert np.array_equal(back.charge_C, amap.charge_C)
    assert np.array_equal(back.x_m, amap.x_m) and np.array_equal(back.forces_N, amap.forces_N)
    assert back.electrode_names == ["A", "B", "C"]
    assert np.array_equal(back.mask, amap.mask) and np.array_equal(back.status, amap.status)
    assert np.allclose(back.electrode_centers_m, CENTRES)


def test_invalid_maps_are_refused_with_the_dataset_named(amap, tmp_path):
    bad = analytic_map()
    bad.forces_N = [1.0, 0.5, 2.0]
    with pytest.raises(pvdfkit.InputError, match=r"/forces_N\[1\] = 0.5 must be >"):
        pvdfkit.write_map(str(tmp_path / "bad.h5"), bad)
    bad = analytic_map()
    bad.charge_C = np.zeros(7)
    with pytest.raises(pvdfkit.InputError, match="/charge_C has 7 values"):
        pvdfkit.validate_map(bad, "bad.h5")
    with pytest.raises(pvdfkit.InputError, match="missing.h5"):
        pvdfkit.read_map(str(tmp_path / "missing.h5"))


def test_vectorised_locate_recovers_known_presses(locator):
    rng = np.random.default_rng(3)
    n = 200
    # Presses within 7 mm of the centre (the electrodes sit at 10 mm): farther out this field has fold
    # twins the lookup may not report (docs/lookup.md); that is the lookup's, not the binding's, matter.
    r = 0.007 * np.sqrt(rng.uniform(0, 1, n))
    t = rng.uniform(0, 2 * np.pi, n)
    x, y = r * np.cos(t), r * np.sin(t)
    F = rng.uniform(0.6, 1.8, n)
    q = analytic_charge_C(x, y, F)
    out = locator.locate(q)
    assert len(out) == n and out.x_m.shape == (n,)
    assert out.flags.dtype == np.uint32
    # Noise-free charges of this isotropic field often have a second exact solution (a farther
    # press at another force): the truth must be the answer or, flagged ambiguous, an alternative.
    ok = out.has_position
    assert ok.mean() > 0.95
    candidates = np.concatenate([np.stack([out.x_m, out.y_m], 1)[:, None, :], out.alternatives[:, :, :2]], axis=1)
    dist = np.nanmin(np.hypot(candidates[..., 0] - x[:, None], candidates[..., 1] - y[:, None]), axis=1)
    assert dist[ok].max() < 1e-4
    single = ok & (out.flags & pvdfkit.FLAGS["ambiguous"] == 0)
    assert single.sum() > n // 3
    err = np.hypot(out.x_m - x, out.y_m - y)[single]
    # The error is the interpolant's (0.5 mm grid), far below a grid step.
    assert np.median(err) < 2e-5 and err.max() < 1e-4
    assert np.allclose(out.force_N[single], F[single], rtol=1e-2)
    amb = ok & ~single
    assert (out.n_solutions[amb] >= 2).all() and np.isfinite(out.alternatives[amb, 0, 0]).all()
    # Every solution is reported: n_solutions - 1 alternatives, and their posterior probabilities
    # with the main answer's form a distribution whose largest member is the main answer.
    n_alt = np.isfinite(out.alternatives[:, :, 0]).sum(axis=1)
    assert (n_alt[ok] == out.n_solutions[ok] - 1).all()
    total = out.probability + np.nansum(out.alternatives[:, :, 4], axis=1)
    assert np.allclose(total[ok], 1.0, atol=1e-9)
    assert (out.probability[amb] >= np.nanmax(out.alternatives[amb, :, 4], axis=1) - 1e-12).all()
    # One row at a time gives the same answers as the batch.
    one = locator.locate(q[7])
    assert len(one) == 1 and one.x_m[0] == out.x_m[7] and one.flags[0] == out.flags[7]


def test_noise_gives_consistent_sigmas(locator):
    """With the map's noise added, the scatter of the answers matches the reported 1-sigma."""
    rng = np.random.default_rng(5)
    x0, y0, F0 = 0.003, -0.002, 1.0
    q = analytic_charge_C(np.full(400, x0), np.full(400, y0), np.full(400, F0))
    q = q + rng.normal(0, NOISE_C, q.shape)
    out = locator.locate(q)
    ok = out.has_position
    assert ok.mean() > 0.95
    ratio_x = np.std(out.x_m[ok] - x0) / np.median(out.sigma_x_m[ok])
    ratio_y = np.std(out.y_m[ok] - y0) / np.median(out.sigma_y_m[ok])
    assert 0.7 < ratio_x < 1.4 and 0.7 < ratio_y < 1.4


def test_flags_and_known_force(locator):
    q = np.array([[0.0, 0.0, 0.0], [1e-16, -1e-16, 0.0]])  # zero and far below the noise: no press
    out = locator.locate(q)
    assert out.flags[0] & pvdfkit.FLAGS["no_press"] and out.flags[1] & pvdfkit.FLAGS["no_press"]
    assert not out.has_position.any()
    assert np.isnan(out.x_m).all()
    with pytest.raises(pvdfkit.InputError, match=r"charges_C\[0, 0\] = nan"):  # refused, not flagged (tests/python/test_input_errors.py)
        locator.locate([[np.nan, 1e-11, 1e-11]])
    assert out.flags_text[0] == pvdfkit.flags_text(int(out.flags[0]))
    x, y = np.array([0.002, -0.004]), np.array([0.001, 0.003])
    q = analytic_charge_C(x, y, 1.3)
    known = locator.locate(q, known_force_N=1.3)
    assert np.allclose(known.x_m, x, atol=1e-4) and np.allclose(known.force_N, 1.3)
    with pytest.raises(pvdfkit.InputError, match=r"expected n x 3 rows"):
        locator.locate(np.zeros((4, 2)))
    with pytest.raises(pvdfkit.InputError, match="known_force_N has 3 values for 2 rows"):
        locator.locate(q, known_force_N=[1.0, 1.0, 1.0])


def test_predict_passes_through_the_map_nodes(amap, locator):
    j, i = 20, 41
    pred = locator.predict([amap.x_m[i]], [amap.y_m[j]], 1.0)
    assert np.allclose(pred[0], amap.charge_C[1, j, i], rtol=1e-9)
    between = locator.predict([0.00123], [-0.00234], 0.8)
    assert np.allclose(between[0], analytic_charge_C(0.00123, -0.00234, 0.8)[0], rtol=1e-3)
    assert np.isnan(locator.predict([0.5], [0.5], 1.0)).all()
