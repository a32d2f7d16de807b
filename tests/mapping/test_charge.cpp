// Charge formulas: the charge law of pvdf/core/piezo.hpp (used by the solver) against numbers
// worked by hand, the quadrature form against the uniform-stress oracle, and seed 001 eq. 2
// against the tensor transformation (computed independently with pvdf::stress_to_material).
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/material.hpp"
#include "pvdf/core/piezo.hpp"
#include "pvdf/mapping/charge.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Core>

#include <cmath>
#include <random>

using namespace pvdf::mapping;

TEST_CASE("the charge law Q = A (d31 N11 + d32 N22) / h against hand-worked numbers", "[mapping][charge]") {
  // A = 4 mm², h = 25 µm, d31 = 6.5 pC/N, d32 = 0.65 pC/N, N11 = 120 N/m, N22 = -40 N/m:
  // d31 N11 + d32 N22 = 7.8e-10 - 2.6e-11 = 7.54e-10 C/m; / h = 3.016e-5 C/m²; × A = 1.2064e-10 C.
  CHECK(pvdf::piezo_charge_density_C_per_m2(120.0, -40.0, 25e-6, 6.5e-12, 0.65e-12) == Approx(3.016e-5).epsilon(1e-14));
  CHECK(pvdf::piezo_charge_C(4e-6, 120.0, -40.0, 25e-6, 6.5e-12, 0.65e-12) == Approx(1.2064e-10).epsilon(1e-14));
  // Compression along the draw gives charge of the opposite sign; the shear N12 is not an input.
  CHECK(pvdf::piezo_charge_C(4e-6, -120.0, 40.0, 25e-6, 6.5e-12, 0.65e-12) == Approx(-1.2064e-10).epsilon(1e-14));
  // Halving the thickness at the same resultants doubles the stress and the charge.
  CHECK(pvdf::piezo_charge_C(4e-6, 120.0, -40.0, 12.5e-6, 6.5e-12, 0.65e-12) == Approx(2.4128e-10).epsilon(1e-14));
  // The quadrature form over a uniform field is the law itself (one home for the formula).
  std::vector<MembraneForceSample> samples(5, MembraneForceSample{0.8e-6, 120.0, -40.0});
  CHECK(electrode_charge_C(samples, 25e-6, 6.5e-12, 0.65e-12) ==
        Approx(pvdf::piezo_charge_C(4e-6, 120.0, -40.0, 25e-6, 6.5e-12, 0.65e-12)).epsilon(1e-14));
}

TEST_CASE("a uniformly stressed electrode collects d31*sigma11*area + d32*sigma22*area", "[mapping][charge]") {
  const double area = 4e-6, h = 25e-6, d31 = 6.5e-12, d32 = 0.65e-12;
  const double N11 = 120.0, N22 = 0.0;  // N/m
  // Random quadrature weights that sum to the area.
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0.1, 1.0);
  std::vector<MembraneForceSample> samples(37);
  double total = 0;
  for (auto& s : samples) total += (s.weight_m2 = u(rng));
  for (auto& s : samples) {
    s.weight_m2 *= area / total;
    s.N11_N_per_m = N11;
    s.N22_N_per_m = N22;
  }
  CHECK(electrode_charge_C(samples, h, d31, d32) == Approx(d31 * (N11 / h) * area).epsilon(1e-14));
  for (auto& s : samples) s.N22_N_per_m = -40.0;
  CHECK(electrode_charge_C(samples, h, d31, d32) == Approx((d31 * N11 / h + d32 * -40.0 / h) * area).epsilon(1e-14));
  CHECK_THROWS_AS(electrode_charge_C(samples, 0.0, d31, d32), pvdf::InputError);
  samples[3].weight_m2 = -1;
  CHECK_THROWS_AS(electrode_charge_C(samples, h, d31, d32), pvdf::InputError);
}

TEST_CASE("radial-stress charge by tensor rotation; eq. 2 as printed differs off-axis", "[mapping][charge]") {
  const double d31 = 6.5e-12, d32 = 0.65e-12, area = 4e-6, sigma_r = 2e6, sigma_t = 0.3e6;
  for (double beta_deg : {0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0}) {
    const double beta = beta_deg * pvdf::pi / 180;
    // Independent oracle: the radial direction at angle β from the draw axis (axis 1) is the
    // global x of a frame in which the draw axis sits at angle −β.
    const Eigen::Vector3d global(sigma_r, sigma_t, 0.0);  // [σrr, σθθ, σrθ]
    const Eigen::Vector3d material = pvdf::stress_to_material(-beta) * global;
    const double oracle = (d31 * material[0] + d32 * material[1]) * area;
    CHECK(charge_radial_tensor_C(d31, d32, beta, sigma_r, sigma_t, area) == Approx(oracle).epsilon(1e-12));
  }
  // Along and across the draw eq. 2 agrees with the tensor form (σθ = 0) ...
  CHECK(charge_eq2_printed_C(d31, d32, 0.0, sigma_r, area) == Approx(charge_radial_tensor_C(d31, d32, 0.0, sigma_r, 0, area)));
  CHECK(charge_eq2_printed_C(d31, d32, pvdf::pi / 2, sigma_r, area) ==
        Approx(charge_radial_tensor_C(d31, d32, pvdf::pi / 2, sigma_r, 0, area)));
  // ... but at 45° it is (cos + sin)/(cos² + sin²) = √2 times too large for any d31, d32.
  const double ratio = charge_eq2_printed_C(d31, d32, pvdf::pi / 4, sigma_r, area) /
                       charge_radial_tensor_C(d31, d32, pvdf::pi / 4, sigma_r, 0, area);
  CHECK(ratio == Approx(std::sqrt(2.0)).epsilon(1e-12));
}
