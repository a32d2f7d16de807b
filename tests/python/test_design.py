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
