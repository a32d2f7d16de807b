// The map interpolant against the analytic model: exact at nodes, 4th-order convergence
// between them, gradients equal to finite differences, the force law exact for a membrane.
#include "fixture.hpp"

#include "pvdf/mapping/interpolant.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include "../test_worst.hpp"

using namespace pvdf::mapping;

namespace {

/// Max relative error of electrode 0 over random points in r < 20 mm.
double max_error(double spacing) {
  SyntheticModel model;
  const MapInterpolant f(build_synthetic_map(model, spacing, 3e-3, {1.0}, 1e-13));
  const auto points = pvdf_test::random_presses(400, 0.02, 1.0, 1.0, 4);
  double worst = 0;
  for (const auto& p : points) {
    double q[3];
    REQUIRE(f.evaluate(p.x_m, p.y_m, 0.0, q, nullptr));
    for (std::size_t k = 0; k < 3; ++k) {
      const double exact = model.charge_C(p.x_m, p.y_m, 1.0, k);
      worst = pvdf::testing::worst_of(worst, std::abs(q[k] - exact) / exact);
    }
  }
  return worst;
}

}  // namespace

TEST_CASE("the interpolant reproduces node values and converges at 4th order", "[mapping][interpolant]") {
  SyntheticModel model;
  const ChargeMap map = build_synthetic_map(model, 2e-3, 3e-3, {1.0}, 1e-13);
  const MapInterpolant f(map);
  for (std::size_t j = 5; j < map.ny() - 5; j += 3) {
    for (std::size_t i = 5; i < map.nx() - 5; i += 3) {
      if (!f.node_usable(i, j) || !f.inside(map.x_m[i], map.y_m[j])) continue;
      double q[3];
      REQUIRE(f.evaluate(map.x_m[i], map.y_m[j], 0.0, q, nullptr));
      for (std::size_t k = 0; k < 3; ++k) CHECK(q[k] == Approx(map.charge_C[map.charge_index(0, j, i, k)]).epsilon(1e-12));
    }
  }
  const double e2 = max_error(2e-3), e1 = max_error(1e-3), e05 = max_error(0.5e-3);
  INFO("max relative error: h = 2 mm " << e2 << ", 1 mm " << e1 << ", 0.5 mm " << e05);
  CHECK(e2 / e1 > 8.0);    // 16 for 4th order; allow the pre-asymptotic regime
  CHECK(e1 / e05 > 10.0);
  CHECK(e05 < 1e-3);
}

TEST_CASE("interpolant gradients match central differences of its values", "[mapping][interpolant]") {
  SyntheticModel model;
  model.force_skew = 0.05;
  const MapInterpolant f(build_synthetic_map(model, 1e-3, 3e-3, {0.5, 1.0, 2.0}, 1e-13));
  const auto points = pvdf_test::random_presses(50, 0.03, 0.6, 1.8, 6);
  for (const auto& p : points) {
    const double l = std::log(p.force_N);
    double q[3], qp[3], qm[3];
    std::array<double, 3> dq[3];
    REQUIRE(f.evaluate(p.x_m, p.y_m, l, q, dq));
    const double hx = 1e-7, hl = 1e-6;
    const double steps[3][3] = {{hx, 0, 0}, {0, hx, 0}, {0, 0, hl}};
    for (int d = 0; d < 3; ++d) {
      // Stay inside one cell/level interval: skip steps that cross a node line.
      if (!f.evaluate(p.x_m + steps[d][0], p.y_m + steps[d][1], l + steps[d][2], qp, nullptr)) continue;
      if (!f.evaluate(p.x_m - steps[d][0], p.y_m - steps[d][1], l - steps[d][2], qm, nullptr)) continue;
      const double h = steps[d][0] + steps[d][1] + steps[d][2];
      for (int k = 0; k < 3; ++k) {
        const double fd = (qp[k] - qm[k]) / (2 * h);
        CHECK(dq[k][std::size_t(d)] == Approx(fd).epsilon(1e-4).margin(1e-6 * std::abs(q[k]) / h * 1e-3));
      }
    }
  }
}

TEST_CASE("between force levels a pure membrane map follows F^(2/3) exactly", "[mapping][interpolant]") {
  SyntheticModel model;  // force_skew = 0: Q ∝ F^(2/3)
  const MapInterpolant f(build_synthetic_map(model, 1e-3, 3e-3, {0.5, 2.0}, 1e-13));
  double q1[3], q[3];
  REQUIRE(f.evaluate(0.0037, -0.0061, 0.0, q1, nullptr));
  for (double F : {0.1, 0.7, 1.3, 5.0}) {
    REQUIRE(f.evaluate(0.0037, -0.0061, std::log(F), q, nullptr));
    for (int k = 0; k < 3; ++k) CHECK(q[k] == Approx(q1[k] * std::pow(F, 2.0 / 3.0)).epsilon(1e-12));
  }
  // Outside the mask there is no value.
  CHECK_FALSE(f.evaluate(0.0445, 0.0, 0.0, q, nullptr));
  CHECK_FALSE(f.inside(0.1, 0.0));
}
