// The lookup against the analytic model: accuracy between grid nodes, noise coverage, flags.
#include "fixture.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/mapping/ambiguity.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <thread>

using namespace pvdf::mapping;
using pvdf_test::Press;

namespace {

SyntheticModel skewed_model() {
  SyntheticModel m;          // seed-001 triangle, anisotropic, decaying like d^-0.8
  m.force_skew = 0.05;       // force exponent 2/3 ± 0.05 across the film: levels matter
  return m;
}

const std::vector<double> levels{0.25, 0.5, 1.0, 2.0, 4.0};

}  // namespace

/// The reported answer nearest the truth: the position itself, or, for an ambiguous result,
/// the better of it and its alternative (the user is told both fit).
Location::Alternative nearest_answer(const Location& r, const Press& p) {
  Location::Alternative a{r.x_m, r.y_m, r.force_N, r.residual, r.sigma_x_m, r.sigma_y_m, r.sigma_F_N};
  for (int k = 0; k < r.n_alternatives; ++k) {
    const auto& alt = r.alternatives[std::size_t(k)];
    if (std::hypot(alt.x_m - p.x_m, alt.y_m - p.y_m) < std::hypot(a.x_m - p.x_m, a.y_m - p.y_m)) a = alt;
  }
  return a;
}

double nearest_answer_error(const Location& r, const Press& p, double* force_error) {
  const auto a = nearest_answer(r, p);
  if (force_error) *force_error = std::abs(a.force_N - p.force_N) / p.force_N;
  return std::hypot(a.x_m - p.x_m, a.y_m - p.y_m);
}

TEST_CASE("noise-free presses between grid nodes are located far below the grid spacing", "[mapping][locator]") {
  const SyntheticModel model = skewed_model();
  const double spacing = 1e-3;
  const ChargeMap map = build_synthetic_map(model, spacing, 3e-3, levels, 0.05e-12);
  LocatorOptions options;
  options.min_force_N = levels.front();  // the deployment's force range: the map's levels
  options.max_force_N = levels.back();
  const Locator locator(map, options);
  // Random positions (never on nodes) around the electrode triangle, forces 0.3–3 N between levels.
  const auto presses = pvdf_test::random_presses(600, 0.015, 0.3, 3.0, 7);
  const auto a = pvdf_test::measure_accuracy(locator, pvdf_test::synthetic_oracle(model), presses, false);
  const double med_pos = pvdf_test::median(a.position_error_m), med_force = pvdf_test::median(a.force_error);
  INFO("median position error " << med_pos * 1e3 << " mm, median force error " << med_force * 100 << " %, flagged "
                                << a.flagged << ", ambiguous " << a.ambiguous << " of " << presses.size()
                                << ", unflagged answers off by > 0.2 mm and > 3 sigma: " << a.silent_wrong);
  CHECK(a.flagged == 0);
  CHECK(med_pos < 0.05e-3);    // target: < 0.05 mm (grid spacing 1 mm)
  CHECK(med_force < 0.005);    // target: < 0.5 %
  // Known limitation (docs/lookup.md §2): near an electrode the map folds and the
  // interpolation error (~1 sigma here) can move the fit to the other side of the fold.
  CHECK(a.silent_wrong < int(presses.size()) / 10);
  // Three electrodes and an unknown force: a second exact solution is common (docs/lookup.md §2).
  CHECK(a.ambiguous > 0);
}

TEST_CASE("with a known force three electrodes locate presses without ambiguity", "[mapping][locator]") {
  const SyntheticModel model = skewed_model();
  const ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, levels, 0.05e-12);
  const auto presses = pvdf_test::random_presses(300, 0.015, 0.3, 3.0, 17);
  std::vector<double> err;
  int ambiguous = 0, silent_wrong = 0;
  const Locator locator(map);
  LocatorOptions fixed;
  fixed.known_force_N = 1.0;
  const Locator at_one_newton(map, fixed);  // the option and the per-call force agree
  const Press one{0.0031, -0.0042, 1.0};
  CHECK(at_one_newton.locate(pvdf_test::charges(model, one)).x_m == locator.locate(pvdf_test::charges(model, one), 1.0).x_m);
  for (const auto& p : presses) {
    const Location r = locator.locate(pvdf_test::charges(model, p), p.force_N);
    REQUIRE(r.has_position());
    CHECK(r.force_N == Approx(p.force_N).epsilon(1e-12));
    ambiguous += (r.flags & flag::ambiguous) != 0;
    const double e = std::hypot(r.x_m - p.x_m, r.y_m - p.y_m);
    err.push_back(e);
    silent_wrong += !(r.flags & flag::ambiguous) && e > 0.2e-3 && e > 3 * std::hypot(r.sigma_x_m, r.sigma_y_m);
  }
  INFO("known force: ambiguous " << ambiguous << " of " << presses.size() << ", median error "
                                 << pvdf_test::median(err) * 1e3 << " mm, silently wrong " << silent_wrong);
  CHECK(pvdf_test::median(err) < 0.05e-3);
  CHECK(ambiguous < int(presses.size()) / 6);
  CHECK(silent_wrong < int(presses.size()) / 50);
}

