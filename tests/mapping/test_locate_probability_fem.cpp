// The lookup's solutions and their probabilities on a multi-level FEM map with the force
// unknown (docs/lookup.md §1.8): presses solved by the FEM between the map's nodes, with
// Gaussian charge noise. Three claims, each two-sided or counted over every draw:
//  - the reported position σ's are right: the truth lies within 2σ of the nearest reported
//    solution, per axis, in 90–99 % of ALL draws (nominal 95.4 %; an unlocated draw counts as a
//    miss; the band is from the binomial spread, see below). PVDF_TEST_SIGMA_SCALE multiplies the
//    reported σ's here (test only) to show the band catches σ × 0.5 and σ × 2;
//  - the truth is among the reported solutions: within 3σ per axis plus a fixed 0.1 mm (the
//    map's interpolation budget, 5 % of its 2 mm spacing; not measured by the locator) in ≥ 98 %
//    of ALL draws;
//  - the probability of the main answer is calibrated: among presses whose p_best falls in a
//    bin, the main answer is the right one about as often as the bin says.
// (The force-known accuracy target, median < 0.05 mm, is checked on a 1 mm FEM map by
// test_locate_fem; this 2 mm map errs by ~0.06 mm noise-free and is here for its extent.)
//
// Oracle: FEM solves (pvdf::fem::ProbeSweep) at each true press, never the lookup's own model.
// The presses are drawn from the lookup's prior — uniform over the map's area and uniform in F
// over the force range — because calibration is a statement about presses drawn from the prior.
// The film is the seed-001 film with the draw direction turned by 20°, so the layout has no
// mirror symmetry (with it every off-axis press would have an exact mirror twin: p = ½ always).
// The map: 2 mm grid over ±6 mm (clear of the electrodes), levels 0.5, 1, 2 N: 147 probe solves
// plus the truth solves (label `slow`). The truths lie a cell inside the map's edge, so every
// one has full interpolation stencils.
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"

#include "../test_sigma_scale.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

using namespace pvdf::mapping;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

using pvdf::testing::test_sigma_scale;  // tests/test_sigma_scale.hpp

struct Press {
  double x, y, F;
  std::vector<double> q;
};

/// The seed-001 scene with its draw direction at 20°.
pvdf::Scene anisotropic_scene() {
  std::ifstream in(std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json");
  nlohmann::json json = nlohmann::json::parse(in);
  json["material"]["draw_angle_deg"] = 20.0;
  return pvdf::parse_scene(json, "seed001.json with draw_angle_deg 20");
}

ChargeMap fem_map(pvdf::fem::ProbeSweep& sweep, const pvdf::Scene& scene, const std::vector<double>& levels,
                  double spacing_m, int half, double noise_C) {
  ChargeMap map;
  map.scene_json = scene.original.dump();
  map.pvdfkit_version = "test";
  map.model = pvdf::fem::model_name(sweep.setup().model);
  map.tolerance = 0.01;
  map.description = "test_locate_probability_fem: ProbeSweep solves, 2 mm grid over the film centre";
  for (int i = -half; i <= half; ++i) map.x_m.push_back(i * spacing_m);
  map.y_m = map.x_m;
  map.forces_N = levels;
  for (const auto& e : scene.electrodes) {
    map.electrode_names.push_back(e.name);
    map.electrode_centers_m.push_back(e.center_m);
  }
  map.noise_C.assign(map.ne(), noise_C);
  map.allocate();
  map.mask.assign(map.nx() * map.ny(), 1);
  for (std::size_t f = 0; f < map.nf(); ++f) {
    for (std::size_t j = 0; j < map.ny(); ++j) {
      pvdf::fem::SweepState state;
      for (std::size_t i = 0; i < map.nx(); ++i) {
        const auto s = sweep.solve(map.x_m[i], map.y_m[j], levels[f], state.dofs.empty() ? nullptr : &state, &state);
        REQUIRE(pvdf::fem::usable(s.status));
        for (std::size_t k = 0; k < map.ne(); ++k) map.charge_C[map.charge_index(f, j, i, k)] = s.charge_C[k];
        map.deflection_at_load_m[map.point(f, j, i)] = s.deflection_at_load_m;
        map.status[map.point(f, j, i)] = std::uint8_t(PointStatus::ok);
      }
    }
  }
  validate(map, "test map");
  return map;
}

}  // namespace

