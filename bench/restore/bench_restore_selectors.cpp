// The choice of beta on scanners it was not tuned on. For each scene of the randomized family
// (pvdf/restore/family.hpp: strips at their own depths, three kernel models, SNR 20-60 dB, speeds
// 25-80 mm/s, moving averages, edge shapes, textures), G is identified from two edge scans and every
// selector designs its inverse; the restored test scan is scored at its three edges (mu, position) and
// in L2. The reference is the best constant beta found in hindsight for that scene (a quarter-decade
// grid, same target resolution and low cut). Then the model-mismatch study: a filter identified on one
// scanner restores scans of a slightly different one (depth +-10 %, speed +-20 %, other edge profiles).
//
// Run:  build/bench/restore/bench_restore_selectors [--quick] [--scenes N] [--first-seed S] [--mismatch-only]
//       [--min-peak-fraction P] (the resolution bound of the predicted rule and of the isotropic hindsight)
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
  bool isotropic;       // one gain for both singular directions (else Tikhonov, seed 000 eq. 4)
  double predicted_scale = 1.0;
};

// Hindsight: the best constant beta of one regularization on a quarter-decade grid 1e-8 .. 1.
Score hindsight_best(const TransferMatrix& t, const std::vector<IdentificationScan>& ids, const family::FamilyScene& sc,
                     const Scan& test, bool isotropic, double min_peak_fraction) {
  Score best;
  best.mu = 1e300;
  for (int p = 0; p <= 32; ++p) {
    DesignOptions o;
    o.isotropic = isotropic;
    o.beta_policy = BetaPolicy::constant;
    o.beta = std::pow(10.0, -8.0 + 0.25 * p);
    const InverseFilter f = design_inverse(t, ids, o);
    // The isotropic design's mu is unbiased at any beta, so its best mu lies at ever wider blur: it is held to
    // the same resolution target as the rules (Tikhonov, the seed-000 design, is searched unconstrained).
    if (isotropic && f.peak_fraction < min_peak_fraction) continue;
    const Score s = evaluate(f, sc, test);
    if (s.mu < best.mu) best = s;
  }
  return best;
}

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

