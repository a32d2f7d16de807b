// The choice of beta on scanners it was not tuned on. For each scene of the randomized family
// (pvdf/restore/family.hpp: strips at their own depths, three kernel models, SNR 20-60 dB, speeds
// 25-80 mm/s, moving averages, edge shapes, textures), G is identified from two edge scans and every
// selector designs its inverse; the restored test scan is scored at its three edges (mu, position) and
// in L2. The reference is the best constant beta found in hindsight for that scene (a quarter-decade
// grid, same target resolution and low cut). Then the model-mismatch study: a filter identified on one
// scanner restores scans of a slightly different one (depth +-10 %, speed +-20 %, other edge profiles).
//
// Run:  build/bench/restore/bench_restore_selectors [--quick] [--scenes N] [--first-seed S]
//       (default 48 scenes from seed 1000, about two minutes on one core; --quick: 6 scenes)
#include "pvdf/restore/apply.hpp"
#include "pvdf/restore/family.hpp"
#include "pvdf/restore/filter.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

using namespace pvdf::restore;

namespace {

struct Score {
  double mu = 0, position_m = 0, l2 = 0, beta = 0;
};

Score evaluate(const InverseFilter& f, const family::FamilyScene& sc, const Scan& test) {
  const auto r = restore_scan(f, test);
  const auto edges = family::score_edges(r, sc.edges);
  Score s;
  for (const auto& e : edges) {
    s.mu += e.mu_error / static_cast<double>(edges.size());
    s.position_m = std::max(s.position_m, e.position_error_m);
  }
  s.l2 = family::force_l2_error(r, test, f.resolution_m);
  s.beta = f.beta;
  return s;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double p = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(p);
  const double a = p - static_cast<double>(i);
  return i + 1 < v.size() ? (1 - a) * v[i] + a * v[i + 1] : v[i];
}

struct Selector {
  const char* name;
  BetaPolicy policy;
  double beta;
  bool paper_settings;  // resolution 0 and no low cut (seed 000)
  bool corner;          // frequency-dependent beta with the corner at the target resolution
};

// (2) Model mismatch: identify on the scene's scanner, restore scans of a modified one.
void mismatch_study(int n_scenes, unsigned long first_seed) {
  const int n_mis = std::max(2, n_scenes / 4);
  struct Variant {
    const char* name;
    double depth, speed;
    bool wide_edges;
  };
  const Variant variants[] = {{"matched", 1, 1, false},       {"depth -10 %", 0.9, 1, false}, {"depth +10 %", 1.1, 1, false},
                              {"speed -20 % (resampled)", 1, 0.8, false}, {"speed +20 % (resampled)", 1, 1.2, false},
                              {"edges 0.5 mm rectangles", 1, 1, true}};
  std::printf("\n(2) model mismatch, default settings, %d scenes (seeds %lu..): mu error (mean of 3 edges) and the "
              "largest edge position error\n%-28s %12s %12s %16s %16s\n",
              n_mis, first_seed, "variant", "median mu", "max mu", "median pos (mm)", "max pos (mm)");
  for (const Variant& v : variants) {
    std::vector<double> m, p;
    for (int q = 0; q < n_mis; ++q) {
      const auto sc = family::draw_scene(first_seed + static_cast<unsigned long>(q));
      const auto ids = family::identification_scans(sc);
      const DesignOptions o;
      const auto f = design_inverse(identify_transfer(ids, o), ids, o);
      auto other = sc;
      other.scanner.depth_m[0] *= v.depth;
      other.scanner.depth_m[1] *= v.depth;
      other.scanner.speed_m_per_s *= v.speed;
      if (v.wide_edges)
        for (auto& e : other.edges) {
          e.shape = family::EdgeShape::rectangle;
          e.width_m = 0.5e-3;
        }
      Scan test = family::test_scan(other);
      if (v.speed != 1) test = resample_scan(test, f.sample_spacing_m);
      const Score s = evaluate(f, other, test);
      m.push_back(s.mu);
      p.push_back(s.position_m);
    }
    std::printf("%-28s %12.4f %12.4f %16.3f %16.3f\n", v.name, quantile(m, 0.5), *std::max_element(m.begin(), m.end()),
                quantile(p, 0.5) * 1e3, *std::max_element(p.begin(), p.end()) * 1e3);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int n_scenes = 48;
  unsigned long first_seed = 1000;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--quick")) n_scenes = 6;
    else if (!std::strcmp(argv[a], "--scenes") && a + 1 < argc) n_scenes = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--first-seed") && a + 1 < argc) first_seed = std::strtoul(argv[++a], nullptr, 10);
    else {
      std::fprintf(stderr, "usage: bench_restore_selectors [--quick] [--scenes N] [--first-seed S]\n");
      return 2;
    }
  }
  if (n_scenes < 1 || n_scenes > 10000) {
    std::fprintf(stderr, "error: --scenes = %d must be in [1, 10000]\n", n_scenes);
    return 2;
  }
  const std::clock_t t0 = std::clock();
  const std::vector<Selector> selectors = {
      {"constant 1e-4, no target, no low cut (seed 000)", BetaPolicy::constant, 1e-4, true, false},
      {"constant 1e-4", BetaPolicy::constant, 1e-4, false, false},
      {"constant 1e-3", BetaPolicy::constant, 1e-3, false, false},
      {"noise floor of G (old auto)", BetaPolicy::discrepancy, 0, false, false},
      {"GCV", BetaPolicy::gcv, 0, false, false},
      {"L-curve", BetaPolicy::lcurve, 0, false, false},
      {"discrepancy principle (Morozov)", BetaPolicy::morozov, 0, false, false},
      {"frequency-dependent 1e-4, corner = resolution", BetaPolicy::frequency, 1e-4, false, true},
      {"predicted mu error (default)", BetaPolicy::predicted, 0, false, false},
  };
  std::vector<std::vector<double>> mu_ratio(selectors.size()), mu_abs(selectors.size()), pos(selectors.size()),
      l2_ratio(selectors.size()), beta_ratio(selectors.size());
  std::vector<double> best_mu, best_beta, best_pos;
  std::printf("(1) beta selectors on %d scenes of the randomized family (seeds %lu..%lu), N = 8192 taps,\n"
              "    automatic target resolution and low cut unless stated; hindsight: best constant beta per scene\n",
              n_scenes, first_seed, first_seed + static_cast<unsigned long>(n_scenes) - 1);
  for (int q = 0; q < n_scenes; ++q) {
    const auto sc = family::draw_scene(first_seed + static_cast<unsigned long>(q));
    const auto ids = family::identification_scans(sc);
    const Scan test = family::test_scan(sc);
    DesignOptions base;
    const TransferMatrix t = identify_transfer(ids, base);
    // Hindsight: constant beta on a quarter-decade grid.
    Score best;
    best.mu = 1e300;
    for (int p = 0; p <= 28; ++p) {
      DesignOptions o = base;
      o.beta_policy = BetaPolicy::constant;
      o.beta = std::pow(10.0, -8.0 + 0.25 * p);
      const Score s = evaluate(design_inverse(t, ids, o), sc, test);
      if (s.mu < best.mu) best = s;
    }
    best_mu.push_back(best.mu);
    best_beta.push_back(best.beta);
    best_pos.push_back(best.position_m);
    std::printf("  %-86s best beta %.2g: mu err %.4f, pos %.3f mm |", sc.describe().c_str(), best.beta, best.mu,
                best.position_m * 1e3);
    for (std::size_t k = 0; k < selectors.size(); ++k) {
      DesignOptions o = base;
      o.beta_policy = selectors[k].policy;
      o.beta = selectors[k].beta;
      if (selectors[k].paper_settings) o.resolution_m = o.low_cut_wavelength_m = 0;
      if (selectors[k].corner) {
        // The corner at the automatic resolution: first a design to learn it.
        DesignOptions probe = base;
        probe.beta_policy = BetaPolicy::constant;
        o.corner_wavelength_m = design_inverse(t, ids, probe).resolution_m;
      }
      const auto f = design_inverse(t, ids, o);
      const Score s = evaluate(f, sc, test);
      // Ratios to the hindsight best; the floor 1e-3 keeps a lucky near-zero best from dominating.
      mu_ratio[k].push_back(s.mu / std::max(best.mu, 1e-3));
      mu_abs[k].push_back(s.mu);
      pos[k].push_back(s.position_m);
      l2_ratio[k].push_back(s.l2 / std::max(best.l2, 1e-12));
      beta_ratio[k].push_back(s.beta / best.beta);
      if (k + 1 == selectors.size()) std::printf(" default %.4f (beta %.2g)", s.mu, s.beta);
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  std::printf("\n%-50s %11s %11s %11s %11s %11s %11s %11s\n", "selector", "median mu/", "p90 mu/", "median mu", "p90 mu",
              "p90 pos", "median L2/", "median b/");
  std::printf("%-50s %11s %11s %11s %11s %11s %11s %11s\n", "", "best", "best", "error", "error", "err (mm)", "best", "best b");
  for (std::size_t k = 0; k < selectors.size(); ++k) {
    std::printf("%-50s %11.2f %11.2f %11.4f %11.4f %11.3f %11.2f %11.2g\n", selectors[k].name, quantile(mu_ratio[k], 0.5),
                quantile(mu_ratio[k], 0.9), quantile(mu_abs[k], 0.5), quantile(mu_abs[k], 0.9), quantile(pos[k], 0.9) * 1e3,
                quantile(l2_ratio[k], 0.5), quantile(beta_ratio[k], 0.5));
  }
  std::printf("%-50s %11s %11s %11.4f %11.4f %11.3f %11s %11s\n", "hindsight-best constant beta (per scene)", "1", "1",
              quantile(best_mu, 0.5), quantile(best_mu, 0.9), quantile(best_pos, 0.9) * 1e3, "1", "1");
  std::printf("spread of the hindsight-best beta over the scenes: 10th-90th percentile %.2g .. %.2g (x%.0f)\n",
              quantile(best_beta, 0.1), quantile(best_beta, 0.9), quantile(best_beta, 0.9) / quantile(best_beta, 0.1));

  mismatch_study(n_scenes, first_seed);
  std::printf("\nCPU time %.1f s\n", static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC);
  return 0;
}