TEST_CASE("position error falls faster than the grid spacing (interpolation order)", "[mapping][locator]") {
  const SyntheticModel model = skewed_model();
  const auto presses = pvdf_test::random_presses(150, 0.015, 0.5, 2.0, 11);
  auto median_error = [&](double spacing) {
    const Locator locator(build_synthetic_map(model, spacing, 3e-3, levels, 0.05e-12));
    std::vector<double> e;
    for (const auto& p : presses) {
      const Location r = locator.locate(pvdf_test::charges(model, p), p.force_N);
      if (r.has_position()) e.push_back(std::hypot(r.x_m - p.x_m, r.y_m - p.y_m));
    }
    return pvdf_test::median(e);
  };
  const double coarse = median_error(2e-3), fine = median_error(1e-3);
  INFO("known force: median error at 2 mm spacing " << coarse * 1e3 << " mm, at 1 mm " << fine * 1e3 << " mm");
  CHECK(coarse / fine > 5.0);  // bicubic with 4th-order slopes: ~8-16x per halving
}

TEST_CASE("a fourth electrode removes most ambiguity", "[mapping][locator]") {
  SyntheticModel model = skewed_model();
  model.names.push_back("D");
  model.centers_m.push_back({0.0, -0.02});
  LocatorOptions options;
  options.min_force_N = levels.front();
  options.max_force_N = levels.back();
  const Locator locator(build_synthetic_map(model, 1e-3, 3e-3, levels, 0.05e-12), options);
  const auto presses = pvdf_test::random_presses(300, 0.015, 0.3, 3.0, 8);
  std::vector<double> err;
  int ambiguous = 0;
  for (const auto& p : presses) {
    const Location r = locator.locate(pvdf_test::charges(model, p));
    REQUIRE(r.has_position());
    ambiguous += (r.flags & flag::ambiguous) != 0;
    err.push_back(std::hypot(r.x_m - p.x_m, r.y_m - p.y_m));
  }
  INFO("four electrodes: ambiguous " << ambiguous << " of " << presses.size() << ", median error "
                                     << pvdf_test::median(err) * 1e3 << " mm");
  CHECK(ambiguous < int(presses.size()) / 4);
  CHECK(pvdf_test::median(err) < 0.05e-3);
}

void check_coverage(const SyntheticModel& model, bool known_force, const char* what) {
  const double sigma_q = 0.2e-12;  // 0.2 pC on charges of ~5-100 pC
  const ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, levels, sigma_q);
  const auto presses = pvdf_test::random_presses(1200, 0.015, 0.5, 2.0, 3);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, sigma_q);
  int n = 0, in_x = 0, in_y = 0, in_f = 0;
  LocatorOptions options;
  options.min_force_N = levels.front();
  options.max_force_N = levels.back();
  const Locator unknown_force(map, options);
  for (const auto& p : presses) {
    auto q = pvdf_test::charges(model, p);
    for (auto& v : q) v += noise(rng);
    const Location r = known_force ? unknown_force.locate(q, p.force_N) : unknown_force.locate(q);
    if (!r.has_position()) continue;
    const auto a = nearest_answer(r, p);  // for an ambiguous result: the solution near the truth
    ++n;
    in_x += std::abs(a.x_m - p.x_m) <= a.sigma_x_m;
    in_y += std::abs(a.y_m - p.y_m) <= a.sigma_y_m;
    in_f += known_force || std::abs(a.force_N - p.force_N) <= a.sigma_F_N;
  }
  const double fx = double(in_x) / n, fy = double(in_y) / n, ff = double(in_f) / n;
  INFO(what << ": located " << n << " of " << presses.size() << "; within 1 sigma: x " << fx << ", y " << fy << ", F " << ff);
  CHECK(n > int(presses.size()) * 95 / 100);
  // Binomial 1-sigma for n = 1200 at p = 0.683 is 0.013; allow ±0.06 for the linearization
  // and for the few presses on folds of the map (docs/lookup.md §2).
  CHECK(std::abs(fx - 0.683) < 0.06);
  CHECK(std::abs(fy - 0.683) < 0.06);
  if (!known_force) CHECK(std::abs(ff - 0.683) < 0.06);
}

