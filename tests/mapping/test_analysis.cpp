// Map analyses against exact oracles: the ray fit of seed 001 eq. 6 recovers a pure power law
// (and its cos²β + r·sin²β angle factor) sampled into a map; the FEM-vs-measurement comparison
// gives exactly 10 % for charges 1.1× the map's; malformed measurement files are refused by line.
#include "fixture.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/mapping/analysis.hpp"
#include "pvdf/mapping/interpolant.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/pictures.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

using namespace pvdf::mapping;

namespace {

std::string temp_file(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() / "pvdf_test_analysis";
  std::filesystem::create_directories(d);
  return (d / name).string();
}

/// The model of synthetic.hpp reduced to a pure power law around each electrode:
/// core → 0, no rim term, isotropic distance; Q = scale·F^(2/3)·P(β)·d^−exponent with
/// P = cos²β + r·sin²β (r = d32_over_d31; r = 1 gives P = 1).
SyntheticModel power_law_model(double exponent, double r) {
  SyntheticModel m;
  m.core_m = 1e-9;  // finite at the electrode node, negligible (1e-9 m) at d ≥ 3 mm
  m.rim_strength = 0.0;
  m.anisotropy = 1.0;
  m.d32_over_d31 = r;
  m.exponent = exponent;
  m.draw_angle_rad = 0.3;  // the fit must measure β from the draw direction, not from x
  return m;
}

}  // namespace

TEST_CASE("power-law fit is exact on exact data and refuses too few points", "[mapping][analysis]") {
  std::vector<double> x, y;
  for (double v : {0.5, 1.0, 2.0, 7.0}) {
    x.push_back(v);
    y.push_back(3.0 * std::pow(v / 2.0, -0.7));
  }
  const PowerLawFit f = fit_power_law(x, y, 2.0);
  CHECK(f.C2 == Approx(-0.7).epsilon(1e-12));
  CHECK(f.C1 == Approx(3.0).epsilon(1e-12));
  CHECK(f.r_squared == Approx(1.0).epsilon(1e-12));
  CHECK(f.n_used == 4);
  // Non-positive values are skipped, not logged.
  x.push_back(3.0);
  y.push_back(-1.0);
  CHECK(fit_power_law(x, y, 2.0).n_used == 4);
  CHECK_THROWS_AS(fit_power_law({1.0}, {1.0}, 1.0), pvdf::InputError);
  CHECK_THROWS_AS(fit_power_law({1.0, 1.0}, {1.0, 2.0}, 1.0), pvdf::InputError);
}

TEST_CASE("rays on a pure power-law map recover the exponent and C1(beta)", "[mapping][analysis]") {
  const double exponent = 0.8, r = 0.1;
  const SyntheticModel model = power_law_model(exponent, r);
  const ChargeMap map = build_synthetic_map(model, 0.5e-3, 3e-3, {1.0}, 0.05e-12);
  const MapInterpolant interpolant(map);
  RayOptions o;  // defaults: 10°, 3..20 mm, 24 samples, 1 N
  const RayAnalysis a = analyse_rays(map, interpolant, o);
  CHECK(a.draw_angle_rad == Approx(0.3));
  REQUIRE(a.rays.size() == 3 * 36);
  REQUIRE(a.electrodes.size() == 3);
  for (const auto& ray : a.rays) {
    INFO("electrode " << ray.electrode << " beta " << ray.beta_deg);
    REQUIRE(ray.fitted);
    CHECK(ray.n_used == 24);
    CHECK(ray.C2 == Approx(-exponent).margin(1e-3));
    const double b = ray.beta_deg * pvdf::pi / 180;
    // Oracle: Q = scale·P(β)·d^−0.8 with d in m; at d = 1 mm this is C1.
    const double c1 = model.scale_C * (std::cos(b) * std::cos(b) + r * std::sin(b) * std::sin(b)) * std::pow(1e-3, -exponent);
    CHECK(ray.C1_C == Approx(c1).epsilon(2e-3));
    CHECK(ray.r_squared > 0.99999);
  }
  for (const auto& s : a.electrodes) {
    CHECK(s.n_fitted == 36);
    CHECK(s.median_decay_exponent == Approx(exponent).margin(1e-3));
    CHECK(s.n_in_paper_range == 36);  // 0.8 lies in 0.58..1.0
  }
}

