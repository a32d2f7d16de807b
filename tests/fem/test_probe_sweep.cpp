// pvdf::fem::ProbeSweep (one fixed mesh, warm starts) against independent direct solves
// (pvdf::fem::solve on a mesh graded to each probe), and against the physics it must respect:
// mirror symmetry of the seed-001 layout, equilibrium of the rim reaction, Newton's own
// tolerance for warm against cold starts, and the pure-membrane force scaling of warm starts.
#include "pvdf/fem/probe_sweep.hpp"

#include "pvdf/core/error.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>

namespace {

const pvdf::Scene& seed001() {
  static const pvdf::Scene scene = pvdf::load_scene(std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json");
  return scene;
}

/// One sweep for the whole file (its setup runs the three check solves once).
pvdf::fem::ProbeSweep& seed001_sweep() {
  static pvdf::fem::ProbeSweep sweep(seed001(), pvdf::fem::SweepOptions{});
  return sweep;
}

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

/// max_k |a_k − b_k| / max_k |b_k|, the charge error measure of the sweep.
double charge_difference(const std::vector<double>& a, const std::vector<double>& b) {
  REQUIRE(a.size() == b.size());
  double d = 0;
  for (std::size_t k = 0; k < a.size(); ++k) d = std::max(d, std::abs(a[k] - b[k]));
  return d / max_abs(b);
}

pvdf::fem::Result direct_solve(double x, double y, double F) {
  const pvdf::Scene s = pvdf::with_probe_load(seed001(), x, y, F);
  pvdf::fem::Options o = pvdf::fem::options_from_scene(s);
  o.adaptive = false;  // the default mesh graded to this probe (error ~1e-3, docs/bench-fem.md)
  return pvdf::fem::solve(s, o);
}

}  // namespace

TEST_CASE("probe sweep setup: auto model, estimated charge error within the tolerance", "[fem][sweep]") {
  const auto& setup = seed001_sweep().setup();
  INFO(setup.model_reason << " | " << setup.error_estimator);
  CHECK(setup.model == pvdf::fem::Model::large_rotation);
  CHECK_FALSE(setup.include_bending);
  CHECK(setup.n_dofs > 0);
  // The mesh is sized by the discretization part (half the tolerance). The cheap model's total may
  // exceed the tolerance where bending's effect (the clamp layer's, docs/fem.md §6.1) is near half of
  // it: such probes go on to the clamp-layer condition (the next test case checks the charges).
  // Since r17 seed 001's worst check states 1.0003 %: its model part now counts the layer.
  CHECK(setup.estimated_discretization_error <= 0.5 * 0.01);
  CHECK(setup.estimated_discretization_error <= setup.estimated_relative_error);
  CHECK(setup.estimated_relative_error <= 0.02);
}

TEST_CASE("probe sweep charges equal direct solves within the tolerance", "[fem][sweep]") {
  auto& sweep = seed001_sweep();
  // Positions other than the setup's own checks: near electrode B, between A and C, and (12, -12) mm,
  // where the 1 mm footprint lies in cells of several times its size (on the sweep mesh alone the
  // charges there were 1.6 % off, with an estimate of 0.28 %: docs/map-generation.md §6).
  for (const auto& p : {std::array<double, 2>{-0.008, -0.004}, std::array<double, 2>{0.013, 0.006},
                        std::array<double, 2>{0.012, -0.012}}) {
    const auto s = sweep.solve(p[0], p[1], 1.0);
    REQUIRE(pvdf::fem::usable(s.status));
    const auto r = direct_solve(p[0], p[1], 1.0);
    REQUIRE(pvdf::fem::usable(r.summary.status));
    std::vector<double> q_direct;
    for (const auto& e : r.electrodes) q_direct.push_back(e.charge_C);
    INFO("probe at (" << p[0] << ", " << p[1] << ") m");
    CHECK(charge_difference(s.charge_C, q_direct) <= 0.01);
    CHECK(charge_difference(s.charge_C, q_direct) <= 3 * s.estimated_relative_error + 2e-3);  // the estimate sees it
    CHECK(s.rim_reaction_N == Approx(1.0).epsilon(1e-6));
  }
}

TEST_CASE("probe sweep: warm start equals cold start to Newton tolerance, in fewer iterations", "[fem][sweep]") {
  auto& sweep = seed001_sweep();
  pvdf::fem::SweepState neighbour;
  const auto a = sweep.solve(0.004, 0.003, 1.0, nullptr, &neighbour);
  REQUIRE(pvdf::fem::usable(a.status));
  CHECK_FALSE(a.warm_started);
  const auto cold = sweep.solve(0.005, 0.003, 1.0);
  const auto warm = sweep.solve(0.005, 0.003, 1.0, &neighbour);
  REQUIRE(pvdf::fem::usable(cold.status));
  REQUIRE(pvdf::fem::usable(warm.status));
  CHECK(warm.warm_started);
  CHECK(warm.newton_iterations < cold.newton_iterations);
  CHECK(charge_difference(warm.charge_C, cold.charge_C) < 1e-7);
  CHECK(warm.deflection_at_load_m == Approx(cold.deflection_at_load_m).epsilon(1e-7));
  CHECK(warm.rim_reaction_N == Approx(1.0).epsilon(1e-6));

  // Across forces: the state at 1 N scaled by the membrane law (w ∝ F^(1/3)) starts the 0.4 N solve.
  pvdf::fem::SweepState at_1N;
  REQUIRE(pvdf::fem::usable(sweep.solve(0.005, 0.003, 1.0, &neighbour, &at_1N).status));
  const auto scaled = sweep.solve(0.005, 0.003, 0.4, &at_1N);
  const auto scaled_cold = sweep.solve(0.005, 0.003, 0.4);
  REQUIRE(pvdf::fem::usable(scaled.status));
  REQUIRE(pvdf::fem::usable(scaled_cold.status));
  CHECK(scaled.warm_started);
  CHECK(charge_difference(scaled.charge_C, scaled_cold.charge_C) < 1e-7);
  CHECK(scaled.rim_reaction_N == Approx(0.4).epsilon(1e-6));
  // Pure membrane without bending: charges ∝ F^(2/3) (large-rotation kinematics: nearly).
  CHECK(charge_difference(scaled.charge_C, std::vector<double>{warm.charge_C[0] * std::cbrt(0.16),
                                                               warm.charge_C[1] * std::cbrt(0.16),
                                                               warm.charge_C[2] * std::cbrt(0.16)}) < 0.01);
}

TEST_CASE("probe sweep: mirror-symmetric probes give mirrored charges (B <-> C)", "[fem][sweep]") {
  auto& sweep = seed001_sweep();
  const auto right = sweep.solve(0.006, -0.002, 1.0);
  const auto left = sweep.solve(-0.006, -0.002, 1.0);
  REQUIRE(pvdf::fem::usable(right.status));
  REQUIRE(pvdf::fem::usable(left.status));
  const double scale = max_abs(right.charge_C);
  CHECK(std::abs(right.charge_C[0] - left.charge_C[0]) <= 1e-6 * scale);
  CHECK(std::abs(right.charge_C[1] - left.charge_C[2]) <= 1e-6 * scale);
  CHECK(std::abs(right.charge_C[2] - left.charge_C[1]) <= 1e-6 * scale);
  CHECK(right.deflection_at_load_m == Approx(left.deflection_at_load_m).epsilon(1e-6));
  // The probe near C loads C more than B.
  CHECK(right.charge_C[2] > right.charge_C[1]);
}

TEST_CASE("probe sweep refuses probes outside the served region and bad forces", "[fem][sweep]") {
  auto& sweep = seed001_sweep();
  CHECK_THROWS_AS(sweep.solve(0.0446, 0.0, 1.0), pvdf::InputError);  // footprint crosses the rim
  CHECK_THROWS_AS(sweep.solve(0.0, 0.0, -1.0), pvdf::InputError);
  CHECK_THROWS_AS(sweep.solve(std::nan(""), 0.0, 1.0), pvdf::InputError);
}
