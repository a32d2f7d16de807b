// Adaptive placement (docs/map-generation.md §10) audited where a user reads a map: between its
// nodes and force levels. A small 15 mm film with three electrodes is mapped whole (adaptive,
// finest spacing 2 mm, coarse 4 mm, two force levels); at presses drawn at random off the nodes
// and between the levels — a third of them within 3 mm of the served edge — the lookup's charges
// are compared with probe solves made here at a tolerance 25 times tighter, on a sweep mesh the
// test requires to be finer than the map's (independent of the map, its mesh and its
// interpolant). Asserted: the stated total error never falls below half the true error (σ does
// not under-state); where the map states that it met the tolerance the true error is within it;
// and the stated error is sharp: stated / true ≤ 8 in the median (the predictor it replaced, a
// cell's largest coarser surplus over an extrapolated rate, gave 10–16). Not asserted: the issue's
// band (stated / true in [0.5, 3] at ≥ 90 % of the presses whose true error exceeds 1e-3) —
// measured 37 % at 143 presses (docs/map-generation.md §10.3): the 2 mm interpolant's error varies
// within a cell by more than a node-based estimate read bilinearly can follow (even fitted to the
// truth itself: 72 %).
#include "pvdf/core/constants.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/mapping/generate.hpp"
#include "pvdf/mapping/locator.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

using namespace pvdf::mapping;

namespace {

pvdf::Scene film_15mm() {
  const nlohmann::json j = nlohmann::json::parse(R"({
    "membrane": {"shape": "circle", "radius_m": 0.015, "thickness_m": 25e-6, "pretension_N_per_m": 0.0},
    "material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "G12_Pa": 0.58e9, "nu12": 0.35,
                 "draw_angle_deg": 0.0, "d31_C_per_N": 6.5e-12, "d32_C_per_N": 0.65e-12},
    "electrodes": [
      {"name": "A", "center_m": [0.0, 0.005], "size_m": [0.002, 0.002], "angle_deg": 0.0},
      {"name": "B", "center_m": [-0.00433, -0.0025], "size_m": [0.002, 0.002], "angle_deg": 0.0},
      {"name": "C", "center_m": [0.00433, -0.0025], "size_m": [0.002, 0.002], "angle_deg": 0.0}
    ],
    "probe": {"radius_m": 0.001},
    "loads": [{"position_m": [0.0, 0.0], "force_N": 1.0}],
    "model": {"kinematics": "auto", "tolerance": 0.05}
  })");
  return pvdf::parse_scene(j, "film-15mm");
}

struct Press {
  double x_m, y_m, force_N, edge_distance_m;
};

}  // namespace

