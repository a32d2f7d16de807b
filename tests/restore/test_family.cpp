// The restoration on scanners it was not tuned on: scenes drawn from the randomized family
// (pvdf/restore/family.hpp, its own forward model) with seeds the study (bench_restore_selectors,
// seeds 1000-1047) never used; line forces in N/m; the flat-surface level; model mismatch.
#include "restore_test_util.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/restore/family.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include "../test_worst.hpp"

using namespace pvdf::restore;

namespace {

// Fresh seeds, fixed before the first run of this test and not chosen by their outcome.
const std::uint64_t fresh_seeds[] = {9101, 9102, 9103, 9104};

// Acquisition of the seed-000 scanner (Table 1 chain: the example's identification scans have an SNR of
// 236-396, i.e. 47-52 dB): the tests fix 50 dB; the study covers 20-60 dB. Identification: the family's
// 4 scans of each of the two edges.
family::FamilyScene fresh_scene(std::uint64_t seed) {
  auto sc = family::draw_scene(seed);
  sc.scanner.snr_dB = 50;
  return sc;
}

// Mean of the restored f_z (N/m) over the samples farther than `clear_m` from every force of the truth,
// inside the central 80 % of the scan.
double flat_level(const RestoredForces& r, const Scan& scan, double clear_m) {
  const std::size_t n = r.x_m.size();
  std::vector<char> busy(n, 0);
  const auto reach = static_cast<long>(clear_m / r.sample_spacing_m);
  for (std::size_t i = 0; i < n; ++i) {
    if (scan.fz_N[i] == 0.0) continue;
    for (long k = std::max(0L, static_cast<long>(i) - reach); k <= std::min(static_cast<long>(n) - 1, static_cast<long>(i) + reach); ++k)
      busy[static_cast<std::size_t>(k)] = 1;
  }
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t i = n / 10; i < n - n / 10; ++i)
    if (!busy[i]) {
      sum += r.fz_N_per_m[i];
      ++count;
    }
  REQUIRE(count > n / 10);
  return sum / static_cast<double>(count);
}

double peak(const std::vector<double>& v) {
  double p = 0;
  for (double x : v) p = pvdf::testing::worst_of(p, x);
  return p;
}

}  // namespace

// The targets: with the default settings every edge's mu within 0.02 and its position
// within 0.2 mm (seeds fixed before the first run; the default regularization is isotropic, chosen by the
// study on seeds 1000-1047, docs/restore.md section 4).
TEST_CASE("Default settings on unseen scanners of the family: mu within 0.02, edges within 0.2 mm", "[restore][family]") {
  int edges = 0;
  for (const auto seed : fresh_seeds) {
    const auto sc = fresh_scene(seed);
    const auto ids = family::identification_scans(sc);
    const DesignOptions defaults;
    const auto f = design_inverse(identify_transfer(ids, defaults), ids, defaults);
    const auto r = restore_scan(f, family::test_scan(sc));
    const auto scores = family::score_edges(r, sc.edges);
    for (std::size_t e = 0; e < scores.size(); ++e) {
      INFO(sc.describe() << ", edge " << e << " at " << sc.edges[e].x_m * 1e3 << " mm, mu " << sc.edges[e].fx_N / sc.edges[e].fz_N
                         << ": mu error " << scores[e].mu_error << ", position error " << scores[e].position_error_m * 1e3
                         << " mm, beta " << f.beta << " (" << f.beta_reason << ")");
      CHECK(scores[e].mu_error < 0.02);
      CHECK(scores[e].position_error_m < 0.2e-3);
      ++edges;
    }
  }
  CHECK(edges == 12);
}