TEST_CASE("reported 1-sigma uncertainty covers about 68 % of the errors under charge noise", "[mapping][locator]") {
  // Three electrodes (seed 001) with the force known: (x, y) from three charges.
  check_coverage(skewed_model(), true, "three electrodes, known force");
  // Four electrodes, force unknown: (x, y, F) from four charges.
  SyntheticModel four = skewed_model();
  four.names.push_back("D");
  four.centers_m.push_back({0.0, -0.02});
  check_coverage(four, false, "four electrodes, unknown force");
  // (Three electrodes with unknown force: up to four exact solutions; the coverage of the
  // nearest reported one is measured in docs/lookup.md, not asserted.)
}

TEST_CASE("a symmetric layout is flagged ambiguous with the mirror position as alternative", "[mapping][locator]") {
  // Three electrodes on the x axis: the charges are even in y, so (x, y) and (x, −y) coincide.
  SyntheticModel model;
  model.centers_m = {{-0.012, 0.0}, {0.0, 0.0}, {0.012, 0.0}};
  const ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, {0.5, 1.0, 2.0}, 0.05e-12);
  const Locator locator(map);
  const Press p{0.0053, 0.0081, 1.3};
  const Location r = locator.locate(pvdf_test::charges(model, p));
  REQUIRE(r.has_position());
  CHECK((r.flags & flag::ambiguous) != 0);
  // Both the truth and its mirror image are among the reported solutions, with the same force
  // and — by the symmetry — the same posterior probability.
  std::vector<Location::Alternative> all{{r.x_m, r.y_m, r.force_N, r.residual, r.sigma_x_m, r.sigma_y_m, r.sigma_F_N,
                                          r.probability}};
  for (int a = 0; a < r.n_alternatives; ++a) all.push_back(r.alternatives[std::size_t(a)]);
  CHECK(int(all.size()) == r.n_solutions);
  const Location::Alternative* truth = nullptr;
  const Location::Alternative* mirror = nullptr;
  double p_sum = 0;
  for (const auto& s : all) {
    p_sum += s.probability;
    if (std::abs(s.x_m - p.x_m) < 1e-4 && std::abs(s.y_m - p.y_m) < 1e-4) truth = &s;
    if (std::abs(s.x_m - p.x_m) < 1e-4 && std::abs(s.y_m + p.y_m) < 1e-4) mirror = &s;
  }
  REQUIRE(truth != nullptr);
  REQUIRE(mirror != nullptr);
  CHECK(std::abs(mirror->force_N - p.force_N) / p.force_N < 1e-3);
  CHECK(mirror->probability == Approx(truth->probability).epsilon(0.02));
  CHECK(p_sum == Approx(1.0).epsilon(1e-12));
  CHECK(r.probability >= truth->probability);  // the main answer is the most probable
}

