// Hard cases of the issue: each must converge (with the rim carrying the applied force) or fail
// with a clear status — never NaN. Coarse meshes: these test robustness, not accuracy.
#include "pvdf/fem/solver.hpp"

#include <catch2/catch.hpp>

#include <cmath>

namespace {

pvdf::fem::Options coarse(pvdf::fem::Model model = pvdf::fem::Model::large_rotation) {
  pvdf::fem::Options o;
  o.model = model;
  o.adaptive = false;
  o.coarse_size_m = 0.045 / 3;
  o.probe_size_m = 1e-3;
  o.electrode_size_m = 1e-3;
  return o;
}

void check_usable(const pvdf::Scene& s, const pvdf::fem::Options& o, double total_force_N) {
  const auto r = pvdf::fem::solve(s, o);
  INFO(pvdf::fem::status_name(r.summary.status) << ": " << r.summary.message << " (" << r.summary.newton_iterations
                                                << " Newton iterations, " << r.summary.load_steps << " steps)");
  REQUIRE(pvdf::fem::usable(r.summary.status));
  CHECK(std::isfinite(r.max_deflection_m));
  CHECK(std::isfinite(r.deflection_at_load_m));
  for (const auto& e : r.electrodes)
    for (double v : e.mean_membrane_force_material_N_per_m) CHECK(std::isfinite(v));
  CHECK(r.rim_reaction_N == Approx(total_force_N).epsilon(1e-4));
  // A downward force gives a downward film.
  if (total_force_N > 0) {
    CHECK(r.deflection_at_load_m > 0);
  }
}

pvdf::Load probe(double x, double y, double F) {
  pvdf::Load l;
  l.position_m = {x, y};
  l.force_N = F;
  return l;
}

}  // namespace

TEST_CASE("thickness 1 um and 2 mm", "[fem][hard]") {
  pvdf::Scene s = pvdf::default_scene();
  s.membrane.thickness_m = 1e-6;
  check_usable(s, coarse(), 1.0);
  s.membrane.thickness_m = 2e-3;
  check_usable(s, coarse(), 1.0);
}

TEST_CASE("strong orthotropy E1/E2 = 20 at an oblique draw angle", "[fem][hard]") {
  pvdf::Scene s = pvdf::default_scene();
  s.material.E1_Pa = 4e9;
  s.material.E2_Pa = 0.2e9;
  s.material.nu12 = 0.35;
  s.material.draw_angle_rad = 0.5;
  check_usable(s, coarse(), 1.0);
}

TEST_CASE("probe footprint 0.5 mm from the rim, and a probe on an electrode corner", "[fem][hard]") {
  pvdf::Scene s = pvdf::default_scene();
  s.loads = {probe(0.045 - 0.0015, 0.0, 1.0)};
  check_usable(s, coarse(), 1.0);
  s.loads = {probe(0.001, 0.011, 1.0)};  // corner (1, 11) mm of electrode A
  check_usable(s, coarse(), 1.0);
}

TEST_CASE("force from 1e-6 N to 20 N, several probes at once", "[fem][hard]") {
  pvdf::Scene s = pvdf::default_scene();
  s.loads = {probe(0, 0, 1e-6)};
  check_usable(s, coarse(), 1e-6);
  s.loads = {probe(0, 0, 20.0)};
  check_usable(s, coarse(), 20.0);
  s.loads = {probe(0.01, 0.0, 0.5), probe(-0.01, 0.01, 0.7)};
  check_usable(s, coarse(), 1.2);
}

TEST_CASE("pretension 0 and 100 N/m; automatic model choice", "[fem][hard]") {
  pvdf::Scene s = pvdf::default_scene();
  s.membrane.pretension_N_per_m = 100.0;
  check_usable(s, coarse(), 1.0);
  s.membrane.pretension_N_per_m = 0.0;
  auto o = coarse(pvdf::fem::Model::automatic);
  const auto r = pvdf::fem::solve(s, o);
  REQUIRE(pvdf::fem::usable(r.summary.status));
  // 1 N on 25 µm deflects ~100 thicknesses: never the linear plate.
  CHECK(r.summary.model != pvdf::fem::Model::linear);
  CHECK(!r.summary.model_reason.empty());
  // A tiny force on a thick film is the linear plate regime.
  s.membrane.thickness_m = 1e-3;
  s.loads = {probe(0, 0, 1e-3)};
  const auto lin = pvdf::fem::solve(s, o);
  REQUIRE(pvdf::fem::usable(lin.summary.status));
  CHECK(lin.summary.model == pvdf::fem::Model::linear);
}