// (1) Every selector on each scene of the family against the hindsight-best constant beta, then the
// table of ratios and errors over the scenes.
void selector_study(const std::vector<Selector>& selectors, int n_scenes, unsigned long first_seed,
                    double min_peak_fraction) {
  const std::size_t S = selectors.size();
  // Ratios to the hindsight-best constant beta of the selector's own regularization ("own") and to that of
  // Tikhonov, the seed-000 design ("Tikhonov").
  std::vector<std::vector<double>> ratio_own(S), ratio_tik(S), mu_abs(S), pos(S), l2_ratio(S);
  std::vector<double> best_mu[2], best_beta[2], best_pos[2];
  std::printf("(1) beta selectors on %d scenes of the randomized family (seeds %lu..%lu), N = 8192 taps,\n"
              "    automatic target resolution and low cut unless stated; hindsight: best constant beta per scene\n",
              n_scenes, first_seed, first_seed + static_cast<unsigned long>(n_scenes) - 1);
  for (int q = 0; q < n_scenes; ++q) {
    const auto sc = family::draw_scene(first_seed + static_cast<unsigned long>(q));
    const auto ids = family::identification_scans(sc);
    const Scan test = family::test_scan(sc);
    const DesignOptions base;
    const TransferMatrix t = identify_transfer(ids, base);
    Score best[2];
    for (int iso = 0; iso < 2; ++iso) {
      best[iso] = hindsight_best(t, ids, sc, test, iso == 1, min_peak_fraction);
      best_mu[iso].push_back(best[iso].mu);
      best_beta[iso].push_back(best[iso].beta);
      best_pos[iso].push_back(best[iso].position_m);
    }
    std::printf("  %-86s best beta %.2g / %.2g: mu err %.4f / %.4f |", sc.describe().c_str(), best[0].beta, best[1].beta,
                best[0].mu, best[1].mu);
    for (std::size_t k = 0; k < S; ++k) {
      DesignOptions o = base;
      o.isotropic = selectors[k].isotropic;
      o.predicted_beta_scale = selectors[k].predicted_scale;
      o.min_peak_fraction = min_peak_fraction;
      o.beta_policy = selectors[k].policy;
      o.beta = selectors[k].beta;
      if (selectors[k].paper_settings) o.resolution_m = o.low_cut_wavelength_m = 0;
      if (selectors[k].corner) {
        // The corner at the automatic resolution: first a design to learn it.
        DesignOptions probe = o;
        probe.beta_policy = BetaPolicy::constant;
        o.corner_wavelength_m = design_inverse(t, ids, probe).resolution_m;
      }
      const Score s = evaluate(design_inverse(t, ids, o), sc, test);
      // The floor 1e-3 keeps a lucky near-zero best from dominating.
      const Score& own = best[selectors[k].isotropic ? 1 : 0];
      ratio_own[k].push_back(s.mu / std::max(own.mu, 1e-3));
      ratio_tik[k].push_back(s.mu / std::max(best[0].mu, 1e-3));
      mu_abs[k].push_back(s.mu);
      pos[k].push_back(s.position_m);
      l2_ratio[k].push_back(s.l2 / std::max(own.l2, 1e-12));
      if (k + 1 == S) std::printf(" default %.4f (beta %.2g)", s.mu, s.beta);
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  std::printf("\n%-52s %9s %9s %9s %9s %9s %9s %9s %9s\n", "selector", "med mu/", "p90 mu/", "med mu/", "p90 mu/",
              "median", "p90", "p90 pos", "med L2/");
  std::printf("%-52s %9s %9s %9s %9s %9s %9s %9s %9s\n", "", "own best", "own best", "Tik best", "Tik best", "mu err",
              "mu err", "err (mm)", "own best");
  for (std::size_t k = 0; k < S; ++k) {
    std::printf("%-52s %9.2f %9.2f %9.2f %9.2f %9.4f %9.4f %9.3f %9.2f\n", selectors[k].name, quantile(ratio_own[k], 0.5),
                quantile(ratio_own[k], 0.9), quantile(ratio_tik[k], 0.5), quantile(ratio_tik[k], 0.9), quantile(mu_abs[k], 0.5),
                quantile(mu_abs[k], 0.9), quantile(pos[k], 0.9) * 1e3, quantile(l2_ratio[k], 0.5));
  }
  const char* names[2] = {"hindsight-best constant beta, Tikhonov", "hindsight-best constant beta, isotropic"};
  for (int iso = 0; iso < 2; ++iso) {
    std::printf("%-52s %9s %9s %9s %9s %9.4f %9.4f %9.3f %9s\n", names[iso], "1", "1", "", "", quantile(best_mu[iso], 0.5),
                quantile(best_mu[iso], 0.9), quantile(best_pos[iso], 0.9) * 1e3, "1");
    std::printf("  spread of its beta over the scenes: 10th-90th percentile %.2g .. %.2g\n", quantile(best_beta[iso], 0.1),
                quantile(best_beta[iso], 0.9));
  }

}

}  // namespace

int main(int argc, char** argv) {
  int n_scenes = 48;
  unsigned long first_seed = 1000;
  double min_peak_fraction = DesignOptions().min_peak_fraction;
  bool mismatch_only = false;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--quick")) n_scenes = 6;
    else if (!std::strcmp(argv[a], "--scenes") && a + 1 < argc) n_scenes = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--first-seed") && a + 1 < argc) first_seed = std::strtoul(argv[++a], nullptr, 10);
    else if (!std::strcmp(argv[a], "--min-peak-fraction") && a + 1 < argc) min_peak_fraction = std::atof(argv[++a]);
    else if (!std::strcmp(argv[a], "--mismatch-only")) mismatch_only = true;
    else {
      std::fprintf(stderr, "usage: bench_restore_selectors [--quick] [--scenes N] [--first-seed S] [--min-peak-fraction P] [--mismatch-only]\n");
      return 2;
    }
  }
  if (n_scenes < 1 || n_scenes > 10000) {
    std::fprintf(stderr, "error: --scenes = %d must be in [1, 10000]\n", n_scenes);
    return 2;
  }
  const std::clock_t t0 = std::clock();
  if (mismatch_only) {
    mismatch_study(n_scenes, first_seed);
    std::printf("\nCPU time %.1f s\n", static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC);
    return 0;
  }
  const std::vector<Selector> selectors = {
      {"Tikhonov constant 1e-4, no target, no low cut (seed 000)", BetaPolicy::constant, 1e-4, true, false, false},
      {"Tikhonov constant 1e-4", BetaPolicy::constant, 1e-4, false, false, false},
      {"Tikhonov noise floor of G", BetaPolicy::discrepancy, 0, false, false, false},
      {"Tikhonov GCV", BetaPolicy::gcv, 0, false, false, false},
      {"Tikhonov L-curve", BetaPolicy::lcurve, 0, false, false, false},
      {"Tikhonov discrepancy principle (Morozov)", BetaPolicy::morozov, 0, false, false, false},
      {"Tikhonov frequency-dependent 1e-4, corner = res.", BetaPolicy::frequency, 1e-4, false, true, false},
      {"Tikhonov predicted mu error x 0.25 (old default)", BetaPolicy::predicted, 0, false, false, false, 0.25},
      {"isotropic constant 1e-4", BetaPolicy::constant, 1e-4, false, false, true},
      {"isotropic constant 1e-2", BetaPolicy::constant, 1e-2, false, false, true},
      {"isotropic GCV", BetaPolicy::gcv, 0, false, false, true},
      {"isotropic predicted mu error (default)", BetaPolicy::predicted, 0, false, false, true},
  };
  selector_study(selectors, n_scenes, first_seed, min_peak_fraction);

  mismatch_study(n_scenes, first_seed);
  std::printf("\nCPU time %.1f s\n", static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC);
  return 0;
}
