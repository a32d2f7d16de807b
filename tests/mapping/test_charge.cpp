// Charge formulas: the quadrature form against the uniform-stress oracle, and seed 001 eq. 2
// against the tensor transformation (computed independently with pvdf::stress_to_material).
#include "pvdf/core/error.hpp"
#include "pvdf/core/material.hpp"
#include "pvdf/mapping/charge.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Core>

#include <cmath>
#include <random>

using namespace pvdf::mapping;

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
    const double beta = beta_deg * M_PI / 180;
    // Independent oracle: the radial direction at angle β from the draw axis (axis 1) is the
    // global x of a frame in which the draw axis sits at angle −β.
    const Eigen::Vector3d global(sigma_r, sigma_t, 0.0);  // [σrr, σθθ, σrθ]
    const Eigen::Vector3d material = pvdf::stress_to_material(-beta) * global;
    const double oracle = (d31 * material[0] + d32 * material[1]) * area;
    CHECK(charge_radial_tensor_C(d31, d32, beta, sigma_r, sigma_t, area) == Approx(oracle).epsilon(1e-12));
  }
  // Along and across the draw eq. 2 agrees with the tensor form (σθ = 0) ...
  CHECK(charge_eq2_printed_C(d31, d32, 0.0, sigma_r, area) == Approx(charge_radial_tensor_C(d31, d32, 0.0, sigma_r, 0, area)));
  CHECK(charge_eq2_printed_C(d31, d32, M_PI / 2, sigma_r, area) ==
        Approx(charge_radial_tensor_C(d31, d32, M_PI / 2, sigma_r, 0, area)));
  // ... but at 45° it is (cos + sin)/(cos² + sin²) = √2 times too large for any d31, d32.
  const double ratio = charge_eq2_printed_C(d31, d32, M_PI / 4, sigma_r, area) /
                       charge_radial_tensor_C(d31, d32, M_PI / 4, sigma_r, 0, area);
  CHECK(ratio == Approx(std::sqrt(2.0)).epsilon(1e-12));
}
