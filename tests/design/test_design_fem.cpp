// The design bound on a real (FEM) map: the Jacobian the design takes from a coarse map's
// interpolant agrees with finite differences of direct FEM probe solves, so the Cramér–Rao
// bound of the map is the bound of the physics (within the map's interpolation error).
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/mapping/design.hpp"
#include "pvdf/mapping/generate.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pvdf::mapping;

TEST_CASE("the bound from a coarse FEM map matches the bound from direct FEM solves", "[design][fem][slow]") {
  const pvdf::Scene scene = pvdf::default_scene();  // seed 001
  // Step 1: a 5 × 5 map at 2 mm around the press (2, 2) mm — enough for 4th-order node slopes there.
  MapOptions mo;
  mo.spacing_m = 0.002;
  mo.forces_N = {1.0};
  mo.region_m = std::array<double, 4>{-0.0005, 0.0065, -0.0005, 0.0065};
  mo.threads = 1;
  mo.use_symmetry = false;
  const ChargeMap map = generate_map(scene, mo);
  DesignOptions o;
  o.adc_bits = 0;
  o.noise_C = {0.05e-12};
  o.check_ambiguity = false;
  const DesignSummary d = evaluate_design(map, o);
  const double h = d.maps.x_m[1] - d.maps.x_m[0];
  const std::size_t node = d.maps.index(std::size_t(std::llround((0.002 - d.maps.x_m[0]) / h)),
                                        std::size_t(std::llround((0.002 - d.maps.y_m[0]) / h)));
  REQUIRE(d.maps.evaluated[node]);

  // Step 2: the Jacobian by central differences of direct solves (±1 mm, ±20 % in ln F: steps large against the solve-to-solve discretization noise).
  pvdf::fem::SweepOptions so;
  so.forces_N = {1.0};
  // One mesh for all seven solves: a mesh refined around each footprint (the map's default) moves
  // with the probe, and its solve-to-solve discretization noise (~1e-3 of the charges) is not small
  // against the differences of ±1 mm (measured: the force-unknown bound 2.4 mm instead of 0.34).
  so.probe_size_m = -1;
  pvdf::fem::ProbeSweep sweep(scene, so);
  auto charges = [&](double x, double y, double f) {
    const auto s = sweep.solve(x, y, f);
    REQUIRE(pvdf::fem::usable(s.status));
    return s.charge_C;
  };
  const double dx = 0.001, dl = 0.2;
  const auto xp = charges(0.002 + dx, 0.002, 1.0), xm = charges(0.002 - dx, 0.002, 1.0);
  const auto yp = charges(0.002, 0.002 + dx, 1.0), ym = charges(0.002, 0.002 - dx, 1.0);
  const auto fp = charges(0.002, 0.002, std::exp(dl)), fm = charges(0.002, 0.002, std::exp(-dl));
  std::vector<std::array<double, 3>> jac(map.ne());
  for (std::size_t k = 0; k < map.ne(); ++k) {
    jac[k] = {(xp[k] - xm[k]) / (2 * dx), (yp[k] - ym[k]) / (2 * dx), (fp[k] - fm[k]) / (2 * dl)};
  }
  const PointBound known = cramer_rao_bound(jac, {0.05e-12, 0.05e-12, 0.05e-12}, true);
  const PointBound unknown = cramer_rao_bound(jac, {0.05e-12, 0.05e-12, 0.05e-12}, false);
  INFO("map bound " << d.maps.sigma_pos_known_force_m[node] * 1e3 << " mm (force known), "
                    << d.maps.sigma_pos_unknown_force_m[node] * 1e3 << " mm (unknown); direct FEM "
                    << known.sigma_pos_m * 1e3 << " / " << unknown.sigma_pos_m * 1e3 << " mm");
  REQUIRE_FALSE(known.singular);
  CHECK(d.maps.sigma_pos_known_force_m[node] == Approx(known.sigma_pos_m).epsilon(0.2));
  // With the force unknown the bound hinges on how far ∂q/∂ln F is from a combination of the
  // position columns; a one-level map assumes ∂q/∂ln F = (2/3)·q (the membrane law), which the
  // large-rotation FEM departs from: measured 0.349 (map) vs 0.265 mm (direct), so only the
  // order is asserted here (docs/design.md §3).
  CHECK(d.maps.sigma_pos_unknown_force_m[node] == Approx(unknown.sigma_pos_m).epsilon(0.5));
}
