// Newton's stagnation limit (issue 30; Options::stagnation_iterations): films at the physical limits
// (E2 = 2.2e-3 Pa, nu12 = -0.99, pretension -1e9 N/m) — refused by the scene parser, but reachable
// through the library API — must end with a non-converged status after a bounded number of Newton
// iterations, not stir the residual for the whole iteration cap of every continuation stage.
// Each case is first run with the limit switched off, to show that it really stagnates: Newton
// then needs more than the limit's bound — on this coarse mesh the pretension case never
// converges, E2 and nu12 crawl to convergence in 175-195 iterations (at 127k DOFs: minutes) —
// then with the default limit.
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/solver.hpp"

#include <catch2/catch.hpp>

#include <string>

namespace {

pvdf::fem::Options coarse_cold() {
  pvdf::fem::Options o;
  o.model = pvdf::fem::Model::large_rotation;
  o.adaptive = false;
  o.coarse_size_m = 0.045 / 3;
  o.probe_size_m = 2e-3;
  o.electrode_size_m = 4e-3;
  o.grade_rim_for_bending = false;
  o.include_bending = false;
  o.estimate_bending_effect = false;
  o.max_newton_iterations = 120;  // a cap the limit must beat by far
  o.max_cutbacks = 1;
  return o;
}

// Without the limit the film needs more Newton iterations than the limit's bound; with it, it
// stops with no_convergence ("stagnated") within that bound.
void check_stops_early(const std::string& name, const pvdf::Scene& s) {
  const pvdf::fem::Options on = coarse_cold();
  // At most max_stagnated_stages stages of at most a few windows each.
  const int bound = 4 * on.stagnation_iterations * on.max_stagnated_stages;
  pvdf::fem::Options off = coarse_cold();
  off.stagnation_iterations = 0;  // no limit: the iteration cap decides
  const auto r_off = pvdf::fem::solve(s, off);
  INFO(name << " without the limit: " << pvdf::fem::status_name(r_off.summary.status) << ", "
            << r_off.summary.newton_iterations << " Newton iterations: " << r_off.summary.message);
  REQUIRE(r_off.summary.newton_iterations > bound);

  const auto r_on = pvdf::fem::solve(s, on);
  INFO(name << " with the limit: " << pvdf::fem::status_name(r_on.summary.status) << ", "
            << r_on.summary.newton_iterations << " Newton iterations: " << r_on.summary.message);
  CHECK(r_on.summary.status == pvdf::fem::Status::no_convergence);
  CHECK(r_on.summary.message.find("stagnated") != std::string::npos);
  CHECK(r_on.summary.newton_iterations <= bound);
}

}  // namespace

TEST_CASE("Newton stops early on a stagnating film", "[fem][newton]") {
  pvdf::Scene s = pvdf::default_scene();
  SECTION("E2 = 2.2e-3 Pa") {
    s.material.E2_Pa = 2.2e-3;
    check_stops_early("E2", s);
  }
  SECTION("nu12 = -0.99 with E2 = E1") {
    s.material.E2_Pa = s.material.E1_Pa;
    s.material.nu12 = -0.99;
    check_stops_early("nu12", s);
  }
  SECTION("pretension -1e9 N/m") {
    s.membrane.pretension_N_per_m = -1e9;
    check_stops_early("N0", s);
  }
}

TEST_CASE("the stagnation limit leaves a converging solve alone", "[fem][newton]") {
  // Seed 001's film at 1 N, the same coarse mesh: it converges with the limit as without it, with
  // the same Newton iterations and the same answer (the limit only ever stops a solve).
  const pvdf::Scene s = pvdf::default_scene();
  pvdf::fem::Options off = coarse_cold();
  off.stagnation_iterations = 0;
  const auto r_off = pvdf::fem::solve(s, off);
  const auto r_on = pvdf::fem::solve(s, coarse_cold());
  REQUIRE(r_off.summary.status == pvdf::fem::Status::converged);
  REQUIRE(r_on.summary.status == pvdf::fem::Status::converged);
  CHECK(r_on.summary.newton_iterations == r_off.summary.newton_iterations);
  CHECK(r_on.deflection_at_load_m == r_off.deflection_at_load_m);
}