TEST_CASE("every exact solution is found: fold twins less than a cell apart are reported, not merged",
          "[mapping][locator]") {
  // The map's own charges at every usable node (noise-free, 1 N, force unknown in 0.25-4 N):
  // the press itself is an exact solution, so it must be the answer or one of the reported
  // alternatives. Next to an electrode the map folds and a second exact solution can lie
  // 0.07-0.4 mm away; a lookup that merges solutions closer than a cell (the defect this test
  // was written for) missed the press at 129 of 5564 nodes (2.3 %); now 3.
  SyntheticModel model;  // seed-001 triangle
  const double sigma = 0.002e-12;
  const ChargeMap map = build_synthetic_map(model, 1e-3, 2e-3, {1.0}, sigma);
  LocatorOptions options;
  options.noise_C = {sigma};
  options.min_force_N = 0.25;
  options.max_force_N = 4.0;
  // The charges are the interpolant's own: the map's error between nodes (§1.10) is no error
  // here, and with it in σ the twins 0.07 mm apart would rightly be one solution within 3σ.
  options.interpolation_error = false;
  const Locator locator(map, options);
  // The two cases found by the design work: the truth and its twin, both exact.
  struct Twin {
    double x, y, twin_x, twin_y;
  };
  for (const Twin& t : {Twin{1e-3, 10e-3, 0.9937e-3, 10.3582e-3}, Twin{8e-3, -5e-3, 7.9589e-3, -4.9431e-3}}) {
    std::array<double, 3> q{};
    REQUIRE(locator.predict(t.x, t.y, 1.0, q.data()));
    const Location r = locator.locate(q.data());
    INFO("press (" << t.x * 1e3 << ", " << t.y * 1e3 << ") mm -> (" << r.x_m * 1e3 << ", " << r.y_m * 1e3 << ") mm, "
                   << flags_text(r.flags) << ", " << r.n_solutions << " solution(s)");
    REQUIRE(r.has_position());
    CHECK((r.flags & flag::ambiguous) != 0);
    const Press truth{t.x, t.y, 1.0}, twin{t.twin_x, t.twin_y, 1.0};
    CHECK(nearest_answer_error(r, truth, nullptr) < 1e-6);
    CHECK(nearest_answer_error(r, twin, nullptr) < 1e-6);
  }
  // All nodes: the truth is among the reported answers nearly everywhere.
  std::size_t n = 0, missed = 0;
  for (std::size_t j = 0; j < map.ny(); ++j) {
    for (std::size_t i = 0; i < map.nx(); ++i) {
      const double x = map.x_m[i], y = map.y_m[j];
      std::array<double, 3> q{};
      if (!locator.predict(x, y, 1.0, q.data())) continue;
      const Location r = locator.locate(q.data());
      if (!r.has_position() && (r.flags & flag::no_press)) continue;  // charges below the noise
      ++n;
      if (!r.has_position()) {
        ++missed;
        continue;
      }
      // Solutions within 3 σ of each other are one solution (merged, by design): the press
      // must be within 3 σ of a reported answer (or 0.01 mm where σ is smaller).
      // With more than four solutions only the best four are reported (the count is): a press
      // among the unreported ones is not a miss.
      const auto a = nearest_answer(r, Press{x, y, 1.0});
      const bool all_reported = r.n_solutions <= 1 + r.n_alternatives;
      if (all_reported && std::hypot(a.x_m - x, a.y_m - y) > std::max(1e-5, 3 * std::hypot(a.sigma_x_m, a.sigma_y_m))) ++missed;
    }
  }
  INFO(missed << " of " << n << " nodes without the press among the answers");
  CHECK(n > 4000);
  CHECK(double(missed) <= 0.002 * double(n));
}

TEST_CASE("presses outside the mapped area are flagged or matched by a press inside", "[mapping][locator]") {
  const SyntheticModel model = skewed_model();
  const double sigma_q = 0.02e-12;
  const ChargeMap map = build_synthetic_map(model, 1e-3, 8e-3, levels, sigma_q);  // mapped r <= 37 mm
  const Locator locator(map);
  int outside = 0, total = 0;
  for (double angle = 0.1; angle < 6.28; angle += 0.5) {
    const Press p{0.0435 * std::cos(angle), 0.0435 * std::sin(angle), 1.0};  // in the rim margin
    const auto q = pvdf_test::charges(model, p);
    const Location r = locator.locate(q);
    ++total;
    if (r.flags & flag::outside_map) {
      ++outside;
      CHECK_FALSE(r.has_position());
      CHECK(r.x_m == 0.0);
      continue;
    }
    // Not flagged: then a press inside the map really produces these charges (an exact twin,
    // docs/lookup.md §2) — checked against the analytic model, not against the map.
    REQUIRE(r.has_position());
    CHECK(std::hypot(r.x_m, r.y_m) < 0.037 + 1e-3);
    for (std::size_t k = 0; k < 3; ++k) CHECK(std::abs(model.charge_C(r.x_m, r.y_m, r.force_N, k) - q[k]) < 5 * sigma_q);
  }
  INFO(outside << " of " << total << " rim presses flagged outside_map");
  CHECK(outside > 0);
  // Charges no mapped press can produce (A much larger than anywhere in the map relative to
  // B and C) are always outside the map.
  const std::vector<double> impossible{200e-12, 0.5e-12, 0.5e-12};
  const Location r = locator.locate(impossible);
  CHECK((r.flags & flag::outside_map) != 0);
  CHECK_FALSE(r.has_position());
}

