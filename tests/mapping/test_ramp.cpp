// The force-ramp test (docs/lookup.md §2, "Force ramps"). Oracles: the membrane scaling law
// (with Q = F^(2/3)·G(x, y) — or any force law common to all electrodes — every exact solution
// at the peak is exact along the whole ramp, so a ramp cannot separate them), and the χ²
// distribution of the ramp statistic under Gaussian noise.
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/ramp.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>

using namespace pvdf::mapping;

namespace {

const std::vector<double> levels{0.25, 0.5, 1.0, 2.0};

/// A map whose charge direction turns with the force, differently across the film (as under
/// pretension): each level is the synthetic seed-001 model with its own decay exponent.
ChargeMap turning_map() {
  SyntheticModel base;
  ChargeMap map = build_synthetic_map(base, 2e-3, 3e-3, levels, 0.05e-12);
  for (std::size_t f = 0; f < levels.size(); ++f) {
    SyntheticModel m;
    m.exponent = 0.8 + 0.1 * std::log(levels[f]);
    for (std::size_t j = 0; j < map.ny(); ++j) {
      for (std::size_t i = 0; i < map.nx(); ++i) {
        for (std::size_t k = 0; k < map.ne(); ++k) {
          map.charge_C[map.charge_index(f, j, i, k)] = m.charge_C(map.x_m[i], map.y_m[j], levels[f], k);
        }
      }
    }
  }
  return map;
}

}  // namespace

TEST_CASE("chi2_quantile matches tabulated values", "[mapping][ramp]") {
  // Tables of the χ² distribution: 0.999 quantiles for 10, 58 and 100 degrees of freedom.
  CHECK(chi2_quantile(10, 1e-3) == Approx(29.588).epsilon(1e-2));
  CHECK(chi2_quantile(58, 1e-3) == Approx(97.039).epsilon(2e-3));
  CHECK(chi2_quantile(100, 1e-3) == Approx(149.449).epsilon(1e-3));
  CHECK(chi2_quantile(100, 0.05) == Approx(124.342).epsilon(1e-3));
}

TEST_CASE("a ramp cannot separate the exact solutions of a membrane map", "[mapping][ramp]") {
  // Exact F^(2/3) (force_skew 0) and a magnitude-only departure (force_skew: the exponent
  // varies across the film, the direction does not): both keep every peak solution.
  for (const double skew : {0.0, 0.05}) {
    SyntheticModel model;
    model.force_skew = skew;
    const ChargeMap map = build_synthetic_map(model, 2e-3, 3e-3, levels, 0.05e-12);
    const RampAmbiguity r = ramp_ambiguity_share(map);
    INFO("skew " << skew << ": nodes " << r.nodes << " (truth missed " << r.nodes_truth_missed << "), ambiguous at the peak "
                 << r.ambiguous_at_peak << ", after the ramp " << r.ambiguous_after_ramp << ", held "
                 << r.ambiguous_after_hold << ", own rejected " << r.own_rejected
                 << ", median separation " << r.median_separation);
    CHECK(r.nodes > 500);
    CHECK(r.dof == 58);
    CHECK(r.ambiguous_at_peak > 0.5);
    CHECK(r.ambiguous_after_ramp >= r.ambiguous_after_hold);  // lower forces average less
    CHECK(r.ambiguous_after_hold > 0.95 * r.ambiguous_at_peak);
    CHECK(r.own_rejected == 0);
    CHECK(r.median_separation < 1e-3);
  }
}

TEST_CASE("where the direction turns with the force the ramp separates solutions", "[mapping][ramp]") {
  const ChargeMap map = turning_map();
  const RampAmbiguity r = ramp_ambiguity_share(map);
  INFO("nodes " << r.nodes << " (truth missed " << r.nodes_truth_missed << "), ambiguous at the peak "
                << r.ambiguous_at_peak << ", after the ramp " << r.ambiguous_after_ramp << ", held "
                << r.ambiguous_after_hold << ", own rejected " << r.own_rejected << ", median separation "
                << r.median_separation);
  CHECK(r.nodes > 500);
  CHECK(r.own_rejected == 0);  // noise-free: the press's own position fits its own ramp
  CHECK(r.ambiguous_after_hold > 0.95 * r.ambiguous_at_peak);
  CHECK(r.ambiguous_after_ramp < 0.6 * r.ambiguous_after_hold);
}

TEST_CASE("the ramp statistic of the true press follows chi2 with its degrees of freedom", "[mapping][ramp]") {
  // 300 noisy ramps (30 samples 0.3–1.5 N, 0.05 pC) of a press between the nodes, fitted
  // from the truth: mean χ² = dof = 58 (σ of the mean √(2·58/300) = 0.62), and the 0.999
  // quantile is exceeded rarely.
  const ChargeMap map = turning_map();
  const Locator locator(map);
  const MapInterpolant& in = locator.interpolant();
  const double x = 3.3e-3, y = -2.7e-3, sigma = 0.05e-12;
  const int n = 30;
  const std::vector<double> s(3, sigma);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, sigma);
  double sum = 0;
  int above = 0;
  const double limit = chi2_quantile(58, 1e-3);
  for (int t = 0; t < 300; ++t) {
    std::vector<double> q(std::size_t(n) * 3);
    for (int i = 0; i < n; ++i) {
      const double f = 1.5 * (0.2 + 0.8 * i / double(n - 1));
      REQUIRE(in.evaluate(x, y, std::log(f), &q[std::size_t(i) * 3], nullptr));
      for (int k = 0; k < 3; ++k) q[std::size_t(i) * 3 + std::size_t(k)] += noise(rng);
    }
    const RampFit fit = fit_ramp(in, q.data(), n, s.data(), x, y, 1.5, 0.03, 4.0);
    REQUIRE(std::isfinite(fit.chi2));
    CHECK(std::hypot(fit.x_m - x, fit.y_m - y) < 0.2e-3);
    sum += fit.chi2;
    above += fit.chi2 > limit;
  }
  INFO("mean chi2 " << sum / 300 << ", above the 0.999 quantile " << above);
  CHECK(sum / 300 == Approx(58).margin(2.5));
  CHECK(above <= 3);
}