// The default (isotropic) regularization damps the long wavelengths of both forces as much as the weak
// direction's: an isolated edge keeps a fraction of its force near it (the design predicts it from the
// identified G, lobe_force_fraction), the rest spreads as shallow side lobes. Tikhonov keeps ~all of it.
TEST_CASE("Line forces are in N/m: the peak and the integral of an edge do not depend on the sample spacing", "[restore][family]") {
  // One scanner at two speeds (sample spacings differ by 1.6x); the same lone edge of 1 N.
  auto sc = fresh_scene(9105);
  sc.textures.clear();
  sc.edges = {{0.0, 0.4, 1.0, family::EdgeShape::impulse, 0}};
  for (const bool isotropic : {true, false}) {
    double peaks[2], integrals[2], per_sample_peaks[2];
    const double speeds[2] = {0.03, 0.048};
    for (int v = 0; v < 2; ++v) {
      auto s = sc;
      s.scanner.speed_m_per_s = speeds[v];
      const auto ids = family::identification_scans(s);
      DesignOptions o;
      if (!isotropic) {
        o.isotropic = false;
        o.predicted_beta_scale = 0.25;
      }
      REQUIRE(DesignOptions().isotropic);  // the default
      const auto f = design_inverse(identify_transfer(ids, o), ids, o);
      const auto r = restore_scan(f, family::test_scan(s));
      RestoreOptions raw_options;
      raw_options.flat_baseline = false;
      const auto raw = restore_scan(f, family::test_scan(s), raw_options);
      double raw_integral = 0;
      for (std::size_t i = 0; i < raw.x_m.size(); ++i)
        if (std::abs(raw.x_m[i]) < 3 * f.resolution_m) raw_integral += raw.fz_N[i];
      peaks[v] = peak(r.fz_N_per_m);
      per_sample_peaks[v] = peak(r.fz_N);
      integrals[v] = 0;
      for (std::size_t i = 0; i < r.x_m.size(); ++i) {
        CHECK(r.fz_N[i] == Approx(r.fz_N_per_m[i] * r.sample_spacing_m).margin(1e-12));
        if (std::abs(r.x_m[i]) < 3 * f.resolution_m) integrals[v] += r.fz_N_per_m[i] * r.sample_spacing_m;
      }
      // The target Gaussian's peak for 1 N, F / (s sqrt(2 pi)).
      const double s_m = f.resolution_m / 2.3548200450309493;
      const double target_peak = 1.0 / (s_m * std::sqrt(2 * pvdf::pi));
      INFO((isotropic ? "isotropic" : "tikhonov") << ", speed " << speeds[v] << ": peak " << peaks[v] << " N/m (target "
           << target_peak << ", predicted fraction " << f.peak_fraction << "), integral " << integrals[v]
           << " N (without the flat-surface level " << raw_integral << " N, predicted " << f.lobe_force_fraction << ")");
      if (isotropic) {
        // What the design predicts from the identified G, against the simulated scanner's restoration.
        CHECK(raw_integral == Approx(f.lobe_force_fraction).epsilon(0.1));
        CHECK(integrals[v] >= raw_integral);  // the flat-surface level lifts the side lobes near the edge
        CHECK(peaks[v] == Approx(f.peak_fraction * target_peak).epsilon(0.1));
        CHECK(peaks[v] > 0.75 * target_peak);  // the resolution target of the beta rule (0.8, less noise)
      } else {
        // Tikhonov: the integral over the lobe is the edge's force in N, the peak the target's.
        CHECK(integrals[v] == Approx(1.0).epsilon(0.1));
        CHECK(peaks[v] == Approx(target_peak).epsilon(0.1));
      }
    }
    CHECK(peaks[1] == Approx(peaks[0]).epsilon(0.1));
    CHECK(integrals[1] == Approx(integrals[0]).epsilon(0.1));
    // Per sample (N) the same edge is spread over 1.6x fewer samples: its per-sample peak grows with the spacing.
    CHECK(per_sample_peaks[1] / per_sample_peaks[0] == Approx(speeds[1] / speeds[0]).epsilon(0.1));
  }
}

TEST_CASE("The flat-surface level: on flat stretches the restored f_z is within 5 % of the peaks", "[restore][family]") {
  SECTION("unseen scanners of the family") {
    for (const auto seed : fresh_seeds) {
      const auto sc = fresh_scene(seed);
      const auto ids = family::identification_scans(sc);
      const DesignOptions o;
      const auto f = design_inverse(identify_transfer(ids, o), ids, o);
      const Scan scan = family::test_scan(sc);
      const auto r = restore_scan(f, scan);
      RestoreOptions raw;
      raw.flat_baseline = false;
      const auto rr = restore_scan(f, scan, raw);
      const double level = flat_level(r, scan, 3 * f.resolution_m), raw_level = flat_level(rr, scan, 3 * f.resolution_m);
      INFO(sc.describe() << ": flat level " << level << " N/m (without the fix " << raw_level << ") against peaks of "
                         << peak(r.fz_N_per_m) << " N/m");
      CHECK(std::abs(level) < 0.05 * peak(r.fz_N_per_m));
    }
  }
  SECTION("the example surface (edges and a ridged texture), where the raw record sags") {
    const auto ids = restore_test::paper_identification(true);
    const DesignOptions o;
    const auto f = design_inverse(identify_transfer(ids, o), ids, o);
    const auto scene = restore_test::example_scene("scanner.json");
    const Scan scan = simulate_scan(scene);
    const auto r = restore_scan(f, scan);
    RestoreOptions raw;
    raw.flat_baseline = false;
    const auto rr = restore_scan(f, scan, raw);
    const double level = flat_level(r, scan, 3 * f.resolution_m), raw_level = flat_level(rr, scan, 3 * f.resolution_m);
    INFO("flat level " << level << " N/m, without the fix " << raw_level << " N/m, peak " << peak(r.fz_N_per_m) << " N/m");
    CHECK(std::abs(level) < 0.05 * peak(r.fz_N_per_m));
    CHECK(std::abs(raw_level) > std::abs(level));
  }
}