TEST_CASE("rays leaving the map stop there; too short rays are reported, not fitted", "[mapping][analysis]") {
  const SyntheticModel model = power_law_model(1.0, 1.0);
  const ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, {1.0}, 0.05e-12);
  const MapInterpolant interpolant(map);
  RayOptions o;
  o.d_min_m = 5e-3;  // at 1 mm spacing the node on electrode A (Q ~ 1/1e-9 m) spoils slopes up to 3 mm away
  o.d_max_m = 0.09;  // every ray leaves the 42 mm mapped disk
  o.n_samples = 30;
  const RayAnalysis a = analyse_rays(map, interpolant, o);
  for (const auto& ray : a.rays) {
    for (double d : ray.d_m) {
      const double x = map.electrode_centers_m[ray.electrode][0] + d * std::cos(0.3 + ray.beta_deg * pvdf::pi / 180);
      const double y = map.electrode_centers_m[ray.electrode][1] + d * std::sin(0.3 + ray.beta_deg * pvdf::pi / 180);
      CHECK(std::hypot(x, y) <= 0.042 + 1e-9);
    }
    CHECK(int(ray.d_m.size()) < o.n_samples);
    if (ray.fitted) CHECK(ray.C2 == Approx(-1.0).margin(2e-3));
  }
  o.min_points = 40;  // more than there are samples: nothing fitted, each ray says why
  const RayAnalysis none = analyse_rays(map, interpolant, o);
  for (const auto& ray : none.rays) {
    CHECK_FALSE(ray.fitted);
    CHECK(ray.reason.find("need 40") != std::string::npos);
  }
  o = RayOptions{};
  o.d_min_m = 0;
  CHECK_THROWS_AS(analyse_rays(map, interpolant, o), pvdf::InputError);
  o = RayOptions{};
  o.force_N = -1;
  CHECK_THROWS_AS(analyse_rays(map, interpolant, o), pvdf::InputError);
}

TEST_CASE("compare: measured = 1.1 x map gives +10 % at grid nodes exactly, and nearly between them",
          "[mapping][analysis]") {
  const SyntheticModel model;  // the default, anisotropic, rim-weighted model
  const ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, {0.5, 1.0, 2.0}, 0.05e-12);
  const MapInterpolant interpolant(map);
  const std::string path = temp_file("measured.csv");
  {
    std::ofstream out(path);
    out.precision(17);
    out << "# synthetic measurement: 1.1 x the analytic model\n";
    out << "charge_C_C,x_m,y_m,force_N,charge_A_C,charge_B_C,comment_column\n";
    // grid nodes (exact), off-node points, and one outside the map
    const std::vector<pvdf_test::Press> presses = {{0.004, -0.002, 1.0}, {-0.012, 0.007, 0.5}, {0.0, 0.0, 2.0},
                                                   {0.0031, 0.0047, 1.0}, {-0.0083, -0.0121, 1.3}, {0.0440, 0.0, 1.0}};
    for (const auto& p : presses) {
      const auto q = pvdf_test::charges(model, p);
      out << 1.1 * q[2] << ',' << p.x_m << ',' << p.y_m << ',' << p.force_N << ',' << 1.1 * q[0] << ',' << 1.1 * q[1]
          << ",7\n";
    }
  }
  const auto measured = read_measured_csv(path, map.electrode_names);
  REQUIRE(measured.size() == 6);
  CHECK(measured[0].line == 3);
  CHECK(measured[0].charge_C[2] > 0);
  const Comparison c = compare_with_map(map, interpolant, measured);
  CHECK(c.n_presses == 6);
  CHECK(c.n_outside == 1);
  CHECK_FALSE(c.presses[5].in_map);
  CHECK(std::isnan(c.presses[5].difference_pct[0]));
  for (std::size_t i = 0; i < 3; ++i) {  // grid nodes: the interpolant returns node values
    for (std::size_t k = 0; k < 3; ++k) CHECK(c.presses[i].difference_pct[k] == Approx(10.0).epsilon(1e-10));
  }
  for (std::size_t i = 3; i < 5; ++i) {  // between nodes: the interpolation error is ~1e-3 here
    for (std::size_t k = 0; k < 3; ++k) CHECK(c.presses[i].difference_pct[k] == Approx(10.0).margin(0.3));
  }
  CHECK(c.n_compared_values == 15);
  CHECK(c.mean_abs_difference_pct == Approx(10.0).margin(0.1));
  CHECK(c.mean_difference_pct == Approx(10.0).margin(0.1));
  CHECK(c.presses[4].force_extrapolated == false);
  for (const auto& s : c.electrodes) CHECK(s.rms_difference_pct == Approx(10.0).margin(0.1));

  // A figure of the comparison can be drawn.
  const std::string png = temp_file("compare.png");
  write_comparison_png(c, png);
  CHECK(std::filesystem::file_size(png) > 1000);
}