TEST_CASE("FEM presses with unknown force: the truth is among the solutions and p_best is calibrated",
          "[mapping][locator][fem][probability]") {
  const pvdf::Scene scene = anisotropic_scene();
  const std::vector<double> levels{0.5, 1.0, 2.0};
  pvdf::fem::SweepOptions sweep_options;
  sweep_options.solver = pvdf::fem::options_from_scene(scene);
  sweep_options.forces_N = levels;
  sweep_options.n_setup_checks = 0;  // map and truth share the mesh (as in test_locate_fem)
  pvdf::fem::ProbeSweep sweep(scene, sweep_options);

  // 1. The map (noise model: 0.6 pC per electrode, see step 3).
  const double noise_C = 0.6e-12;
  const double half_width_m = 6e-3;
  const ChargeMap map = fem_map(sweep, scene, levels, 2e-3, 3, noise_C);

  // 2. Truth: FEM solves at positions drawn uniformly over the map's area (off the nodes) and
  //    forces uniform over the force range 0.5–2 N (the prior).
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> pos(-half_width_m + 1e-3, half_width_m - 1e-3), force(0.5, 2.0);
  const int n_presses = 160, n_draws = 8;
  std::vector<Press> presses;
  pvdf::fem::SweepState state;
  for (int n = 0; n < n_presses; ++n) {
    Press p{pos(rng), pos(rng), force(rng), {}};
    const auto s = sweep.solve(p.x, p.y, p.F, state.dofs.empty() ? nullptr : &state, &state);
    REQUIRE(pvdf::fem::usable(s.status));
    p.q = s.charge_C;
    presses.push_back(p);
  }

  // The map's own error at each press (noise-free, force known), printed for the reader only:
  // no tolerance below is derived from it.
  LocatorOptions known_options;
  known_options.min_force_N = 0.5;
  known_options.max_force_N = 2.0;
  const Locator known_locator(map, known_options);
  std::vector<double> map_error(presses.size(), 0.0);
  for (std::size_t i = 0; i < presses.size(); ++i) {
    const Location k = known_locator.locate(presses[i].q, presses[i].F);
    map_error[i] = k.has_position() ? std::hypot(k.x_m - presses[i].x, k.y_m - presses[i].y) : 1e-3;
  }
  WARN("map error (noise-free, force known): median " << median(map_error) * 1e3 << " mm; the 1 mm FEM map of "
       "test_locate_fem checks the < 0.05 mm target");

  // 3. Locate each press under independent noise draws, force unknown. The solution the
  //    σ's speak about is the reported solution nearest the truth (in units of its own σ's);
  //    "right": that solution is the main answer (the branch p_best speaks about). The noise,
  //    0.6 pC, keeps σ above most of the map's error, so the test measures the probability model
  //    rather than the map.
  LocatorOptions options;
  options.min_force_N = 0.5;
  options.max_force_N = 2.0;
  const Locator locator(map, options);
  const double sigma_scale = test_sigma_scale();
  std::normal_distribution<double> gauss(0.0, noise_C);
  struct Bin {
    double lo, hi;
    int n = 0, right = 0, n_presses = 0, last_press = -1;
    double sum_p = 0;
  };
  std::vector<Bin> bins{{0.9, 1.01}, {0.7, 0.9}, {0.5, 0.7}, {0.0, 0.5}};
  const double fixed_allowance_m = 0.1e-3;  // the map's interpolation budget: 5 % of the 2 mm spacing
  int n_total = 0, n_among = 0, n_located = 0, n_ambiguous = 0, n_max_solutions = 0;
  int n_axis_1sigma = 0, n_axis_2sigma = 0;  // per axis: 2 per draw
  std::vector<double> axis_z;                // |error| / σ as reported, per axis (for the reference shares)
  for (std::size_t press_index = 0; press_index < presses.size(); ++press_index) {
    const Press& p = presses[press_index];
    for (int draw = 0; draw < n_draws; ++draw) {
      std::vector<double> q = p.q;
      for (double& v : q) v += gauss(rng);
      const Location r = locator.locate(q);
      ++n_total;
      if (!r.has_position()) {  // counted in n_total: a miss for every share below
        axis_z.insert(axis_z.end(), 2, HUGE_VAL);
        continue;
      }
      ++n_located;
      n_ambiguous += (r.flags & flag::ambiguous) != 0;
      n_max_solutions = std::max(n_max_solutions, r.n_solutions);
      REQUIRE(r.n_solutions == 1 + r.n_alternatives);  // every solution is reported
      double p_sum = r.probability;
      for (int a = 0; a < r.n_alternatives; ++a) p_sum += r.alternatives[std::size_t(a)].probability;
      REQUIRE(std::abs(p_sum - 1.0) < 1e-9);
      // The reported solution nearest the truth in units of its σ's (scaled for the test).
      struct Candidate { double dx, dy, sx, sy; };
      auto normalized = [](const Candidate& c) { return std::hypot(c.dx / c.sx, c.dy / c.sy); };
      Candidate best{r.x_m - p.x, r.y_m - p.y, sigma_scale * r.sigma_x_m, sigma_scale * r.sigma_y_m};
      bool main_nearest = true;
      for (int a = 0; a < r.n_alternatives; ++a) {
        const auto& alt = r.alternatives[std::size_t(a)];
        const Candidate c{alt.x_m - p.x, alt.y_m - p.y, sigma_scale * alt.sigma_x_m, sigma_scale * alt.sigma_y_m};
        if (normalized(c) < normalized(best)) {
          best = c;
          main_nearest = false;
        }
      }
      axis_z.push_back(std::abs(best.dx) / best.sx * sigma_scale);
      axis_z.push_back(std::abs(best.dy) / best.sy * sigma_scale);
      n_axis_1sigma += (std::abs(best.dx) <= best.sx) + (std::abs(best.dy) <= best.sy);
      n_axis_2sigma += (std::abs(best.dx) <= 2 * best.sx) + (std::abs(best.dy) <= 2 * best.sy);
      n_among += std::abs(best.dx) <= 3 * best.sx + fixed_allowance_m && std::abs(best.dy) <= 3 * best.sy + fixed_allowance_m;
      for (Bin& b : bins) {
        if (r.probability >= b.lo && r.probability < b.hi) {
          ++b.n;
          if (b.last_press != int(press_index)) ++b.n_presses;
          b.last_press = int(press_index);
          b.right += main_nearest;
          b.sum_p += r.probability;
        }
      }
    }
  }
  const double among_share = double(n_among) / double(n_total);
  const double axis_1sigma = double(n_axis_1sigma) / (2.0 * n_total), axis_2sigma = double(n_axis_2sigma) / (2.0 * n_total);
  WARN("FEM map 2 mm, levels 0.5/1/2 N, draw 20 deg, 0.6 pC noise, force unknown, sigma x " << sigma_scale << ": "
       << n_located << " of " << n_total << " located, " << n_ambiguous << " ambiguous, at most " << n_max_solutions
       << " solutions; of all draws, per axis inside 1 sigma " << 100.0 * axis_1sigma << " %, inside 2 sigma "
       << 100.0 * axis_2sigma << " %; truth among the solutions (3 sigma + 0.1 mm) " << 100.0 * among_share << " %");
  for (const double scale : {0.5, 1.0, 2.0}) {  // for reference: what the σ-scale runs give
    auto share = [&](double k) {
      return double(std::count_if(axis_z.begin(), axis_z.end(), [&](double z) { return z / scale <= k; })) / axis_z.size();
    };
    WARN("for reference, sigma x " << scale << ": per axis inside 1 sigma " << 100 * share(1) << " %, inside 2 sigma "
         << 100 * share(2) << " %");
  }
  for (const Bin& b : bins) {
    WARN("p_best in [" << b.lo << ", " << std::min(b.hi, 1.0) << "): " << b.n << " located draws of " << b.n_presses
         << " presses, mean p_best "
         << (b.n ? b.sum_p / b.n : 0.0) << ", main answer right " << (b.n ? 100.0 * b.right / b.n : 0.0) << " %");
  }
  CHECK(n_located >= n_total * 99 / 100);
  // Two-sided σ check over every draw. Band [0.90, 0.99] for the nominal 0.954 of a 2σ interval:
  // with N = 2 × n_total per-axis indicators (≥ n_total = 1280 independent ones) the binomial SD
  // at 0.954 is ≤ sqrt(0.954·0.046/1280) = 0.006, so nominal lies 9 SDs above 0.90 and 6 below
  // 0.99; σ × 0.5 makes it a 1σ interval (nominal 0.683) and σ × 2 a 4σ one (0.99994). Measured
  // (seed 17): 1σ 84.8 %, 2σ 97.3 % — the valley σ's (docs/lookup.md §1.6) are conservative,
  // about 1.4 × a Gaussian's — so σ × 0.5 gives 84.8 % (below 0.90) and σ × 2 gives > 99 %.
  CHECK(axis_2sigma >= 0.90);
  CHECK(axis_2sigma <= 0.99);
  CHECK(among_share >= 0.98);
  // Calibration: the ≥ 0.9 bin is right ≥ 90 % of the time; every bin with enough presses is
  // right as often as its mean p_best says, within 0.1 plus two binomial standard errors.
  REQUIRE(bins[0].n >= 100);
  CHECK(double(bins[0].right) / bins[0].n >= 0.9);
  int n_bins_checked = 0;
  for (const Bin& b : bins) {
    if (b.n_presses < 10) continue;
    ++n_bins_checked;
    // The draws of one press are alike (its p_best barely moves with the noise): the binomial
    // error counts presses, not draws.
    const double mean_p = b.sum_p / b.n, share = double(b.right) / b.n;
    const double se = std::sqrt(std::max(mean_p * (1 - mean_p), 0.01) / b.n_presses);
    INFO("bin [" << b.lo << ", " << b.hi << "): mean p " << mean_p << ", right " << share);
    CHECK(std::abs(share - mean_p) <= 0.1 + 2 * se);
  }
  CHECK(n_bins_checked >= 2);  // the test sees ambiguous presses, not only certain ones
}