// Identify on one scanner, restore scans of a slightly different one (docs/restore.md section 4 has the
// study over 12 scanners). What must hold: a speed change, once the scan is resampled onto the filter's
// grid, and wider edges cost little against the matched case; a depth change of 10 % degrades mu (the
// sensor's response shape and the two strips' balance change) but keeps the edges within 0.4 mm.
TEST_CASE("Model mismatch: depth +-10 %, speed +-20 % and wider edges degrade mu and positions boundedly", "[restore][family]") {
  const auto sc = fresh_scene(9106);
  const auto ids = family::identification_scans(sc);
  const DesignOptions o;
  const auto f = design_inverse(identify_transfer(ids, o), ids, o);
  auto restore_variant = [&](double depth, double speed, bool wide) {
    auto other = sc;
    other.scanner.depth_m[0] *= depth;
    other.scanner.depth_m[1] *= depth;
    other.scanner.speed_m_per_s *= speed;
    if (wide)
      for (auto& e : other.edges) {
        e.shape = family::EdgeShape::rectangle;
        e.width_m = 0.5e-3;
      }
    Scan scan = family::test_scan(other);
    if (speed != 1) {
      CHECK_THROWS_AS(restore_scan(f, scan), pvdf::InputError);  // refused unless resampled
      scan = resample_scan(scan, f.sample_spacing_m);
    }
    return family::score_edges(restore_scan(f, scan), other.edges);
  };
  const auto matched = restore_variant(1, 1, false);
  double matched_mean = 0;
  for (const auto& m : matched) matched_mean += m.mu_error / 3;
  struct Variant {
    const char* name;
    double depth, speed;
    bool wide;
  };
  for (const Variant& v : {Variant{"speed -20 %", 1, 0.8, false}, Variant{"speed +20 %", 1, 1.2, false},
                           Variant{"0.5 mm wide edges", 1, 1, true}}) {
    const auto s = restore_variant(v.depth, v.speed, v.wide);
    for (std::size_t e = 0; e < s.size(); ++e) {
      INFO(v.name << ", edge " << e << ": mu error " << s[e].mu_error << " (matched " << matched[e].mu_error
                  << "), position error " << s[e].position_error_m * 1e3 << " mm");
      CHECK(s[e].mu_error < matched[e].mu_error + 0.03);
      CHECK(s[e].position_error_m < 0.2e-3);
    }
  }
  for (const double depth : {0.9, 1.1}) {
    const auto s = restore_variant(depth, 1, false);
    double mean = 0;
    for (std::size_t e = 0; e < s.size(); ++e) {
      INFO("depth x " << depth << ", edge " << e << ": mu error " << s[e].mu_error << ", position error "
                      << s[e].position_error_m * 1e3 << " mm");
      CHECK(s[e].position_error_m < 0.4e-3);
      mean += s[e].mu_error / 3;
    }
    INFO("depth x " << depth << ": mean mu error " << mean << " against " << matched_mean << " matched");
    CHECK(mean > matched_mean);
    CHECK(mean < 0.6);
  }
}

TEST_CASE("The family's scans are its own model: the point-strip kernel agrees with the closed form", "[restore][family]") {
  // An independent check of the family's numerical Flamant derivative against strip_signal_per_N.
  auto sc = family::draw_scene(9107);
  sc.scanner.model = family::KernelModel::point_strip;
  sc.scanner.snr_dB = 200;
  sc.scanner.adc_bits = 40;
  sc.scanner.moving_average = 1;
  const family::FamilyEdge e{0.0, 0.3, 1.0, family::EdgeShape::impulse, 0};
  const Scan scan = family::scan_surface(sc, {e}, {}, 1);
  Strip strip;
  strip.depth_m = sc.scanner.depth_m[0];
  strip.offset_m = sc.scanner.offset_m[0];
  strip.width_m = sc.scanner.width_m;
  strip.length_m = sc.scanner.length_m;
  strip.k1_C_per_N = sc.scanner.k_C_per_N[0][0];
  strip.k2_C_per_N = sc.scanner.k_C_per_N[0][1];
  strip.k3_C_per_N = sc.scanner.k_C_per_N[0][2];
  double peak_v = 0, worst = 0;
  for (std::size_t i = 0; i < scan.size(); i += 37) {
    const double x_rel = scan.x_m[i] + strip.offset_m;
    const double v = 0.3 * strip_signal_per_N(strip, sc.scanner.poisson_ratio, 1e9, sc.scanner.speed_m_per_s, ForceComponent::x, x_rel) +
                     strip_signal_per_N(strip, sc.scanner.poisson_ratio, 1e9, sc.scanner.speed_m_per_s, ForceComponent::z, x_rel);
    peak_v = pvdf::testing::worst_of(peak_v, std::abs(v));
    worst = pvdf::testing::worst_of(worst, std::abs(v - scan.m1_V[i]));
  }
  INFO("worst difference " << worst << " V against a peak of " << peak_v << " V");
  CHECK(worst < 1e-3 * peak_v);
}

