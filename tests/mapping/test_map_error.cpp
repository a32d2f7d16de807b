// A map's per-node error estimate against the truth: at interior and rim nodes of a small film's
// map, converged direct solves that keep bending (the independent reference: pvdf::fem::solve,
// adaptive, its own mesh graded to the probe) give each node's true charge error; it must lie
// within the map's tolerance, and the stored estimate (/estimated_charge_error_C) must be within
// [0.5, 3] of it wherever it exceeds 1e-3. The map file carries the estimates (format 2) and which
// model solved each node (/model).
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/fem/solver.hpp"
#include "pvdf/mapping/generate.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>

using namespace pvdf::mapping;

namespace {

// 10 mm film, 25 µm, three 1.5 mm electrodes: the bending layer at the clamp is ~0.1 mm wide.
pvdf::Scene film() {
  return pvdf::parse_scene(nlohmann::json::parse(R"({
    "membrane": {"shape": "circle", "radius_m": 0.010, "thickness_m": 25e-6, "pretension_N_per_m": 0.0},
    "material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "G12_Pa": 0.58e9, "nu12": 0.35,
                 "draw_angle_deg": 0.0, "d31_C_per_N": 6.5e-12, "d32_C_per_N": 0.65e-12},
    "electrodes": [
      {"name": "A", "center_m": [0.0, 0.004], "size_m": [0.0015, 0.0015], "angle_deg": 0.0},
      {"name": "B", "center_m": [-0.0035, -0.002], "size_m": [0.0015, 0.0015], "angle_deg": 0.0},
      {"name": "C", "center_m": [0.0035, -0.002], "size_m": [0.0015, 0.0015], "angle_deg": 0.0}
    ],
    "probe": {"radius_m": 0.001},
    "loads": [{"position_m": [0.0, 0.0], "force_N": 1.0}],
    "model": {"kinematics": "auto", "tolerance": 0.01, "max_refinements": 6}
  })"), "map-error-film");
}

std::size_t index_of(const std::vector<double>& axis, double v) {
  for (std::size_t i = 0; i < axis.size(); ++i) {
    if (std::abs(axis[i] - v) < 1e-9) return i;
  }
  FAIL("grid has no node at " << v);
  return 0;
}

}  // namespace

TEST_CASE("a map's per-node charge error estimates match the true error at interior and rim nodes",
          "[mapping][generate][error]") {
  const pvdf::Scene scene = film();
  MapOptions o;
  o.spacing_m = 0.002;
  o.forces_N = {1.0};
  o.region_m = std::array<double, 4>{0.0, 0.008, 0.0, 0.008};  // a quadrant out to the served edge (8 mm)
  o.tolerance = 0.01;
  o.threads = 1;
  o.use_symmetry = false;
  MapReport report;
  const ChargeMap map = generate_map(scene, o, &report);
  REQUIRE(report.n_failed == 0);
  REQUIRE(map.estimated_charge_error_C.size() == map.charge_C.size());
  REQUIRE(report.node_model.size() == map.status.size());

  // Interior (centre, between electrodes) and rim nodes (r = 7.2 and 6.3 mm: within 2 mm of the
  // served edge r = 8 mm, 2.8 and 3.7 mm from the clamp).
  const std::vector<std::array<double, 2>> nodes{{0.0, 0.0}, {0.002, 0.002}, {0.006, 0.004}, {0.004, 0.006}, {0.006, 0.002}};
  pvdf::fem::Options direct = pvdf::fem::options_from_scene(scene);
  direct.model = pvdf::fem::Model::large_rotation;
  direct.include_bending = true;
  direct.tolerance = 0.001;
  int judged = 0;
  for (const auto& p : nodes) {
    const std::size_t i = index_of(map.x_m, p[0]), j = index_of(map.y_m, p[1]);
    REQUIRE(map.status[map.point(0, j, i)] == std::uint8_t(PointStatus::ok));
    const pvdf::fem::Result r = pvdf::fem::solve(pvdf::with_probe_load(scene, p[0], p[1], 1.0), direct);
    REQUIRE(pvdf::fem::usable(r.summary.status));
    double diff = 0, ref_scale = 0, est = 0, scale = 0;
    for (std::size_t k = 0; k < map.ne(); ++k) {
      const std::size_t c = map.charge_index(0, j, i, k);
      diff = std::max(diff, std::abs(map.charge_C[c] - r.electrodes[k].charge_C));
      ref_scale = std::max(ref_scale, std::abs(r.electrodes[k].charge_C));
      est = std::max(est, map.estimated_charge_error_C[c]);
      scale = std::max(scale, std::abs(map.charge_C[c]));
    }
    const double truth = diff / ref_scale, estimate = est / scale;
    INFO("node (" << p[0] * 1e3 << ", " << p[1] * 1e3 << ") mm, model " << int(report.node_model[map.point(0, j, i)])
                  << ": true error " << truth << ", estimate " << estimate << ", reference estimate "
                  << r.summary.estimated_relative_error);
    CHECK(truth <= o.tolerance);
    if (truth > 1e-3) {
      ++judged;
      CHECK(estimate >= 0.5 * truth);
      CHECK(estimate <= 3.0 * truth);
    }
  }
  CHECK(judged >= 1);  // the test must judge at least one estimate
}