TEST_CASE("charges at the noise level are flagged no_press", "[mapping][locator]") {
  const SyntheticModel model = skewed_model();
  const Locator locator(build_synthetic_map(model, 2e-3, 3e-3, levels, 0.5e-12));
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.5e-12);
  for (int i = 0; i < 50; ++i) {
    const std::vector<double> q{noise(rng), noise(rng), noise(rng)};
    CHECK((locator.locate(q).flags & flag::no_press) != 0);
  }
  const double nan = std::nan("");
  const std::vector<double> bad{nan, 1e-11, 1e-11};
  CHECK_FALSE(locator.locate(bad).has_position());
  // A real press at 1 N is not.
  CHECK((locator.locate(pvdf_test::charges(model, {0.004, -0.002, 1.0})).flags & flag::no_press) == 0);
}

TEST_CASE("a single-level map uses the F^(2/3) law and says so", "[mapping][locator]") {
  SyntheticModel model;  // pure membrane scaling: exact
  const ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, {1.0}, 0.05e-12);
  LocatorOptions wide;
  wide.max_force_N = 4.0;
  const Locator locator(map, wide);
  const Press p{-0.0071, 0.0123, 2.7};
  const Location r = locator.locate(pvdf_test::charges(model, p));
  REQUIRE(r.has_position());
  CHECK((r.flags & flag::scaling_assumed) != 0);
  CHECK((r.flags & flag::force_extrapolated) != 0);
  double force_error = 0;
  const double error = nearest_answer_error(r, p, &force_error);
  CHECK(force_error < 1e-3);
  CHECK(error < 0.05e-3);
  // At the map's own level the law is not needed: no flag (with the default range, which for
  // a one-level map is half to twice its level, as for any map).
  const Locator plain(map);
  const Press at_level{-0.0071, 0.0123, 1.0};
  const Location s = plain.locate(pvdf_test::charges(model, at_level));
  REQUIRE(s.has_position());
  CHECK((s.flags & (flag::scaling_assumed | flag::force_extrapolated)) == 0);
  // The default range ends at twice the level: a press at 2.7 N is not accepted there.
  const Location far = plain.locate(pvdf_test::charges(model, p));
  if (far.has_position()) CHECK(far.force_N <= 2.0 * (1 + 1e-9));
}

TEST_CASE("calibration stored in the map is applied to measured charges", "[mapping][locator]") {
  SyntheticModel model = skewed_model();
  ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, levels, 0.05e-12);
  map.calibration = Calibration{{1.25, 0.8, 1.1}, {2e-12, -1e-12, 0.5e-12}, "test", "{}"};
  const Locator calibrated(map);
  const Press p{0.0021, 0.0152, 0.9};
  auto q = pvdf_test::charges(model, p);
  for (std::size_t k = 0; k < 3; ++k) q[k] = map.calibration->gain[k] * q[k] + map.calibration->offset_C[k];
  const Location r = calibrated.locate(q);
  REQUIRE(r.has_position());
  CHECK(std::hypot(r.x_m - p.x_m, r.y_m - p.y_m) < 0.05e-3);
  CHECK(std::abs(r.force_N - p.force_N) / p.force_N < 0.005);
  LocatorOptions raw;
  raw.use_calibration = false;
  const Location u = Locator(map, raw).locate(q);
  CHECK((!u.has_position() || std::hypot(u.x_m - p.x_m, u.y_m - p.y_m) > 0.5e-3));
}

TEST_CASE("locate is thread-safe: concurrent calls give the sequential answers", "[mapping][locator]") {
  const SyntheticModel model = skewed_model();
  const Locator locator(build_synthetic_map(model, 1e-3, 3e-3, levels, 0.05e-12));
  const auto presses = pvdf_test::random_presses(200, 0.03, 0.5, 2.0, 9);
  std::vector<Location> seq(presses.size()), par(presses.size());
  for (std::size_t i = 0; i < presses.size(); ++i) seq[i] = locator.locate(pvdf_test::charges(model, presses[i]));
  auto work = [&](std::size_t first) {
    for (std::size_t i = first; i < presses.size(); i += 2) par[i] = locator.locate(pvdf_test::charges(model, presses[i]));
  };
  std::thread a(work, 0), b(work, 1);
  a.join();
  b.join();
  for (std::size_t i = 0; i < presses.size(); ++i) {
    CHECK(par[i].x_m == seq[i].x_m);
    CHECK(par[i].force_N == seq[i].force_N);
  }
}

