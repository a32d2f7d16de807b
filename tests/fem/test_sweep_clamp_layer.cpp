// The map sweep's clamp-layer ladder (fem::ProbeSweep; docs/fem.md §3.4, docs/map-generation.md §6)
// against the independent axisymmetric oracle with bending (tests/fem/oracles): the films of
// test_fem_clamp_layer (15 mm radius, thick enough that the clamp's bending layer is 2–4 % of the
// radius, a centred 3 mm probe, the outer electrode 1.3 mm from the clamp), where the cheap sweep
// model (large-rotation membrane without bending) misses bending's effect by 2–3 % of the largest
// charge. The sweep must send the probe to the clamp-layer condition (not the rim-graded mesh),
// come closer to the oracle than the cheap model, and state a per-node error that covers its true
// error without being absurdly cautious. Comparisons fail on NaN.
#include "clamp_layer_films.hpp"
#include "oracle_compare.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/fem/probe_sweep.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

using namespace pvdf::fem::testing;
namespace oracles = pvdf::fem::oracles;

namespace {

using namespace pvdf::fem::testing::clamp_films;

// The map's sweep settings at a tolerance of 2 % (below bending's effect, so the ladder acts; the
// condition's share 3/4 · 2 % lets its estimate be measured rather than acted on, as in
// test_fem_clamp_layer). No setup checks: the first sweep mesh, as `map --setup-checks 0`.
pvdf::fem::SweepOptions sweep_options(double force_N, pvdf::fem::SweepOptions::RimModel rim) {
  pvdf::fem::SweepOptions o;
  o.solver.tolerance = 0.02;
  o.forces_N = {force_N};
  o.n_setup_checks = 0;
  o.rim_model = rim;
  return o;
}

}  // namespace

TEST_CASE("sweep near the clamp: clamp-layer condition against the axisymmetric oracle", "[fem][sweep][clamp][oracle]") {
  struct Case {
    double h_m, force_N;
  };
  // Not the 50 µm, 1 N film: the condition's constant K was calibrated on it (clamp_layer.cpp).
  for (const Case c : {Case{50e-6, 0.3}, Case{75e-6, 1.0}}) {
    const pvdf::Scene s = clamp_scene(c.h_m, c.force_N);
    const auto bent = oracles::solve_axisymmetric(oracle_problem(s, true, oracles::Kinematics::green_lagrange));
    REQUIRE(bent.converged);
    std::vector<double> q_oracle;
    for (const auto& e : s.electrodes) q_oracle.push_back(oracle_electrode_charge(bent, s, e, 8));

    pvdf::fem::ProbeSweep cheap(s, sweep_options(c.force_N, pvdf::fem::SweepOptions::RimModel::never));
    const pvdf::fem::ProbeSolution p = cheap.solve(0, 0, c.force_N);
    pvdf::fem::ProbeSweep sweep(s, sweep_options(c.force_N, pvdf::fem::SweepOptions::RimModel::by_estimate));
    REQUIRE(sweep.setup().clamp_layer_condition);
    const pvdf::fem::ProbeSolution n = sweep.solve(0, 0, c.force_N);
    INFO(p.message << " / " << n.message);
    REQUIRE(pvdf::fem::usable(p.status));
    REQUIRE(pvdf::fem::usable(n.status));
    const double e_cheap = relative_error(p.charge_C, q_oracle);
    const double e_node = relative_error(n.charge_C, q_oracle);
    const double stated = n.estimated_relative_error;
    std::printf("SWEEP-CLAMP h %.0f um, F %.1f N: cheap %.3e (stated %.3e, model part sent it on: %.3e); node model %d "
                "%.3e, stated %.3e (clamp part %.3e), stated/true %.2f; %s\n",
                c.h_m * 1e6, c.force_N, e_cheap, p.estimated_relative_error, n.cheap_model_relative_error,
                int(n.model_used), e_node, stated, n.clamp_layer_relative_error, stated / e_node, n.message.c_str());
    // The ladder: the cheap model's bending estimate sent the probe on, and the condition kept it
    // (no rim-graded mesh was built).
    CHECK(n.model_used == pvdf::fem::SweepModel::clamp_layer);
    CHECK(sweep.timing().rim_solves == 0);
    CHECK(sweep.timing().clamp_layer_solves == 1);
    CHECK(n.clamp_layer_relative_error > 0);
    CHECK(std::abs(n.rim_reaction_N - c.force_N) <= 1e-6 * c.force_N);
    // Closer to the oracle with bending than the bending-free plain clamp, by a clear factor.
    CHECK(e_node <= e_cheap / 2);
    CHECK(e_node <= 0.02);
    // The stated per-node error (discretization + bending's remaining effect + the condition's
    // estimate) covers the true error and is not absurdly cautious.
    CHECK(stated / e_node >= 0.5);
    CHECK(stated / e_node <= 3.0);
  }
}

TEST_CASE("sweep near the clamp: PVDF_CLAMP_LAYER=rim-graded selects the rim-graded path", "[fem][sweep][clamp]") {
  const pvdf::Scene s = clamp_scene(75e-6, 1.0);
  auto o = sweep_options(1.0, pvdf::fem::SweepOptions::RimModel::by_estimate);
  {
    pvdf::fem::ProbeSweep sweep(s, o);
    CHECK(sweep.setup().clamp_layer_condition);
  }
  ::setenv("PVDF_CLAMP_LAYER", "rim-graded", 1);
  pvdf::fem::ProbeSweep rim(s, o);
  ::unsetenv("PVDF_CLAMP_LAYER");
  CHECK_FALSE(rim.setup().clamp_layer_condition);
  CHECK(rim.setup().rim_model_available);
  ::setenv("PVDF_CLAMP_LAYER", "sideways", 1);
  CHECK_THROWS_AS(pvdf::fem::ProbeSweep(s, o), pvdf::InputError);
  ::unsetenv("PVDF_CLAMP_LAYER");
  o.solver.clamp_layer_condition = false;  // the option itself, as the env switch sets it
  pvdf::fem::ProbeSweep off(s, o);
  CHECK_FALSE(off.setup().clamp_layer_condition);
}
