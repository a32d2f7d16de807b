// An answer that breaks a physical bound is never reported as converged (issue 30 item 2,
// fem/src/checks.cpp): a deflection beyond the film's size, or no rim reaction for a nonzero load,
// demotes a "converged" result to no-convergence with the reason and no fields; a plausible
// result is left alone. The scene reader refuses the inputs that lead there (test_hostile_cli),
// so these results are built by hand: they stand for what a solver bug or a bound missed would give.
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/plausibility.hpp"

#include <catch2/catch.hpp>

#include <cmath>

namespace {

/// A converged result of the seed-001 scene (1 N at the centre): deflection 3 mm, reaction 1 N.
pvdf::fem::Result plausible() {
  pvdf::fem::Result r;
  r.summary.status = pvdf::fem::Status::converged;
  r.summary.message = "Newton converged; estimated output error 0.004 <= tolerance 0.01";
  r.max_deflection_m = 3e-3;
  r.deflection_at_load_m = 3e-3;
  r.rim_reaction_N = 1.0;
  r.electrodes.resize(3);
  return r;
}

}  // namespace

TEST_CASE("a plausible converged answer stays converged", "[fem][physical-bounds]") {
  const pvdf::Scene scene = pvdf::default_scene();
  pvdf::fem::Result r = plausible();
  CHECK(pvdf::fem::physical_bound_violation(scene, r).empty());
  CHECK_FALSE(pvdf::fem::enforce_physical_bounds(scene, r));
  CHECK(r.summary.status == pvdf::fem::Status::converged);
  CHECK(r.electrodes.size() == 3);
  // Right at the bounds: a deflection equal to the film's size, a reaction of 2e-6 of the load.
  r.max_deflection_m = -0.045;
  r.rim_reaction_N = 2e-6;
  CHECK(pvdf::fem::physical_bound_violation(scene, r).empty());
}

TEST_CASE("a deflection beyond the film's size is not converged", "[fem][physical-bounds]") {
  const pvdf::Scene scene = pvdf::default_scene();
  pvdf::fem::Result r = plausible();
  r.max_deflection_m = 3.8e10;  // what E = 1e-30 Pa gave on the 45 mm film before the scene bounds
  const std::string why = pvdf::fem::physical_bound_violation(scene, r);
  CHECK(why.find("3.8e+10 m exceeds the film's size 0.045 m") != std::string::npos);
  CHECK(pvdf::fem::enforce_physical_bounds(scene, r));
  CHECK(r.summary.status == pvdf::fem::Status::no_convergence);
  CHECK_FALSE(pvdf::fem::usable(r.summary.status));
  CHECK(r.summary.message.find("physical bound broken") != std::string::npos);
  CHECK(r.electrodes.empty());  // no fields, as every non-usable result
  // The bound scales with the film: 3 m on a 4.5 m film is inside.
  pvdf::Scene big = scene;
  big.membrane.outline.radius_m = 4.5;
  pvdf::fem::Result s = plausible();
  s.max_deflection_m = 3.0;
  CHECK(pvdf::fem::physical_bound_violation(big, s).empty());
  s.max_deflection_m = std::nan("");
  CHECK_FALSE(pvdf::fem::physical_bound_violation(big, s).empty());  // NaN is never inside a bound
}

TEST_CASE("a loaded film with no rim reaction is not converged", "[fem][physical-bounds]") {
  pvdf::Scene scene = pvdf::default_scene();
  pvdf::fem::Result r = plausible();
  r.max_deflection_m = 0;
  r.deflection_at_load_m = 0;
  r.rim_reaction_N = 0;  // what a press of 1e-300 N gave: "converged", a prediction of 0
  CHECK(pvdf::fem::physical_bound_violation(scene, r).find("the rim carries 0 N of the applied 1 N") !=
        std::string::npos);
  CHECK(pvdf::fem::enforce_physical_bounds(scene, r));
  CHECK(r.summary.status == pvdf::fem::Status::no_convergence);
  // A pressure load counts by pressure x area (1 Pa on the 45 mm film: 6.4 mN).
  pvdf::Load p;
  p.kind = pvdf::Load::Kind::pressure;
  p.pressure_Pa = 1.0;
  scene.loads = {p};
  pvdf::fem::Result q = plausible();
  q.rim_reaction_N = 0;
  CHECK(pvdf::fem::physical_bound_violation(scene, q).find("of the applied 0.00636") != std::string::npos);
  // No load: a zero reaction is the exact answer.
  scene.loads.clear();
  CHECK(pvdf::fem::physical_bound_violation(scene, q).empty());
  // A result that is already a failure is not examined.
  pvdf::fem::Result f;
  f.summary.status = pvdf::fem::Status::not_finite;
  CHECK(pvdf::fem::physical_bound_violation(pvdf::default_scene(), f).empty());
}