TEST_CASE("bad locator input is refused with a message", "[mapping][locator]") {
  SyntheticModel two;
  two.names = {"A", "B"};
  two.centers_m = {{0.0, 0.01}, {0.0, -0.01}};
  CHECK_THROWS_AS(Locator(build_synthetic_map(two, 3e-3, 3e-3, {1.0}, 1e-13)), pvdf::InputError);
  const ChargeMap map = build_synthetic_map(SyntheticModel{}, 3e-3, 3e-3, {1.0}, 1e-13);
  LocatorOptions o;
  o.noise_C = {1e-13, 1e-13};
  CHECK_THROWS_WITH(Locator(map, o), Catch::Contains("noise_C"));
  o.noise_C = {-1.0};
  CHECK_THROWS_AS(Locator(map, o), pvdf::InputError);
}

TEST_CASE("locate_from fits only its starts: from the lookup's answers it reproduces them, and says no more than "
          "it was given",
          "[mapping][locator]") {
  const SyntheticModel model = skewed_model();
  const ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, levels, 0.05e-12);
  LocatorOptions options;
  options.min_force_N = levels.front();
  options.max_force_N = levels.back();
  const Locator locator(map, options);
  // Two fits of one solution from different starts agree to within their convergence
  // tolerance, which is loose along a weakly determined direction (near a fold: measured up to
  // 5e-3 cell there): within a tenth of the reported σ, plus 1e-3 cell (the map's own
  // interpolation error).
  const double cell = 1e-3;
  auto answers = [](const Location& r) {
    std::vector<Location::Alternative> a{{r.x_m, r.y_m, r.force_N, r.residual, r.sigma_x_m, r.sigma_y_m, r.sigma_F_N}};
    for (int k = 0; k < r.n_alternatives; ++k) a.push_back(r.alternatives[std::size_t(k)]);
    return a;
  };
  auto same_solution = [&](const Location::Alternative& a, const Location::Alternative& b) {
    return std::abs(a.x_m - b.x_m) < 0.1 * std::max(a.sigma_x_m, b.sigma_x_m) + 1e-3 * cell &&
           std::abs(a.y_m - b.y_m) < 0.1 * std::max(a.sigma_y_m, b.sigma_y_m) + 1e-3 * cell &&
           std::abs(a.force_N - b.force_N) < 0.1 * std::max(a.sigma_F_N, b.sigma_F_N) + 5e-4 * a.force_N;
  };
  auto contains = [&](const std::vector<Location::Alternative>& set, const Location::Alternative& s) {
    for (const auto& e : set) {
      if (same_solution(e, s)) return true;
    }
    return false;
  };
  const auto presses = pvdf_test::random_presses(300, 0.015, 0.3, 3.0, 11);
  int n_compared = 0, n_same = 0, n_ambiguous = 0, n_single = 0;
  for (const auto& p : presses) {
    std::array<double, 3> q{};
    for (std::size_t k = 0; k < 3; ++k) q[k] = model.charge_C(p.x_m, p.y_m, p.force_N, k);
    const Location r = locator.locate(q.data());
    REQUIRE(r.has_position());
    if (r.n_solutions > 4) continue;  // only four are reported: the others cannot be started from
    const auto solutions = answers(r);
    std::vector<std::array<double, 3>> starts;
    for (const auto& a : solutions) starts.push_back({a.x_m, a.y_m, a.force_N});
    ++n_compared;
    // Started at every reported solution: the same solutions and flags (which of two exact,
    // noise-free solutions is called "best" may swap: both χ² are at rounding level).
    const Location f = locator.locate_from(q.data(), starts.data(), int(starts.size()));
    const auto found = answers(f);
    bool same = f.flags == r.flags && f.n_solutions == r.n_solutions && found.size() == solutions.size();
    for (const auto& s : solutions) same = same && contains(found, s);
    n_same += same ? 1 : 0;
    // Started at one of them only: that one, and no claim of an ambiguity it cannot know about.
    if (r.flags & flag::ambiguous) {
      ++n_ambiguous;
      const Location one = locator.locate_from(q.data(), &starts[1], 1);
      n_single += one.has_position() && !(one.flags & flag::ambiguous) && one.n_solutions == 1 &&
                          same_solution(solutions[1], answers(one)[0])
                      ? 1
                      : 0;
    }
  }
  INFO(n_same << " of " << n_compared << " reproduced; " << n_single << " of " << n_ambiguous
              << " ambiguous presses reported as one solution from one start");
  CHECK(n_compared > 250);
  CHECK(n_same == n_compared);
  CHECK(n_ambiguous > 0);
  CHECK(n_single == n_ambiguous);

  // Nothing to fit from: starts off the map or with no force, or none at all → outside_map.
  std::array<double, 3> q{};
  for (std::size_t k = 0; k < 3; ++k) q[k] = model.charge_C(0.002, 0.003, 1.0, k);
  const std::array<std::array<double, 3>, 3> bad{{{0.5, 0.0, 1.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, -1.0}}};
  for (int n = 0; n <= 3; ++n) {
    const Location r = locator.locate_from(q.data(), bad.data(), n);
    CHECK(r.flags == flag::outside_map);
    CHECK(!r.has_position());
    CHECK(r.n_starts == 0);
  }
  // Charges at the noise level stay no_press, whatever the starts.
  const std::array<double, 3> quiet{1e-16, -1e-16, 0.0};
  const std::array<double, 3> good{0.002, 0.003, 1.0};
  CHECK((locator.locate_from(quiet.data(), &good, 1).flags & flag::no_press) != 0);
}