TEST_CASE("adaptive map: the stated total error holds between nodes and force levels", "[mapping][generate][adaptive][slow]") {
  const pvdf::Scene scene = film_15mm();
  MapOptions o;
  o.placement = Placement::adaptive;
  o.spacing_m = 0.002;
  o.adaptive_levels = 1;
  o.forces_N = {0.5, 2.0};
  o.tolerance = 0.05;
  o.threads = 2;
  o.n_setup_checks = 0;
  o.rim_model = pvdf::mapping::RimModel::never;
  o.direct_solves = pvdf::mapping::DirectSolves::never;
  MapReport report;
  const ChargeMap map = generate_map(scene, o, &report);
  REQUIRE(report.n_failed == 0);
  REQUIRE(report.level_solves.size() == 2);
  REQUIRE(std::isfinite(map.estimated_total_relative_error));
  const Locator locator(map);

  // Presses: uniform in the served disc (radius 15 − 2 mm margin), off the nodes by construction,
  // force log-uniform between the levels; 10 within 3 mm of the served edge, 20 farther in.
  const double served_m = 0.015 - 2 * scene.probe.radius_m;
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Press> presses;
  int n_edge = 0, n_inner = 0;
  for (int attempt = 0; attempt < 20000 && (n_edge < 10 || n_inner < 20); ++attempt) {
    const double r = served_m * std::sqrt(u(rng)), t = 2 * pvdf::pi * u(rng);
    const Press p{r * std::cos(t), r * std::sin(t), 0.5 * std::pow(4.0, u(rng)), served_m - r};
    std::array<double, max_electrodes> on_map{};
    if (!locator.predict(p.x_m, p.y_m, p.force_N, on_map.data())) continue;  // not in a usable cell
    const bool edge = p.edge_distance_m <= 0.003;
    if (edge && n_edge < 10) ++n_edge, presses.push_back(p);
    if (!edge && n_inner < 20) ++n_inner, presses.push_back(p);
  }
  REQUIRE(presses.size() >= 30);
  REQUIRE(n_edge >= 10);

  // References: a sweep of its own (no error estimates needed), tolerance 25 times tighter, its mesh
  // sized by two setup checks — finer than the map's, so the map's discretization error is part of
  // the true error its stated total must cover.
  std::vector<std::vector<double>> reference(presses.size());
  pvdf::fem::SweepOptions so;
  so.solver = pvdf::fem::options_from_scene(scene);
  so.solver.tolerance = o.tolerance / 25;
  so.rim_margin_m = 2 * scene.probe.radius_m;
  so.forces_N = o.forces_N;
  so.n_setup_checks = 2;
  so.estimate_errors = false;
  so.rim_model = pvdf::fem::SweepOptions::RimModel::never;
  pvdf::fem::ProbeSweep sweep(scene, so);
  INFO("map mesh " << report.n_dofs << " DOFs, reference mesh " << sweep.setup().n_dofs);
  REQUIRE(sweep.setup().n_dofs > report.n_dofs);
  for (std::size_t i = 0; i < presses.size(); ++i) {
    const auto s = sweep.solve(presses[i].x_m, presses[i].y_m, presses[i].force_N);
    if (pvdf::fem::usable(s.status)) reference[i] = s.charge_C;
  }

  int n_counted = 0, n_in_band = 0, n_met = 0;
  double worst_under = 1e300;
  std::vector<double> effectivities;
  for (std::size_t i = 0; i < presses.size(); ++i) {
    const Press& p = presses[i];
    INFO("press (" << 1e3 * p.x_m << ", " << 1e3 * p.y_m << ") mm, " << p.force_N << " N, " << 1e3 * p.edge_distance_m
                   << " mm from the served edge");
    REQUIRE(reference[i].size() == map.ne());
    std::array<double, max_electrodes> q{}, e{};
    REQUIRE(locator.predict(p.x_m, p.y_m, p.force_N, q.data()));
    REQUIRE(locator.charge_error(p.x_m, p.y_m, p.force_N, e.data()));
    double largest = 0, true_abs = 0, stated_abs = 0;
    for (std::size_t k = 0; k < map.ne(); ++k) {
      largest = std::max(largest, std::abs(reference[i][k]));
      true_abs = std::max(true_abs, std::abs(q[k] - reference[i][k]));
      stated_abs = std::max(stated_abs, e[k]);
    }
    const double truth = true_abs / largest, stated = stated_abs / largest;
    INFO("true " << truth << ", stated " << stated);
    REQUIRE(std::isfinite(truth));
    REQUIRE(std::isfinite(stated));
    // σ never under-states by more than a factor 2 (fails on NaN: the comparison is false).
    CHECK(stated >= 0.5 * truth);
    if (stated <= o.tolerance) {
      ++n_met;
      CHECK(truth <= o.tolerance);
    }
    if (truth > 1e-3) {
      ++n_counted;
      const double eff = stated / truth;
      effectivities.push_back(eff);
      if (eff >= 0.5 && eff <= 3) ++n_in_band;
      worst_under = std::min(worst_under, eff);
    }
    std::printf("press %6.2f %6.2f mm %5.2f N edge %5.2f mm: true %.4f stated %.4f\n", 1e3 * p.x_m, 1e3 * p.y_m, p.force_N,
                1e3 * p.edge_distance_m, truth, stated);
  }
  REQUIRE(n_counted >= 20);
  std::sort(effectivities.begin(), effectivities.end());
  const double median = effectivities[effectivities.size() / 2];
  // Sharp, not only honest: the median of stated / true within a factor 8 (fails on NaN).
  CHECK(median <= 8.0);
  std::printf("adaptive map: %zu + %zu solves (levels 4, 2 mm), %zu points interpolated; %zu presses (%d within 3 mm of "
              "the served edge); stated <= tolerance at %d; true > 1e-3 at %d: effectivity in [0.5, 3] at %d, median %.2f, "
              "smallest %.2f\n",
              report.level_solves[0], report.level_solves[1], report.n_interpolated, presses.size(), n_edge, n_met, n_counted,
              n_in_band, median, worst_under);
}