TEST_CASE("compare: signed differences of opposite errors cancel in the mean, not in the mean |diff|",
          "[mapping][analysis]") {
  const SyntheticModel model;
  const ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, {1.0}, 0.05e-12);
  const MapInterpolant interpolant(map);
  std::vector<MeasuredPress> m;
  for (double f : {0.8, 1.2}) {
    MeasuredPress p{0.005, 0.001, 1.0, {}, 0};
    for (std::size_t k = 0; k < 3; ++k) p.charge_C.push_back(f * model.charge_C(p.x_m, p.y_m, 1.0, k));
    m.push_back(p);
  }
  const Comparison c = compare_with_map(map, interpolant, m);
  CHECK(c.mean_abs_difference_pct == Approx(20.0).epsilon(1e-10));
  CHECK(c.mean_difference_pct == Approx(0.0).margin(1e-9));
  // Force outside the levels: compared through the F^(2/3) law and flagged.
  m[0].force_N = 3.0;
  for (std::size_t k = 0; k < 3; ++k) m[0].charge_C[k] = model.charge_C(m[0].x_m, m[0].y_m, 3.0, k);
  const Comparison e = compare_with_map(map, interpolant, m);
  CHECK(e.presses[0].force_extrapolated);
  CHECK(e.n_force_extrapolated == 1);
  CHECK(e.presses[0].difference_pct[0] == Approx(0.0).margin(1e-8));  // the default model has Q ∝ F^(2/3) exactly
}

TEST_CASE("measured CSV: a missing column or a bad row is refused with its name or line", "[mapping][analysis]") {
  const std::vector<std::string> names{"A", "B", "C"};
  auto write = [](const std::string& name, const std::string& text) {
    const std::string p = temp_file(name);
    std::ofstream(p) << text;
    return p;
  };
  auto message = [&](const std::string& path) {
    try {
      read_measured_csv(path, names);
    } catch (const pvdf::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string missing = write("missing.csv", "x_m,y_m,force_N,charge_A_C,charge_C_C\n0,0,1,1e-12,1e-12\n");
  CHECK(message(missing).find("missing column 'charge_B_C'") != std::string::npos);
  const std::string no_force = write("noforce.csv", "x_m,y_m,charge_A_C,charge_B_C,charge_C_C\n0,0,1e-12,1e-12,1e-12\n");
  CHECK(message(no_force).find("'force_N'") != std::string::npos);
  const std::string text = write("text.csv", "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n0,0,1,1e-12,1e-12,1e-12\n"
                                             "# a comment\n0.001,0,1,abc,1e-12,1e-12\n");
  CHECK(message(text).find(":4:") != std::string::npos);
  const std::string short_row = write("short.csv", "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n0,0,1,1e-12,1e-12\n");
  CHECK(message(short_row).find(":2:") != std::string::npos);
  const std::string zero_force = write("zero.csv", "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n0,0,0,1e-12,1e-12,1e-12\n");
  CHECK(message(zero_force).find(":2: force_N") != std::string::npos);
  const std::string empty = write("empty.csv", "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n");
  CHECK(message(empty).find("no data rows") != std::string::npos);
  CHECK(message(temp_file("does-not-exist.csv")).find("cannot open") != std::string::npos);
}

TEST_CASE("pictures of the analyses are written", "[mapping][analysis]") {
  const SyntheticModel model;
  const ChargeMap map = build_synthetic_map(model, 1e-3, 3e-3, {1.0}, 0.05e-12);
  const MapInterpolant interpolant(map);
  RayOptions o;
  o.beta_deg = {45, 65, 85};  // seed 001 Fig. 12's angles
  const RayAnalysis a = analyse_rays(map, interpolant, o);
  REQUIRE(a.rays.size() == 9);
  CHECK(a.rays[1].beta_deg == 65);
  const std::string png = temp_file("rays.png");
  std::vector<MeasuredPress> m{{map.electrode_centers_m[1][0] + 0.005 * std::cos(pvdf::pi / 4),
                                map.electrode_centers_m[1][1] + 0.005 * std::sin(pvdf::pi / 4), 1.0, {1e-12, 2e-12, 3e-12}, 2}};
  write_rays_png(a, map, 1, {45, 65, 85}, &m, 2.0, png);
  CHECK(std::filesystem::file_size(png) > 1000);
  CHECK_THROWS_AS(write_rays_png(a, map, 1, {7.0}, nullptr, 2.0, png), pvdf::InputError);  // no such ray
  const Locator locator(map);
  const std::string all = temp_file("all.png");
  write_isocharge_overlay_png(locator, map, 1.0, all, 0.015);
  CHECK(std::filesystem::file_size(all) > 1000);
}
