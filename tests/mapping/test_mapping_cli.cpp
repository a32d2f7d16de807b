// End-to-end: `pvdfkit locate` and `pvdfkit calibrate` on a synthetic map — exit codes (0, 2
// bad input, 3 no position), JSON and CSV contracts, line-numbered stream warnings.
#include "../app/cli_runner.hpp"
#include "fixture.hpp"

#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

using pvdf::test::run_pvdfkit;
using namespace pvdf::mapping;

namespace {

std::string dir() {
  const auto d = std::filesystem::temp_directory_path() / "pvdf_test_mapping_cli";
  std::filesystem::create_directories(d);
  return d.string();
}

SyntheticModel model() {
  SyntheticModel m;
  m.force_skew = 0.05;
  return m;
}

const std::string& map_path() {
  static const std::string path = [] {
    const std::string p = dir() + "/map.h5";
    write_map(p, build_synthetic_map(model(), 1e-3, 3e-3, {0.25, 0.5, 1.0, 2.0, 4.0}, 0.05e-12));
    return p;
  }();
  return path;
}

std::string charges_arg(const pvdf_test::Press& p) {
  const auto q = pvdf_test::charges(model(), p);
  char buf[128];
  std::snprintf(buf, sizeof buf, "%.12g,%.12g,%.12g", q[0], q[1], q[2]);
  return buf;
}

}  // namespace

TEST_CASE("locate one press: JSON with position, uncertainty and flags", "[mapping][cli]") {
  const pvdf_test::Press p{0.0031, -0.0024, 1.0};
  const auto r = run_pvdfkit("locate " + map_path() + " --charges-C " + charges_arg(p) + " --force-N 1 --json");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j["x_m"].get<double>() == Approx(p.x_m).margin(5e-5));
  CHECK(j["y_m"].get<double>() == Approx(p.y_m).margin(5e-5));
  CHECK(j["sigma_x_m"].get<double>() > 0);
  CHECK(j["flags"].is_array());
}

TEST_CASE("locate exits 3 for no press and for charges outside the map, 2 for bad input", "[mapping][cli]") {
  auto r = run_pvdfkit("locate " + map_path() + " --charges-C 1e-16,-1e-16,1e-16");
  CHECK(r.exit_code == 3);
  CHECK(r.out.find("no_press") != std::string::npos);
  r = run_pvdfkit("locate " + map_path() + " --charges-C 2e-10,5e-13,5e-13 --json");
  CHECK(r.exit_code == 3);
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j["flags"][0] == "outside_map");
  CHECK_FALSE(j.contains("x_m"));  // never printed as a result
  r = run_pvdfkit("locate " + map_path() + " --charges-C 1e-11,2e-11");
  CHECK(r.exit_code == 2);
  CHECK(r.err.rfind("error: ", 0) == 0);
  r = run_pvdfkit("locate " + dir() + "/missing.h5 --charges-C 1e-11,2e-11,3e-11");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("missing.h5") != std::string::npos);
  r = run_pvdfkit("locate " + map_path() + " --charges-C 1e-11,2e-11,3e-11 --noise-C -1");
  CHECK(r.exit_code == 2);
}

TEST_CASE("locate streams CSV rows, skipping malformed ones by line number or refusing with --strict", "[mapping][cli]") {
  const std::string input = dir() + "/presses.csv";
  {
    std::ofstream out(input);
    out << "t_s,charge_A_C,charge_B_C,charge_C_C\n";
    out << "0.0001," << charges_arg({0.002, 0.004, 1.2}) << "\n";
    out << "0.0002,oops,1e-11,1e-11\n";
    out << "0.0003," << charges_arg({-0.003, 0.001, 0.8}) << "\n";
  }
  auto r = run_pvdfkit("locate " + map_path() + " --input " + input);
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(pvdf::test::line_count(r.out) == 3);  // header + 2 rows
  CHECK(r.out.rfind("t_s,x_m,y_m,force_N,residual,sigma_x_m,sigma_y_m,sigma_F_N,flags", 0) == 0);
  CHECK(r.err.find("presses.csv:3:") != std::string::npos);
  r = run_pvdfkit("locate " + map_path() + " --input " + input + " --strict");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("presses.csv:3:") != std::string::npos);
}

TEST_CASE("calibrate writes a calibrated map that locate uses", "[mapping][cli]") {
  const std::string measured = dir() + "/measured.csv", calibrated = dir() + "/cal.h5";
  const double gain[3] = {1.2, 0.85, 1.05}, offset[3] = {1.5e-12, -0.8e-12, 0.3e-12};
  {
    std::ofstream out(measured);
    out << "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n";
    out.precision(12);
    for (const auto& p : pvdf_test::random_presses(20, 0.015, 0.5, 2.0, 41)) {
      const auto q = pvdf_test::charges(model(), p);
      out << p.x_m << ',' << p.y_m << ',' << p.force_N;
      for (int k = 0; k < 3; ++k) out << ',' << gain[k] * q[std::size_t(k)] + offset[k];
      out << '\n';
    }
  }
  auto r = run_pvdfkit("calibrate " + map_path() + " " + measured + " -o " + calibrated + " --json");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j["gain"][0].get<double>() == Approx(1.2).epsilon(1e-3));
  // Locate a measured (gain/offset-distorted) press with the calibrated map.
  const pvdf_test::Press p{0.0042, 0.0013, 1.0};
  const auto q = pvdf_test::charges(model(), p);
  char arg[128];
  std::snprintf(arg, sizeof arg, "%.12g,%.12g,%.12g", gain[0] * q[0] + offset[0], gain[1] * q[1] + offset[1],
                gain[2] * q[2] + offset[2]);
  r = run_pvdfkit("locate " + calibrated + " --charges-C " + arg + " --force-N 1 --json");
  REQUIRE(r.exit_code == 0);
  const auto k = nlohmann::json::parse(r.out);
  CHECK(k["calibrated"] == true);
  CHECK(k["x_m"].get<double>() == Approx(p.x_m).margin(1e-4));
  CHECK(k["y_m"].get<double>() == Approx(p.y_m).margin(1e-4));
  // A measurement file with a bad row is refused naming the line.
  {
    std::ofstream out(measured, std::ios::app);
    out << "0.001,zz,1,1,1,1\n";
  }
  r = run_pvdfkit("calibrate " + map_path() + " " + measured + " -o " + calibrated);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("measured.csv:22") != std::string::npos);
}

TEST_CASE("lookup-accuracy reports lookup and triangulation errors growing with noise", "[mapping][cli]") {
  const auto r = run_pvdfkit("lookup-accuracy " + map_path() + " --presses 60 --noise-C 0.01e-12,1e-12 --json");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  REQUIRE(j["rows"].size() == 2);
  const auto& quiet = j["rows"][0];
  const auto& noisy = j["rows"][1];
  CHECK(noisy["median_error_force_known_m"].get<double>() > 10 * quiet["median_error_force_known_m"].get<double>());
  CHECK(quiet["median_error_triangulation_m"].get<double>() > 10 * quiet["median_error_force_known_m"].get<double>());
  CHECK(run_pvdfkit("lookup-accuracy " + map_path() + " --noise-C -1").exit_code == 2);
}