TEST_CASE("the map's own charge error widens the reported sigma, and only where it is stored", "[mapping][locator]") {
  // Oracle: with the force known and every electrode's map error e = 3 σ_noise at the press,
  // the reported σ's scale by √(1 + 3²) (the fit itself is unchanged; the widened σ's use the
  // Jacobian at the end point, the plain ones the fit's last evaluated one: 1 % allowed).
  // (The interpolation error the Locator estimates itself, §1.10, is off here: it would add
  // its own share to both.)
  const SyntheticModel model;
  ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, {1.0}, 0.05e-12);
  const pvdf_test::Press p{0.0031, -0.0017, 1.0};
  const auto q = pvdf_test::charges(model, p);
  LocatorOptions node_estimate_only;
  node_estimate_only.interpolation_error = false;
  const Locator plain(map, node_estimate_only);
  const Location a = plain.locate(q, 1.0);
  map.estimated_charge_error_C.assign(map.charge_C.size(), 3.0 * 0.05e-12);
  const Locator widened(map, node_estimate_only);
  const Location b = widened.locate(q, 1.0);
  REQUIRE(a.has_position());
  REQUIRE(b.has_position());
  CHECK(b.x_m == a.x_m);
  CHECK(b.y_m == a.y_m);
  CHECK(b.sigma_x_m == Approx(std::sqrt(10.0) * a.sigma_x_m).epsilon(1e-2));
  CHECK(b.sigma_y_m == Approx(std::sqrt(10.0) * a.sigma_y_m).epsilon(1e-2));
  // And the answer says how much of its σ that error is: e²/(σ² + e²) = 9/10 at every electrode,
  // none without it.
  CHECK(a.map_error_share == 0.0);
  CHECK(b.map_error_share == Approx(0.9).epsilon(1e-3));
  // A wrong size is refused.
  map.estimated_charge_error_C.resize(3);
  CHECK_THROWS_AS(Locator(map), pvdf::InputError);
}

