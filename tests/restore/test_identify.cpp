// Identification of G (seed 000 eq. 6 / least squares) against the simulator's analytic G, and refusals.
#include "restore_test_util.hpp"

#include "pvdf/core/error.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pvdf::restore;

namespace {
// Relative L2 distance between identified and analytic impulse responses, entry (i, j).
double g_error(const TransferMatrix& t, const ScannerScene& scene, int i, int j) {
  const auto ga = analytic_impulse_responses(scene, t.lag_min, t.g[i][j].size());
  double e = 0, n = 0;
  for (std::size_t l = 0; l < ga[i][j].size(); ++l) {
    e += std::pow(ga[i][j][l] - t.g[i][j][l], 2);
    n += ga[i][j][l] * ga[i][j][l];
  }
  return std::sqrt(e / n);
}
}  // namespace

TEST_CASE("Identified G equals the simulator's analytic G (noise-free, eq. 6)", "[restore][identify]") {
  const auto ids = restore_test::paper_identification(false);
  DesignOptions o;
  const auto t = identify_transfer(ids, o);
  CHECK(t.force_condition_number == Approx(5.06).epsilon(0.01));  // [0.6 0.2; 0.9 1.0]
  const auto scene = restore_test::example_scene("edge_a.json");
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      INFO("g" << i + 1 << j + 1);
      // Only the Tukey taper of the lag window's ends (where the 1/x^2 tails are) separates them.
      CHECK(g_error(t, scene, i, j) < 0.03);
    }
}

TEST_CASE("Least squares over more scans averages the noise of G down", "[restore][identify]") {
  const auto scene = restore_test::example_scene("edge_a.json");
  auto two = restore_test::paper_identification(true, 100);
  auto four = two;
  auto more = restore_test::paper_identification(true, 200);
  four.insert(four.end(), more.begin(), more.end());
  DesignOptions o;
  const auto t2 = identify_transfer(two, o);
  const auto t4 = identify_transfer(four, o);
  double e2 = 0, e4 = 0;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      e2 += g_error(t2, scene, i, j);
      e4 += g_error(t4, scene, i, j);
    }
  CHECK(e2 < 0.4);  // realistic noise: a few per cent per entry
  CHECK(e4 < e2);   // twice the data, ~1/sqrt(2) of the noise
  CHECK(t4.force_condition_number == Approx(t2.force_condition_number).epsilon(1e-9));
}

TEST_CASE("Identification refuses parallel force vectors", "[restore][identify]") {
  auto ids = restore_test::paper_identification(false);
  DesignOptions o;
  ids[1].fx_N = 2 * ids[0].fx_N;
  ids[1].fz_N = 2 * ids[0].fz_N;
  CHECK_THROWS_WITH(identify_transfer(ids, o), Catch::Contains("parallel"));
  ids[1].fx_N = 0.605;  // nearly parallel to (0.6, 0.9) scaled: cond > 100
  ids[1].fz_N = 0.9;
  ids[0].fx_N = 0.6;
  ids[0].fz_N = 0.9;
  CHECK_THROWS_AS(identify_transfer(ids, o), pvdf::InputError);
  ids[1].fx_N = 0.0;
  ids[1].fz_N = 0.0;
  CHECK_THROWS_WITH(identify_transfer(ids, o), Catch::Contains("(0, 0)"));
}

TEST_CASE("Identification refuses empty scans and too few scans", "[restore][identify]") {
  auto ids = restore_test::paper_identification(true);
  DesignOptions o;
  SECTION("all-zero signals") {
    std::fill(ids[1].scan.m1_V.begin(), ids[1].scan.m1_V.end(), 0.0);
    std::fill(ids[1].scan.m2_V.begin(), ids[1].scan.m2_V.end(), 0.0);
    CHECK_THROWS_WITH(identify_transfer(ids, o), Catch::Contains("no signal"));
  }
  SECTION("noise only") {
    auto scene = restore_test::example_scene("edge_b.json");
    scene.edges.clear();
    ids[1].scan = simulate_scan(scene);
    CHECK_THROWS_WITH(identify_transfer(ids, o), Catch::Contains("no signal"));
  }
  SECTION("edge outside the scan") {
    ids[0].edge_x_m = 0.3;
    CHECK_THROWS_WITH(identify_transfer(ids, o), Catch::Contains("outside"));
  }
  SECTION("one scan") {
    ids.pop_back();
    CHECK_THROWS_WITH(identify_transfer(ids, o), Catch::Contains("at least 2"));
  }
  SECTION("different sample spacing") {
    for (auto& x : ids[1].scan.x_m) x *= 2;
    CHECK_THROWS_WITH(identify_transfer(ids, o), Catch::Contains("sample spacing"));
  }
}

TEST_CASE("Design reports the conditioning and a filter that inverts G in its band", "[restore][identify]") {
  const auto ids = restore_test::paper_identification(false);
  DesignOptions o;
  o.beta = 1e-8;
  const auto t = identify_transfer(ids, o);
  const auto f = design_inverse(t, ids, o);
  CHECK(f.design_fft_length >= 2 * f.taps);
  CHECK(f.delay_samples == static_cast<long>(f.taps / 2));
  CHECK(f.conditioning.min >= 1.0);
  CHECK(f.conditioning.min <= f.conditioning.median);
  CHECK(f.conditioning.median <= f.conditioning.max);
  CHECK(f.conditioning.band_fraction > 0.01);
  CHECK(std::isfinite(f.beta_abs));
  // Invariance: scaling all forces by 1e3 scales G by 1e-3 and the filters by 1e3 (beta is relative).
  auto scaled = ids;
  for (auto& s : scaled) {
    s.fx_N *= 1e3;
    s.fz_N *= 1e3;
  }
  const auto fs = design_inverse(identify_transfer(scaled, o), scaled, o);
  for (std::size_t l = f.taps / 2 - 50; l < f.taps / 2 + 50; ++l) {
    CHECK(fs.h[1][0][l] == Approx(1e3 * f.h[1][0][l]).margin(1e-9 * std::abs(1e3 * f.h[1][0][f.taps / 2])));
  }
}

TEST_CASE("The frequency-dependent beta needs its corner and damps short wavelengths more", "[restore][identify]") {
  const auto ids = restore_test::paper_identification(false);
  DesignOptions o;
  o.beta_policy = BetaPolicy::frequency;
  const auto t = identify_transfer(ids, o);
  CHECK_THROWS_WITH(design_inverse(t, ids, o), Catch::Contains("corner"));
  o.corner_wavelength_m = 1e-3;
  const auto f = design_inverse(t, ids, o);
  DesignOptions c;  // the same beta, constant
  const auto g = design_inverse(t, ids, c);
  // More damping at high spatial frequency: the frequency-dependent filters have less energy.
  double ef = 0, eg = 0;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (std::size_t l = 0; l < f.taps; ++l) {
        ef += f.h[i][j][l] * f.h[i][j][l];
        eg += g.h[i][j][l] * g.h[i][j][l];
      }
  CHECK(ef < eg);
  CHECK(f.beta_policy == "frequency");
}