TEST_CASE("a known-force press the map reproduces only to its own error is not silently replaced by a far twin",
          "[mapping][locator]") {
  // A 4 mm seed-001-like map (one level, 1 N): at (-6, 2) mm the map's interpolation error
  // (~0.7 pC) is far above the 0.05 pC noise, so with the force known the true position's fit
  // misses the χ² limit while a press 3.7 mm away fits within noise — without a map error
  // estimate the lookup then answers the far press flagged `ok` (the silent twin). With the
  // map's own error stored (here: the interpolation error against the analytic model, the
  // oracle, taken at the cell centres around each node), the true press is among the answers.
  const SyntheticModel model;
  ChargeMap map = build_synthetic_map(model, 4e-3, 3e-3, {1.0}, 0.05e-12);
  const pvdf_test::Press truth{-0.006, 0.002, 1.0};
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.05e-12);
  auto count = [&](const Locator& locator, int& silent_far, int& among) {
    silent_far = among = 0;
    std::mt19937 draws(2);
    for (int i = 0; i < 100; ++i) {
      auto q = pvdf_test::charges(model, truth);
      for (double& v : q) v += noise(draws);
      const Location r = locator.locate(q, 1.0);
      double nearest = std::hypot(r.x_m - truth.x_m, r.y_m - truth.y_m);
      for (int a = 0; a < r.n_alternatives; ++a) {
        nearest = std::min(nearest, std::hypot(r.alternatives[std::size_t(a)].x_m - truth.x_m,
                                               r.alternatives[std::size_t(a)].y_m - truth.y_m));
      }
      among += r.has_position() && nearest < 1e-3;
      silent_far += r.has_position() && r.flags == 0 && nearest >= 1e-3;
    }
  };
  LocatorOptions node_estimate_only;  // no interpolation error estimated by the Locator (§1.10)
  node_estimate_only.interpolation_error = false;
  int silent_before = 0, among_before = 0;
  count(Locator(map, node_estimate_only), silent_before, among_before);
  INFO("without the map's error: " << silent_before << " of 100 silently far, truth among the answers " << among_before);
  CHECK(silent_before > 0);  // the failure this test is about exists
  // The Locator's own estimate of the interpolation error, from the map's nodes alone (§1.10).
  int silent_estimated = 0, among_estimated = 0;
  count(Locator(map), silent_estimated, among_estimated);
  INFO("with the estimated interpolation error: " << silent_estimated << " silently far, truth among the answers "
                                                 << among_estimated);
  CHECK(silent_estimated == 0);
  CHECK(among_estimated >= 95);
  // The map's error per node: the largest |interpolant − model| at the centres of its cells.
  const MapInterpolant interp(map);
  map.estimated_charge_error_C.assign(map.charge_C.size(), 0.0);
  for (std::size_t j = 0; j + 1 < map.ny(); ++j) {
    for (std::size_t i = 0; i + 1 < map.nx(); ++i) {
      if (!interp.cell_usable(i, j)) continue;
      const double xc = 0.5 * (map.x_m[i] + map.x_m[i + 1]), yc = 0.5 * (map.y_m[j] + map.y_m[j + 1]);
      std::array<double, max_electrodes> q{};
      REQUIRE(interp.evaluate(xc, yc, 0.0, q.data(), nullptr));
      for (std::size_t k = 0; k < map.ne(); ++k) {
        const double e = std::abs(q[k] - model.charge_C(xc, yc, 1.0, k));
        for (std::size_t b = 0; b < 2; ++b) {
          for (std::size_t a = 0; a < 2; ++a) {
            double& node = map.estimated_charge_error_C[map.charge_index(0, j + b, i + a, k)];
            node = std::max(node, e);
          }
        }
      }
    }
  }
  int silent_after = 0, among_after = 0;
  count(Locator(map, node_estimate_only), silent_after, among_after);
  INFO("with the map's error: " << silent_after << " silently far, truth among the answers " << among_after);
  CHECK(silent_after == 0);
  CHECK(among_after >= 95);
}

TEST_CASE("the ambiguous share of a film and its remedies", "[mapping][locator][ambiguity]") {
  // Oracle: docs/lookup.md §2's measurement on the synthetic seed-001 map — most presses are
  // ambiguous with the force unknown; a force reading removes most of it; a ±25 % force range
  // lies between. Independent count: the same nodes located one by one here.
  const SyntheticModel model;
  const ChargeMap map = build_synthetic_map(model, 2e-3, 3e-3, {0.5, 1.0, 2.0}, 0.05e-12);
  const AmbiguityShare a = ambiguity_share(map);
  INFO("nodes " << a.nodes << ": unknown " << a.force_unknown << ", known " << a.force_known << ", +-25 % "
                << a.force_within_25);
  CHECK(a.nodes > 500);
  CHECK(a.force_N == 1.0);
  CHECK(a.force_unknown > 0.5);
  CHECK(a.force_known < 0.5 * a.force_unknown);
  CHECK(a.force_within_25 <= a.force_unknown);
  const Locator locator(map);
  std::size_t n = 0, ambiguous = 0;
  for (std::size_t j = 0; j < map.ny(); ++j) {
    for (std::size_t i = 0; i < map.nx(); ++i) {
      if (!locator.interpolant().node_usable(i, j)) continue;
      std::vector<double> q(3);
      for (std::size_t k = 0; k < 3; ++k) q[k] = map.charge_C[map.charge_index(1, j, i, k)];
      const Location r = locator.locate(q);
      if (!r.has_position()) continue;
      ++n;
      ambiguous += r.n_solutions > 1;
    }
  }
  CHECK(n == a.nodes);
  CHECK(double(ambiguous) / double(n) == Approx(a.force_unknown));
}
